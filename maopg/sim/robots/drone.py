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
   the body-frame inertia (MuJoCo's principal moments rotated by ``body_iquat``) times them,
   the yaw torque capped;
5. mixing: the thrust + torque wrench is mapped to the rotor forces by the inverse of the
   matrix built from the rotor sites and actuator gears in the compiled model. A layout that
   cannot produce all four (say, rotors without drag torque: no yaw) is rejected when the
   adapter binds, naming what is missing, instead of silently ignoring those commands.

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
    #: Yaw torque cap (N m): rotor drag torques are weak, so an uncapped yaw command saturates
    #: the rotors and steals the thrust differential that roll and pitch need.
    max_yaw_torque: float = 0.04
    #: Face the direction of travel when a target is farther than this horizontally (m).
    face_travel_min: float = 0.5
    #: Rotor actuator names in the MJCF, in mixer order.
    rotors: tuple[str, ...] = ("rotor_fl", "rotor_fr", "rotor_rl", "rotor_rr")


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
        self._mass = float(model.body_subtreemass[root])
        self._inertia = tuple(tuple(float(v) for v in row) for row in self.inertia)
        self._gravity = -float(model.opt.gravity[2])
        self._act = [self.actuator_id(n) for n in c.rotors]
        self._ctrl_lo = [float(model.actuator_ctrlrange[a, 0]) for a in self._act]
        self._ctrl_hi = [float(model.actuator_ctrlrange[a, 1]) for a in self._act]
        self._mixer = [tuple(float(v) for v in row) for row in self._mixer_matrix()]
        dof = int(model.body_dofadr[root])
        if model.body_dofnum[root] != 6:
            raise ValueError(f"drone '{prefix}': root body must have a free joint")
        self._vel = dof  # qvel[dof:dof+3]: world linear velocity; [dof+3:dof+6]: body angular
        self.reset()

    @property
    def inertia(self) -> np.ndarray:
        """(3, 3) inertia of the root body about its centre of mass, in the body frame.

        MuJoCo stores principal moments (``body_inertia``) in the inertia frame ``body_iquat``;
        a robot file with a full or rotated inertia has a rotated frame, and the attitude loop
        needs ``R diag(I) R^T``.
        """
        root = self.root_body_id
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, self.model.body_iquat[root])
        rot = rot.reshape(3, 3)
        return rot @ np.diag(self.model.body_inertia[root]) @ rot.T

    def _mixer_matrix(self) -> np.ndarray:
        """Inverse of rotor force -> body wrench (thrust z, torque x, y, z), from the model.

        Raises ``ValueError`` when the rotors cannot produce every wrench axis: ``pinv`` would
        return a mixer that silently maps that axis's commands to nothing.
        """
        model = self.model
        wrench = np.zeros((4, len(self._act)))
        for j, a in enumerate(self._act):
            if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_SITE:
                raise ValueError(f"drone '{self.prefix}': rotor actuators must act on sites")
            site = model.actuator_trnid[a, 0]
            if model.site_bodyid[site] != self.root_body_id:
                raise ValueError(f"drone '{self.prefix}': rotor sites must be on the root body")
            rot = np.empty(9)
            mujoco.mju_quat2Mat(rot, model.site_quat[site])
            rot = rot.reshape(3, 3)
            gear = model.actuator_gear[a]
            force = rot @ gear[:3]
            torque = np.cross(model.site_pos[site] - model.body_ipos[self.root_body_id], force)
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
                f"wrench matrix has rank {np.linalg.matrix_rank(wrench)} of 4); a quadrotor yaws "
                "by the rotors' drag torques: give each rotor actuator a gear[5] (N m per N) "
                "with alternating signs"
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
        tz = max(-c.max_yaw_torque, min(c.max_yaw_torque, tz))
        thrust = self._mass * (ax * b2[0] + ay * b2[1] + az * b2[2])

        # 5. mixer: rotor forces from the wrench, clipped to the actuator ranges
        ctrl = data.ctrl
        for k, a in enumerate(self._act):
            m = self._mixer[k]
            f = m[0] * thrust + m[1] * tx + m[2] * ty + m[3] * tz
            ctrl[a] = min(self._ctrl_hi[k], max(self._ctrl_lo[k], f))
