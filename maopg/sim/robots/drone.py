"""Water Filling's quadrotor scout: a free body flown by four rotor thrusts.

Control is a cascade run at ``control_hz`` (the scene calls :meth:`DroneAdapter.apply`):

1. position -> velocity: toward the target at ``min(speed, kp*d, sqrt(2*a_brake*d))`` so it
   cruises at the commanded speed and brakes smoothly onto the target (no overshoot);
2. velocity -> acceleration: the horizontal velocity reference ``v_ref`` follows ``v_des`` at
   most at ``accel`` (m/s^2); ``a = dv_ref/dt + kv * (v_ref - v)`` (feed-forward + feedback,
   which keeps the speed overshoot from the attitude lag near 10%), capped so the tilt stays below
   ``max_tilt``, plus gravity compensation;
3. acceleration -> attitude: the body z axis must point along ``a`` (a quadrotor can only push
   along z); collective thrust ``m * a . z_body``;
4. attitude PD, tilt and yaw decoupled: angular accelerations ``k_p e_tilt - k_d w`` with the
   tilt error the rotation taking the body z axis onto the desired one, and a yaw PD; torque =
   the body-frame inertia times them, the yaw torque capped (below);
5. mixing: the thrust + torque wrench is mapped to the rotor forces by the inverse of the
   matrix built from the rotor sites and actuator gears in the compiled model. A layout that
   cannot produce all four (say, rotors without drag torque: no yaw) is rejected when the
   adapter binds, naming what is missing, instead of silently ignoring those commands.

Every gain is in units that do not depend on the airframe (speeds, accelerations, angular
accelerations), and the adapter scales them by what it reads from the compiled model: the
mass and the inertia of the root body's whole subtree (about its centre of mass, in the root
body's frame), the rotor layout, gears and ``ctrlrange``. So a quadrotor of another size flies
with the same constants. The one torque limit, the yaw cap, is the smaller of
``max_yaw_accel`` times the yaw inertia and ``yaw_share`` of the yaw torque the rotors can add
at hover without leaving their ``ctrlrange``: rotor drag torques are weak, and an uncapped yaw
command saturates the rotors and steals the thrust differential that roll and pitch need.

Everything inside ``apply()`` is plain float arithmetic: it runs ~50 times per 0.5 s tick.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco
import numpy as np

from maopg.sim.robots import base

WRENCH_AXES = ("thrust", "roll torque", "pitch torque", "yaw torque")
"""The body wrench the mixer maps onto rotor forces, in its row order."""


@dataclass(frozen=True)
class DroneConstants:
    """Speeds and gains of the quadrotor (the one place they are set)."""

    max_speed: float = 2.0  # m/s cruise (docs/DESIGN.md §7: the fast robot)
    max_climb: float = 1.0  # m/s vertical speed cap
    #: Position loop: target speed = min(speed, pos_kp * d, sqrt(2 * brake_accel * d)).
    pos_kp: float = 2.0
    brake_accel: float = 2.5  # m/s^2
    #: Velocity loop: desired acceleration = vel_kp * (v_des - v) (1/s).
    vel_kp: float = 2.0
    accel: float = 2.5  # m/s^2: how fast the horizontal velocity reference may change
    vel_kp_z: float = 6.0
    max_tilt: float = 0.45  # rad: caps horizontal acceleration at g * tan(max_tilt)
    #: Tilt PD, in angular acceleration units (scaled by the inertia): wn ~ 17 rad/s, zeta ~ 0.9.
    att_kp: float = 300.0
    att_kd: float = 32.0
    yaw_kp: float = 20.0
    yaw_kd: float = 7.0
    #: Yaw angular acceleration cap (rad/s^2), times the model's yaw inertia: the yaw torque
    #: cap (module docstring); 0.04 N m on the shipped drone's 0.022 kg m^2.
    max_yaw_accel: float = 0.04 / 0.022
    #: The largest share of the rotors' yaw torque at hover the yaw command may take (the
    #: rest of their range is left for roll and pitch).
    yaw_share: float = 0.5
    #: Face the direction of travel when a target is farther than this horizontally (m).
    face_travel_min: float = 0.5
    #: Rotor actuator names in the MJCF, in mixer order.
    rotors: tuple[str, ...] = ("rotor_fl", "rotor_fr", "rotor_rl", "rotor_rr")


def subtree_inertia(model: mujoco.MjModel, root: int) -> tuple[np.ndarray, np.ndarray]:
    """Centre of mass (3,) and inertia (3, 3) about it of body ``root`` and every body below
    it, in ``root``'s frame, with the joints at ``qpos0``.

    MuJoCo stores each body's principal moments (``body_inertia``) in its inertia frame
    (``body_ipos``, ``body_iquat``); a robot file with a full or rotated inertia has a rotated
    frame, and one with rotors or a gimbal as child bodies spreads its mass over them, so the
    moments are rotated into the root frame and summed with the parallel-axis terms.
    """
    n = model.nbody
    frames: dict[int, tuple[np.ndarray, np.ndarray]] = {root: (np.zeros(3), np.eye(3))}
    for b in range(root + 1, n):  # a parent's id is below its children's
        parent = int(model.body_parentid[b])
        if parent in frames:
            pos, rot = frames[parent]
            frames[b] = (pos + rot @ model.body_pos[b], rot @ _matrix(model.body_quat[b]))
    masses = {b: float(model.body_mass[b]) for b in frames}
    total = sum(masses.values())
    centres = {b: pos + rot @ model.body_ipos[b] for b, (pos, rot) in frames.items()}
    com = sum(masses[b] * centres[b] for b in frames) / total if total > 0 else np.zeros(3)
    inertia = np.zeros((3, 3))
    for b, (_, rot) in frames.items():
        axes = rot @ _matrix(model.body_iquat[b])
        d = centres[b] - com
        inertia += axes @ np.diag(model.body_inertia[b]) @ axes.T
        inertia += masses[b] * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return com, inertia


def _matrix(quat: np.ndarray) -> np.ndarray:
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, quat)
    return rot.reshape(3, 3)


def yaw_sign_advice(rotors: Sequence[str], arms: np.ndarray, yaw: np.ndarray) -> str:
    """What to change in the rotors' drag torques (``gear[5]``) when they cannot yaw the drone.

    ``arms`` (rotors, 3) are the rotor positions from the centre of mass, ``yaw`` each rotor's
    yaw torque per newton. A quadrotor yaws by the drag torques of propellers spinning in
    opposite directions: diagonal rotors must share a sign and adjacent ones have opposite
    signs. Any other pattern is a copy of the roll or pitch column (adjacent rotors share it)
    and leaves one wrench axis out.
    """
    scale = np.abs(yaw).max(initial=0.0)
    if scale < 1e-9:
        return (
            "a quadrotor yaws by the rotors' drag torques: give each rotor actuator a gear[5] "
            "(N m per N), the same sign on diagonal rotors and opposite signs on adjacent ones"
        )
    signs = np.sign(np.where(np.abs(yaw) > 1e-3 * scale, yaw, 0.0))
    if len(rotors) != 4 or not signs.all():
        return "check the rotor positions and the sign and size of each rotor's gear[5]"
    xy = arms[:, :2]
    first = 0
    diagonal = int(np.argmax(np.linalg.norm(xy - xy[first], axis=1)))
    others = [k for k in range(4) if k not in (first, diagonal)]
    if signs[first] == signs[diagonal] and signs[others[0]] == signs[others[1]] != signs[first]:
        return "check the rotor positions and gear[2] (the thrust along the body z axis)"
    now = ", ".join(f"{r} {y:+.3g}" for r, y in zip(rotors, yaw, strict=True))
    want = [signs[first]] * 4
    for k in others:
        want[k] = -signs[first]
    fixed = ", ".join(f"{r} {'+' if w > 0 else '-'}" for r, w in zip(rotors, want, strict=True))
    return (
        f"diagonal rotors ({rotors[first]}/{rotors[diagonal]}, {rotors[others[0]]}/"
        f"{rotors[others[1]]}) spin the same way and adjacent ones opposite ways, so the sign of "
        f"the yaw torque gear[5] must match on a diagonal and differ between the diagonals: now "
        f"{now}; make the signs {fixed}"
    )


class DroneAdapter(base.DroneAdapter):
    """Quadrotor with a cascaded position/attitude controller and a rotor mixer."""

    Constants = DroneConstants
    #: 50 Hz keeps the Python cascade's cost below a fifth of the physics it rides on
    #: (bench/perf/wf_bench.py); the attitude PD is still well damped at that rate.
    control_hz: ClassVar[float | None] = 50.0

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, prefix: str, constants: Any = None
    ) -> None:
        super().__init__(model, data, prefix, constants)
        c = self.constants
        root = self.root_body_id
        if model.body_dofnum[root] != 6:
            raise ValueError(f"drone '{prefix}': root body must have a free joint")
        self._mass = float(model.body_subtreemass[root])
        com, inertia = subtree_inertia(model, root)
        self._com = com
        self._inertia = tuple(tuple(float(v) for v in row) for row in inertia)
        self._gravity = -float(model.opt.gravity[2])
        self._act = [self.actuator_id(n, f"{type(c).__name__}.rotors") for n in c.rotors]
        # an actuator without a ctrlrange is unlimited (MuJoCo leaves the range at 0 0)
        ranges = [
            model.actuator_ctrlrange[a].tolist()
            if model.actuator_ctrllimited[a]
            else [-math.inf, math.inf]
            for a in self._act
        ]
        self._ctrl_lo = [lo for lo, _ in ranges]
        self._ctrl_hi = [hi for _, hi in ranges]
        self._mixer = [tuple(float(v) for v in row) for row in self._mixer_matrix()]
        #: The two bounds of the yaw torque cap (N m), by the constant that sets each
        #: (module docstring); the cap is the smaller.
        self.yaw_torque_bounds = self._yaw_torque_bounds()
        self.yaw_torque_cap = min(self.yaw_torque_bounds.values())
        self._vel = int(model.body_dofadr[root])  # qvel[+0:+3]: world linear; [+3:+6]: body angular
        self.reset()

    @property
    def inertia(self) -> np.ndarray:
        """(3, 3) inertia of the root body's subtree about its centre of mass, in the root
        body's frame (:func:`subtree_inertia`): what the attitude loop scales by."""
        return np.array(self._inertia)

    @property
    def rotor_authority(self) -> float:
        """The yaw torque (N m) the rotors can add at hover, either way, before one of them
        reaches the end of its ``ctrlrange`` (inf for rotors without one)."""
        hover = self._mass * self._gravity
        authority = math.inf
        for k, row in enumerate(self._mixer):
            force, per_torque = row[0] * hover, abs(row[3])
            room = min(self._ctrl_hi[k] - force, force - self._ctrl_lo[k])
            if per_torque > 0.0:
                authority = min(authority, room / per_torque)
        return authority

    def _yaw_torque_bounds(self) -> dict[str, float]:
        """``max_yaw_accel * I_zz`` and ``yaw_share * rotor_authority``; ``ValueError`` when
        the rotors cannot even hover the drone within their ``ctrlrange``."""
        c = self.constants
        hover = self._mass * self._gravity
        for k, (name, row) in enumerate(zip(c.rotors, self._mixer, strict=True)):
            force = row[0] * hover
            if not self._ctrl_lo[k] <= force <= self._ctrl_hi[k]:
                raise ValueError(
                    f"{type(self).__name__} for '{self.prefix}': rotor {name} must push "
                    f"{force:.3g} N to hover the drone's {self._mass:.3g} kg, outside its "
                    f"ctrlrange [{self._ctrl_lo[k]:g}, {self._ctrl_hi[k]:g}]: raise the rotors' "
                    "ctrlrange upper bound (or lighten the model)"
                )
        return {
            "max_yaw_accel": c.max_yaw_accel * self._inertia[2][2],
            "yaw_share": c.yaw_share * self.rotor_authority,
        }

    def _mixer_matrix(self) -> np.ndarray:
        """Inverse of rotor force -> body wrench (thrust z, torque x, y, z about the centre of
        mass), from the model.

        Raises ``ValueError`` when the rotors cannot produce every wrench axis: ``pinv`` would
        return a mixer that silently maps that axis's commands to nothing.
        """
        model = self.model
        wrench = np.zeros((4, len(self._act)))
        arms = np.zeros((len(self._act), 3))
        for j, a in enumerate(self._act):
            if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_SITE:
                raise ValueError(f"drone '{self.prefix}': rotor actuators must act on sites")
            site = model.actuator_trnid[a, 0]
            if model.site_bodyid[site] != self.root_body_id:
                raise ValueError(f"drone '{self.prefix}': rotor sites must be on the root body")
            rot = _matrix(model.site_quat[site])
            gear = model.actuator_gear[a]
            force = rot @ gear[:3]
            arms[j] = model.site_pos[site] - self._com
            torque = np.cross(arms[j], force)
            torque += rot @ gear[3:]
            wrench[:, j] = (force[2], torque[0], torque[1], torque[2])
        mixer = np.linalg.pinv(wrench)
        # (wrench @ mixer)[k, k] is the share of a command on axis k the rotors produce: 1 for
        # an axis they control, less for one they cannot (0 when no rotor acts on it at all).
        reproduced = np.diag(wrench @ mixer)
        missing = [
            axis for axis, share in zip(WRENCH_AXES, reproduced, strict=True) if share < 1.0 - 1e-6
        ]
        if missing:
            raise ValueError(
                f"{type(self).__name__} for '{self.prefix}': rotors "
                f"{', '.join(self.constants.rotors)} cannot produce {' or '.join(missing)} (their "
                f"wrench matrix has rank {np.linalg.matrix_rank(wrench)} of 4); "
                + yaw_sign_advice(self.constants.rotors, arms, wrench[3])
            )
        return mixer

    # --- commands --------------------------------------------------------------------------
    def reset(self) -> None:
        pos = self.data.xpos[self.root_body_id]
        self._target = (float(pos[0]), float(pos[1]), float(pos[2]))
        self._speed = self.constants.max_speed
        self._yaw_target = self.yaw
        v = self._vel
        self._vref = (float(self.data.qvel[v]), float(self.data.qvel[v + 1]))

    def hold(self) -> None:
        self.fly_to(self.data.xpos[self.root_body_id], yaw=self._yaw_target)

    def fly_to(
        self, xyz: Sequence[float], speed: float | None = None, yaw: float | None = None
    ) -> None:
        """Fly toward ``xyz`` at most at ``speed``; face ``yaw`` (default: direction of travel)."""
        c = self.constants
        self._target = (float(xyz[0]), float(xyz[1]), float(xyz[2]))
        self._speed = c.max_speed if speed is None else min(float(speed), c.max_speed)
        if yaw is not None:
            self._yaw_target = float(yaw)
        else:
            pos = self.data.xpos[self.root_body_id]
            dx, dy = self._target[0] - pos[0], self._target[1] - pos[1]
            if math.hypot(dx, dy) > c.face_travel_min:
                self._yaw_target = math.atan2(dy, dx)

    @property
    def velocity(self) -> np.ndarray:
        """(3,) world linear velocity of the body (a copy)."""
        return self.data.qvel[self._vel : self._vel + 3].copy()

    # --- control ---------------------------------------------------------------------------
    def apply(self) -> None:
        c = self.constants
        data = self.data
        # Python floats, read once: arithmetic on numpy scalars costs several times as much,
        # and this runs while other environments' threads wait for the GIL.
        pos = data.xpos[self.root_body_id].tolist()
        v = self._vel
        vx, vy, vz, wx, wy, wz = data.qvel[v : v + 6].tolist()

        # 1. position -> desired velocity (horizontal and vertical shaped separately)
        ex, ey = self._target[0] - pos[0], self._target[1] - pos[1]
        ez = self._target[2] - pos[2]
        dh = math.hypot(ex, ey)
        sh = min(self._speed, c.pos_kp * dh, math.sqrt(2.0 * c.brake_accel * dh))
        vdx, vdy = (ex / dh * sh, ey / dh * sh) if dh > 1e-9 else (0.0, 0.0)
        vdz = max(-c.max_climb, min(c.max_climb, c.pos_kp * ez))

        # 2. velocity -> desired acceleration (tilt-limited), gravity compensated
        dt = self.control_dt
        rx, ry = self._vref
        dx, dy = vdx - rx, vdy - ry
        dn = math.hypot(dx, dy)
        if dn > c.accel * dt:
            dx, dy = dx * c.accel * dt / dn, dy * c.accel * dt / dn
        rx, ry = rx + dx, ry + dy
        self._vref = (rx, ry)
        ax = dx / dt + c.vel_kp * (rx - vx)
        ay = dy / dt + c.vel_kp * (ry - vy)
        az = c.vel_kp_z * (vdz - vz) + self._gravity
        az = max(0.3 * self._gravity, az)
        amax = az * math.tan(c.max_tilt)
        ah = math.hypot(ax, ay)
        if ah > amax:
            ax, ay = ax * amax / ah, ay * amax / ah

        # 3. desired thrust axis z_d along a
        an = math.sqrt(ax * ax + ay * ay + az * az)
        zx, zy, zz = ax / an, ay / an, az / an

        # 4. attitude PD, tilt and yaw decoupled (a full SO(3) error would shrink, even flip,
        # the tilt correction while a large yaw turn is under way): the tilt error is the
        # rotation taking z_body onto z_d, e = R^T (z_b x z_d); yaw is a wrapped heading error.
        r = data.xmat[self.root_body_id].tolist()  # row-major R: columns are body axes in world
        b0, b1, b2 = (r[0], r[3], r[6]), (r[1], r[4], r[7]), (r[2], r[5], r[8])
        cx = b2[1] * zz - b2[2] * zy
        cy = b2[2] * zx - b2[0] * zz
        cz = b2[0] * zy - b2[1] * zx
        ex_b = b0[0] * cx + b0[1] * cy + b0[2] * cz
        ey_b = b1[0] * cx + b1[1] * cy + b1[2] * cz
        yaw_err = base.wrap_angle(self._yaw_target - math.atan2(r[3], r[0]))
        alx = c.att_kp * ex_b - c.att_kd * wx
        aly = c.att_kp * ey_b - c.att_kd * wy
        alz = c.yaw_kp * yaw_err - c.yaw_kd * wz
        (jxx, jxy, jxz), (jyx, jyy, jyz), (jzx, jzy, jzz) = self._inertia
        tx = jxx * alx + jxy * aly + jxz * alz
        ty = jyx * alx + jyy * aly + jyz * alz
        tz = jzx * alx + jzy * aly + jzz * alz
        cap = self.yaw_torque_cap
        tz = max(-cap, min(cap, tz))
        thrust = self._mass * (ax * b2[0] + ay * b2[1] + az * b2[2])

        # 5. mixer: rotor forces from the wrench, clipped to the actuator ranges
        ctrl = data.ctrl
        for k, a in enumerate(self._act):
            m = self._mixer[k]
            f = m[0] * thrust + m[1] * tx + m[2] * ty + m[3] * tz
            ctrl[a] = min(self._ctrl_hi[k], max(self._ctrl_lo[k], f))
