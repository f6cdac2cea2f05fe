"""Robot adapters: the only layer that knows a robot's joints, actuators and camera.

Options and tasks talk to adapters (``drive_to``, ``set_arm_targets``, ...), never to raw
``data.ctrl`` indices, so a robot can be swapped by pointing the registry at another MJCF and
adapter. The low-level loops (velocity / PD servos) run inside MuJoCo's actuators, in C, at every
physics step; ``apply()`` only refreshes their set-points once per tick (or at ``control_hz``),
which keeps the option layer's Python overhead O(1) per tick.

Conventions an adapter relies on:

* every name in a robot MJCF is local (``base``, ``camera``); the scene attaches the robot with
  the prefix ``"<prefix>/"``, so the adapter looks up ``f"{prefix}/{local}"``;
* the scene rotates the attachment frame by the spawn yaw, so a planar base's slide joints are
  expressed in that rotated frame; :class:`PlanarGroundAdapter` undoes it when commanding;
* the set-point commands a role declares (``COMMANDS``: ``drive_to``, ``fly_to``, ...) refuse
  NaN and infinity with a ``ValueError`` naming the robot and the command, in every adapter of
  the role, a user's included: a NaN target would otherwise reach the servos (a drone climbed
  to 11 m on one) instead of failing where it was made.
"""

from __future__ import annotations

import functools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco
import numpy as np


def wrap_angle(angle: float) -> float:
    """Map an angle to [-pi, pi) so heading errors take the short way round."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _finite_command(command: Callable[..., Any]) -> Callable[..., Any]:
    """``command`` refusing any argument that holds NaN or ±inf (``None`` passes)."""

    @functools.wraps(command)
    def checked(self: RobotAdapter, *args: Any, **kwargs: Any) -> Any:
        for value in (*args, *kwargs.values()):
            if value is not None and not np.isfinite(np.asarray(value, dtype=float)).all():
                shown = ", ".join(
                    [repr(_plain(a)) for a in args]
                    + [f"{k}={_plain(v)!r}" for k, v in kwargs.items()]
                )
                raise ValueError(
                    f"robot {self.prefix!r} ({type(self).__name__}): {command.__name__}({shown}) "
                    "needs finite set-points"
                )
        return command(self, *args, **kwargs)

    checked.finite_checked = True  # type: ignore[attr-defined]
    return checked


def _plain(value: Any) -> Any:
    """A number or a tuple of numbers, for the error line (arrays print their dtype)."""
    if isinstance(value, np.ndarray | list | tuple):
        return tuple(float(v) for v in np.asarray(value, dtype=float).ravel())
    return float(value)


_COUNTS = {
    mujoco.mjtObj.mjOBJ_BODY: "nbody",
    mujoco.mjtObj.mjOBJ_JOINT: "njnt",
    mujoco.mjtObj.mjOBJ_GEOM: "ngeom",
    mujoco.mjtObj.mjOBJ_SITE: "nsite",
    mujoco.mjtObj.mjOBJ_CAMERA: "ncam",
    mujoco.mjtObj.mjOBJ_ACTUATOR: "nu",
}
"""The model's count of each kind of element an adapter looks up by name."""


class RobotAdapter(ABC):
    """Binds one attached robot instance (its name prefix) inside a compiled scene."""

    COMMANDS: ClassVar[tuple[str, ...]] = ()
    """The role's set-point methods: each implementation is checked for finite arguments
    (module docstring)."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for name in cls.COMMANDS:
            command = cls.__dict__.get(name)
            if callable(command) and not getattr(command, "finite_checked", False):
                setattr(cls, name, _finite_command(command))

    #: None: ``apply()`` runs once per ``Scene.advance`` call (one tick); else at this rate (Hz).
    control_hz: ClassVar[float | None] = None
    #: Local (unprefixed) name of the robot's root body in its MJCF.
    root_body: ClassVar[str] = "base"
    #: Local name of the robot's onboard camera.
    camera: ClassVar[str] = "camera"
    #: Frozen dataclass with this robot type's gains/speeds/sizes; instantiated when none is given.
    Constants: ClassVar[type]

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, prefix: str, constants: Any = None
    ) -> None:
        self.model = model
        self.data = data
        self.prefix = prefix
        self.constants = constants if constants is not None else self.Constants()
        adapter = type(self).__name__
        self.root_body_id = self.object_id(
            mujoco.mjtObj.mjOBJ_BODY, self.root_body, f"{adapter}.root_body"
        )
        self.camera_name = self.name(self.camera)
        self.camera_id = self.object_id(
            mujoco.mjtObj.mjOBJ_CAMERA, self.camera, f"{adapter}.camera"
        )
        #: Seconds until the next ``apply()``; the scene sets it before every call.
        self.control_dt = 1.0

    # --- name resolution -------------------------------------------------------------------
    def name(self, local: str) -> str:
        """Full (prefixed) name of one of this robot's elements."""
        return f"{self.prefix}/{local}"

    def object_id(self, objtype: mujoco.mjtObj, local: str, setting: str | None = None) -> int:
        """Id of a prefixed element. A missing name fails naming the robot, the element, the
        robot's elements of that kind (what is allowed) and ``setting``, where the adapter took
        the name from (``"TurtlebotConstants.actuators"``)."""
        full = self.name(local)
        idx = mujoco.mj_name2id(self.model, objtype, full)
        if idx < 0:
            kind = objtype.name.removeprefix("mjOBJ_").lower()
            names = ", ".join(self.local_names(objtype)) or "none"
            where = setting or "the adapter's name for it"
            raise KeyError(
                f"{type(self).__name__} for '{self.prefix}': the model has no {kind} '{full}'; "
                f"the robot's {kind}s: {names}; set {where} to one of them"
            )
        return idx

    def local_names(self, objtype: mujoco.mjtObj) -> list[str]:
        """The local names of this robot's elements of one kind (body, joint, actuator, ...)."""
        count = getattr(self.model, _COUNTS[objtype])
        head = self.name("")
        names = (mujoco.mj_id2name(self.model, objtype, i) or "" for i in range(count))
        return [n.removeprefix(head) for n in names if n.startswith(head)]

    def joint_qpos_adr(self, local: str, setting: str | None = None) -> int:
        joint = self.object_id(mujoco.mjtObj.mjOBJ_JOINT, local, setting)
        return int(self.model.jnt_qposadr[joint])

    def joint_dof_adr(self, local: str, setting: str | None = None) -> int:
        joint = self.object_id(mujoco.mjtObj.mjOBJ_JOINT, local, setting)
        return int(self.model.jnt_dofadr[joint])

    def actuator_id(self, local: str, setting: str | None = None) -> int:
        return self.object_id(mujoco.mjtObj.mjOBJ_ACTUATOR, local, setting)

    def set_position_gains(self, local: str, kp: float, kv: float) -> None:
        """Make an actuator a PD servo, force = kp * (ctrl - q) - kv * qvel.

        The gains come from the constants (the one source), and the servo's form is written
        too, so whatever the robot file declares on the joint (``<position>``, ``<velocity>``,
        ``<motor>``, as robot collections ship them) becomes the servo this adapter commands.
        """
        self._set_servo(local, kp, (0.0, -kp, -kv))

    def set_velocity_gain(self, local: str, kv: float) -> None:
        """Make an actuator a velocity servo, force = kv * (ctrl - qvel) (see
        :meth:`set_position_gains`: a ``<position>`` actuator on a slide works too)."""
        self._set_servo(local, kv, (0.0, 0.0, -kv))

    def _set_servo(self, local: str, gain: float, bias: tuple[float, float, float]) -> None:
        a = self.actuator_id(local)
        model = self.model
        model.actuator_gaintype[a] = mujoco.mjtGain.mjGAIN_FIXED
        model.actuator_biastype[a] = mujoco.mjtBias.mjBIAS_AFFINE
        model.actuator_gainprm[a, 0] = gain
        model.actuator_biasprm[a, :3] = bias

    # --- state -----------------------------------------------------------------------------
    @property
    def position(self) -> np.ndarray:
        """(3,) world position of the root body (a copy)."""
        return self.data.xpos[self.root_body_id].copy()

    @property
    def yaw(self) -> float:
        """Heading of the root body about world z (rad)."""
        xmat = self.data.xmat[self.root_body_id]
        return math.atan2(xmat[3], xmat[0])

    # --- commands --------------------------------------------------------------------------
    def set_initial_pose(self) -> None:
        """Write this robot's start posture into ``data.qpos`` (default: the MJCF's).

        ``Scene.reset`` calls it right after ``mj_resetData``. Override it rather than editing
        ``model.qpos0``: MuJoCo measures hinge/slide angles from ``qpos0``, so changing it would
        move the joints' zero.
        """
        return None

    @abstractmethod
    def reset(self) -> None:
        """Forget any command and hold the current pose (called after ``Scene.reset``)."""

    @abstractmethod
    def hold(self) -> None:
        """Command: stay where you are (used by idling agents)."""

    @abstractmethod
    def apply(self) -> None:
        """Write ``data.ctrl`` for this robot from the current command."""


class GroundAdapter(RobotAdapter):
    """A robot that moves on the floor plane: turtlebot, vehicle, the swap-demo robot."""

    COMMANDS = ("drive_to", "set_velocity", "turn_to")

    @property
    def max_speed(self) -> float:
        return float(self.constants.max_speed)

    @abstractmethod
    def drive_to(self, xy: Sequence[float], speed: float | None = None) -> None:
        """Drive toward a planar target at most at ``speed`` (default ``max_speed``)."""

    @abstractmethod
    def set_velocity(self, vx: float, vy: float) -> None:
        """World-frame planar velocity command (m/s)."""

    def turn_to(self, yaw: float) -> None:
        """Stop where the robot is and turn in place to heading ``yaw`` (rad about world z):
        what a task whose robots face a way (Box Pushing's turns) asks. Both shipped drives
        implement it; a drive that cannot turn in place keeps this default, which refuses."""
        raise NotImplementedError(
            f"robot {self.prefix!r} ({type(self).__name__}) cannot turn in place: its adapter "
            "has no turn_to()"
        )

    def at(self, xy: Sequence[float], tol: float) -> bool:
        pos = self.data.xpos[self.root_body_id]
        return math.hypot(pos[0] - xy[0], pos[1] - xy[1]) <= tol

    @property
    def footprint_radius(self) -> float:
        """The robot's radius for path planning (m): its constants' ``radius`` where they give
        one (a measured footprint), else the farthest its colliding geoms reach horizontally
        from the root body's origin, each geom bounded by its bounding sphere — generous, and
        known for any robot a user brings."""
        given = getattr(self.constants, "radius", None)
        if given is not None:
            return float(given)
        model, data = self.model, self.data
        mujoco.mj_kinematics(model, data)
        centre = data.xpos[self.root_body_id, :2]
        reach = 0.0
        for g in range(model.ngeom):
            body = int(model.geom_bodyid[g])
            if model.body_rootid[body] != self.root_body_id:
                continue
            if not (model.geom_contype[g] or model.geom_conaffinity[g]):
                continue
            offset = math.dist(data.geom_xpos[g, :2], centre)
            reach = max(reach, offset + float(model.geom_rbound[g]))
        if reach == 0.0:
            raise ValueError(
                f"{type(self).__name__} for '{self.prefix}': no colliding geom to measure a "
                "footprint from; give its constants a radius"
            )
        return reach


class DroneAdapter(RobotAdapter):
    """A flying robot commanded by 3-D position targets and a heading.

    Its root body carries a free joint (tasks place it in the air by writing its height), and
    its constants give ``max_speed``.
    """

    COMMANDS = ("fly_to",)

    @abstractmethod
    def fly_to(
        self, xyz: Sequence[float], speed: float | None = None, yaw: float | None = None
    ) -> None:
        """Fly toward ``xyz`` at most at ``speed`` (default ``max_speed``) and turn to ``yaw``
        (rad about world z; None: the adapter's choice, e.g. the direction of travel)."""

    def at(self, xyz: Sequence[float], tol: float) -> bool:
        return float(np.linalg.norm(self.data.xpos[self.root_body_id] - np.asarray(xyz))) <= tol


class ArmAdapter(RobotAdapter):
    """A fixed-base manipulator with joint-space PD control, analytic IK and a gripper."""

    #: Local name of the body a grasped object is welded to. A class attribute, because a
    #: scene declares its welds before it is compiled, i.e. before any adapter exists.
    gripper: ClassVar[str] = "gripper"
    COMMANDS = ("set_arm_targets", "ik")

    @property
    def gripper_body(self) -> str:
        """Full name of the body a grasped object is welded to."""
        return self.name(self.gripper)

    @abstractmethod
    def set_arm_targets(self, q: np.ndarray) -> None: ...

    @abstractmethod
    def set_gripper(self, closed: bool) -> None: ...

    @abstractmethod
    def joint_positions(self) -> np.ndarray: ...

    @abstractmethod
    def ik(self, xyz_world: Sequence[float], pitch: float = -math.pi / 2) -> np.ndarray:
        """Joint targets that put the grasp site at ``xyz_world`` with the given tool pitch."""

    @property
    @abstractmethod
    def grasp_site_position(self) -> np.ndarray: ...


@dataclass(frozen=True)
class PlanarBaseConstants:
    """What :class:`PlanarGroundAdapter` reads from a robot's constants.

    A robot's own constants subclass it, give the numbers defaults and add their own fields;
    the names default to the shipped bases', so a robot whose file names them differently (as
    robot collections do: ``joint_x``, ``base_x_slide``, ...) says so here instead of needing
    an adapter of its own.
    """

    max_speed: float  # m/s
    #: Velocity-servo gain of the two slides (N per m/s).
    kv: float
    #: Heading PD servo (N m per rad, N m per rad/s).
    yaw_kp: float
    yaw_kv: float
    #: The root body's slide x, slide y and yaw hinge joints (local names).
    joints: tuple[str, str, str] = ("x", "y", "yaw")
    #: The actuators on those joints, in the same order.
    actuators: tuple[str, str, str] = ("vx", "vy", "yaw")


class PlanarGroundAdapter(GroundAdapter):
    """Holonomic planar base: slide x/y joints and a yaw hinge on the root body.

    Joint and actuator names come from the constants (:class:`PlanarBaseConstants`). The
    adapter makes the slides' actuators velocity servos and the hinge's a position (PD) servo,
    with the constants' gains (``kv``, ``yaw_kp``, ``yaw_kv``). ``drive_to`` commands, at each
    ``apply()``, full speed toward the target while it is far, and in the last control period
    the velocity that covers exactly the remaining distance. That velocity accounts for the
    servo's first-order lag (time constant ``tau = mass / kv``): a period of length ``T``
    starting at velocity ``v0`` under command ``v`` moves ``v (T - tau) + v0 tau``, so one
    ``apply()`` per tick still arrives without overshoot. The heading follows the motion.
    """

    #: Below this commanded speed (m/s) the heading is kept, so the few-mm corrections after
    #: arrival do not spin the robot round.
    HEADING_MIN_SPEED: ClassVar[float] = 0.05

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, prefix: str, constants: Any = None
    ) -> None:
        super().__init__(model, data, prefix, constants)
        c = self.constants
        act_x, act_y, act_yaw = c.actuators
        joint_x, joint_y, joint_yaw = c.joints
        names = type(c).__name__
        actuators, joints = f"{names}.actuators", f"{names}.joints"
        self._ax, self._ay, self._ayaw = (self.actuator_id(n, actuators) for n in c.actuators)
        self.set_velocity_gain(act_x, c.kv)
        self.set_velocity_gain(act_y, c.kv)
        self.set_position_gains(act_yaw, c.yaw_kp, c.yaw_kv)
        self._q_yaw = self.joint_qpos_adr(joint_yaw, joints)
        self._v_x, self._v_y = (self.joint_dof_adr(j, joints) for j in (joint_x, joint_y))
        self._tau = float(model.body_subtreemass[self.root_body_id]) / c.kv
        # The slide axes live in the attachment frame (rotated by the spawn yaw): world->joint.
        quat = model.body_quat[self.root_body_id]
        yaw0 = math.atan2(
            2.0 * (quat[0] * quat[3] + quat[1] * quat[2]), 1.0 - 2.0 * (quat[2] ** 2 + quat[3] ** 2)
        )
        self._cos0, self._sin0 = math.cos(yaw0), math.sin(yaw0)
        self.reset()

    def reset(self) -> None:
        self._goal: tuple[float, float] | None = None
        self._speed = self.max_speed
        self._vel = (0.0, 0.0)
        self._heading = self.yaw
        self.hold()

    def hold(self) -> None:
        """Brake to a stop where the robot is, keeping its heading.

        A position hold would command a small velocity back against the residual motion of
        a robot that is still moving, and the heading (which follows commanded motion) would
        swing round; a zero-velocity servo stops within a few servo time constants instead.
        """
        self.set_velocity(0.0, 0.0)

    def drive_to(self, xy: Sequence[float], speed: float | None = None) -> None:
        self._goal = (float(xy[0]), float(xy[1]))
        self._speed = self.max_speed if speed is None else min(float(speed), self.max_speed)

    def set_velocity(self, vx: float, vy: float) -> None:
        self._goal = None
        speed = math.hypot(vx, vy)
        scale = self.max_speed / speed if speed > self.max_speed else 1.0
        self._vel = (vx * scale, vy * scale)

    def turn_to(self, yaw: float) -> None:
        """Brake where the robot is (as :meth:`hold`) with ``yaw`` as the heading to keep."""
        self.hold()
        self._heading = float(yaw)

    def apply(self) -> None:
        c0, s0 = self._cos0, self._sin0
        if self._goal is not None:
            pos = self.data.xpos[self.root_body_id]
            dx, dy = self._goal[0] - pos[0], self._goal[1] - pos[1]
            qvel = self.data.qvel
            jx, jy = qvel[self._v_x], qvel[self._v_y]
            v0x, v0y = c0 * jx - s0 * jy, s0 * jx + c0 * jy  # current world velocity
            tau = self._tau
            span = max(self.control_dt - tau, tau)
            vx, vy = (dx - v0x * tau) / span, (dy - v0y * tau) / span
            if math.hypot(vx, vy) > self._speed:  # far away: cruise straight at the target
                dist = math.hypot(dx, dy)
                vx, vy = dx / dist * self._speed, dy / dist * self._speed
        else:
            vx, vy = self._vel
        ctrl = self.data.ctrl
        ctrl[self._ax] = c0 * vx + s0 * vy
        ctrl[self._ay] = -s0 * vx + c0 * vy
        if math.hypot(vx, vy) > self.HEADING_MIN_SPEED:
            self._heading = math.atan2(vy, vx)
        q_yaw = self.data.qpos[self._q_yaw]
        ctrl[self._ayaw] = q_yaw + wrap_angle(self._heading - self.yaw)
