"""Scene composition with ``mujoco.MjSpec``: an arena plus robots, compiled to one model.

An arena MJCF holds the rooms, furniture and props (props may be pulled in with MJCF's
``<attach model=...>``). :class:`SceneBuilder` attaches each robot at a spawn frame with the
name prefix ``"<prefix>/"`` and declares the weld equalities that let a free body (a tool) be
held by the world, a gripper or a basket; :class:`Scene` steps the physics and owns those welds.

The scene's global settings are the arena's and the task's: an attached file's ``<option>``,
``<size>`` and ``<visual>`` are replaced by the scene's before attaching (MuJoCo would keep the
scene's anyway, but print an "Attach conflict" warning and write ``MUJOCO_LOG.TXT`` for every
robot of every build), its keyframes are dropped (their ``qpos`` would describe a model of its
own), and a robot's lights are dropped, because they would light, and so change, every other
robot's camera image.

MuJoCo does not stop on a numerical instability: it resets the state and carries on, counting
a warning. :meth:`Scene.advance` checks the counters and raises :class:`PhysicsInstability`, so
a tick whose physics was reset is never taken for a real one.

A video films the motion between ticks through :meth:`Scene.watch_substeps`: a listener called
at evenly spaced physics steps inside every advance, on the state the physics reached there.
The scene knows nothing of what it is for (no task, no frame), and watching leaves the
trajectory bit for bit as it is.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from maopg.sim.appearance import add_assets, needs_assets
from maopg.sim.looks import OFF
from maopg.sim.robots import ASSETS_DIR, RobotAdapter, RobotSpec, get_robot

WORLD = "world"


class MJCFError(ValueError):
    """An MJCF file failed to load or compile; the message names the file(s)."""


_MUJOCO_LOG = logging.getLogger("maopg.mujoco")


def _log_warning(message: str) -> None:
    """MuJoCo's warnings go to the ``maopg.mujoco`` logger: MuJoCo's own handler prints them
    and appends them to ``MUJOCO_LOG.TXT`` in the working directory, a file no run of ours
    should leave behind (:class:`PhysicsInstability` carries the ones that matter to an
    episode). Logging, unlike ``warnings.warn`` under ``-W error``, never raises — this runs
    inside a C callback."""
    _MUJOCO_LOG.warning("MuJoCo: %s", message)


if mujoco.get_mju_user_warning() is None:  # a user's own handler stays in place
    mujoco.set_mju_user_warning(_log_warning)


class PhysicsInstability(RuntimeError):
    """MuJoCo raised a physics warning during :meth:`Scene.advance` (and, for a bad position,
    velocity or acceleration, reset the state): the tick's physics is not to be trusted.

    ``warning`` is the warning's name (``"mjWARN_BADQACC"``), ``robot`` the prefix of the robot
    whose joint or actuator it names (None when it names none, e.g. a full contact buffer).
    """

    def __init__(self, message: str, warning: str, robot: str | None) -> None:
        super().__init__(message)
        self.warning = warning
        self.robot = robot


_WARNING_MEANING = {
    mujoco.mjtWarning.mjWARN_CONTACTFULL: "the contact buffer is full",
    mujoco.mjtWarning.mjWARN_CNSTRFULL: "the constraint buffer is full",
    mujoco.mjtWarning.mjWARN_BADQPOS: "a bad (NaN/huge) position; MuJoCo reset the state",
    mujoco.mjtWarning.mjWARN_BADQVEL: "a bad (NaN/huge) velocity; MuJoCo reset the state",
    mujoco.mjtWarning.mjWARN_BADQACC: "a bad (NaN/huge) acceleration; MuJoCo reset the state",
    mujoco.mjtWarning.mjWARN_BADCTRL: "a bad (NaN/huge) control; MuJoCo zeroed the controls",
}
"""The warnings a step can raise (``mjWARN_INERTIA`` is the compiler's), and what they mean."""
_DOF_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)
"""Warnings whose ``lastinfo`` is a DOF index."""


def load_spec(path: str | Path) -> mujoco.MjSpec:
    """Parse an MJCF file; relative paths are tried as given, then under ``assets/``."""
    path = Path(path)
    if not path.is_absolute() and not path.exists():
        path = ASSETS_DIR / path
    if not path.exists():
        raise FileNotFoundError(f"MJCF file not found: {path}")
    try:
        return mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:  # MuJoCo reports parse errors as ValueError
        raise MJCFError(f"{path}: MuJoCo could not load it: {exc}") from exc


def weld_name(body: str, holder: str | None) -> str:
    return f"weld:{body}@{WORLD if holder is None else holder}"


def yaw_quat(yaw: float) -> list[float]:
    return [math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0)]


_SIZE_SETTINGS = ("memory", "nconmax", "njmax", "nstack", "nuserdata", "nkey")
"""``<size>`` settings of an MjSpec besides the ``nuser_*`` ones."""


def _copy_settings(dst: Any, src: Any) -> None:
    """Copy every setting of an MjSpec settings struct (``option``, ``visual``) onto another."""
    for name in dir(src):
        if name.startswith("_"):
            continue
        value = getattr(src, name)
        if isinstance(value, bool | int | float | str | np.ndarray):
            setattr(dst, name, value)
        elif not callable(value):  # a nested struct (visual.headlight, ...)
            _copy_settings(getattr(dst, name), value)


def strip_for_attaching(child: mujoco.MjSpec, parent: mujoco.MjSpec, *, lights: bool) -> None:
    """Make ``child`` attach to ``parent`` silently and without side effects on the scene.

    Its global settings become the parent's (so nothing conflicts), its keyframes are deleted,
    and with ``lights=False`` its lights too (see the module docstring).
    """
    _copy_settings(child.option, parent.option)
    _copy_settings(child.visual, parent.visual)
    for name in (*_SIZE_SETTINGS, *(n for n in dir(parent) if n.startswith("nuser_"))):
        setattr(child, name, getattr(parent, name))
    for key in list(child.keys):
        child.delete(key)
    if not lights:
        for light in list(child.lights):
            child.delete(light)


class SceneBuilder:
    """Compose an arena, robots, props and attachable bodies into one compiled :class:`Scene`."""

    def __init__(
        self,
        arena: str | Path | mujoco.MjSpec,
        *,
        timestep: float,
        render_size: int = 64,
        video_size: tuple[int, int] = (480, 640),
        appearance: str = OFF,
    ) -> None:
        """``arena``: an MJCF file, or a spec made in code (a generated room); the builder
        adds to the spec it is given. ``appearance``: the task's ``env.appearance``, whose looks
        may need textures, materials and distractors compiled in
        (:func:`maopg.sim.appearance.add_assets`); ``off`` compiles the scene as it is."""
        self.arena = arena
        self.appearance = appearance
        self.spec = arena if isinstance(arena, mujoco.MjSpec) else load_spec(arena)
        self.spec.option.timestep = timestep
        # Offscreen buffer large enough for every renderer the scene will be asked for.
        self.spec.visual.global_.offwidth = max(render_size, video_size[1])
        self.spec.visual.global_.offheight = max(render_size, video_size[0])
        name = f"<generated arena {arena.modelname!r}>" if arena is self.spec else str(arena)
        self._files: list[str] = [name]
        self._robots: list[tuple[str, RobotSpec]] = []
        self._welds: list[tuple[str, str | None, bool]] = []

    def _attach(
        self, prefix: str, mjcf: str | Path, pos: Sequence[float], yaw: float, *, lights: bool
    ) -> None:
        if "/" in prefix or not prefix:
            raise ValueError(f"prefix must be a non-empty name without '/', got {prefix!r}")
        child = load_spec(mjcf)
        strip_for_attaching(child, self.spec, lights=lights)
        frame = self.spec.worldbody.add_frame(pos=list(pos), quat=yaw_quat(yaw))
        self.spec.attach(child, prefix=f"{prefix}/", frame=frame)
        self._files.append(str(mjcf))

    def add_robot(
        self,
        prefix: str,
        robot: str | RobotSpec,
        pos: Sequence[float],
        yaw: float = 0.0,
    ) -> None:
        """Attach a registered robot at ``pos`` with heading ``yaw``; its names get ``prefix/``."""
        spec = get_robot(robot) if isinstance(robot, str) else robot
        if any(p == prefix for p, _ in self._robots):
            raise ValueError(f"robot prefix '{prefix}' is already used")
        self._attach(prefix, spec.mjcf, pos, yaw, lights=False)
        self._robots.append((prefix, spec))

    def add_prop(
        self, prefix: str, mjcf: str | Path, pos: Sequence[float], yaw: float = 0.0
    ) -> None:
        """Attach a prop file (desk, jar, tool, ...) at a pose; its names get ``prefix/``. A
        prop keeps its lights (a lamp may be the point of it)."""
        self._attach(prefix, mjcf, pos, yaw, lights=True)

    def add_attachable(self, body: str, holders: Sequence[str | None]) -> None:
        """Declare welds between a free ``body`` and each holder body (None = the world).

        The body starts held by ``holders[0]`` at its initial pose; :meth:`Scene.attach`
        switches holders. A body that is always held needs no contacts and never drifts.
        """
        if not holders:
            raise ValueError(f"{body}: give at least one holder")
        for i, holder in enumerate(holders):
            self._welds.append((body, holder, i == 0))

    def build(self) -> Scene:
        for body, holder, active in self._welds:
            self.spec.add_equality(
                type=mujoco.mjtEq.mjEQ_WELD,
                objtype=mujoco.mjtObj.mjOBJ_BODY,
                name=weld_name(body, holder),
                name1=WORLD if holder is None else holder,
                name2=body,
                active=active,
            )
        if needs_assets(self.appearance):
            add_assets(self.spec)
        try:
            model = self.spec.compile()
        except ValueError as exc:
            raise MJCFError(
                f"compiling the scene from {', '.join(self._files)} failed: {exc}"
            ) from exc
        return Scene(model, self._robots, [(b, h) for b, h, _ in self._welds])


class Scene:
    """A compiled scene: model, data, one adapter per robot, and the attach/detach welds."""

    def __init__(
        self,
        model: mujoco.MjModel,
        robots: Sequence[tuple[str, RobotSpec]],
        welds: Sequence[tuple[str, str | None]],
    ) -> None:
        self.model = model
        self.data = mujoco.MjData(model)
        self.timestep = float(model.opt.timestep)
        self._weld_id = {
            (b, h): mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, weld_name(b, h))
            for b, h in welds
        }
        self._welds_of: dict[str, list[int]] = {}
        for (b, _), eq in self._weld_id.items():
            self._welds_of.setdefault(b, []).append(eq)
        self._eq_data0 = model.eq_data.copy()
        self._geom_rgba0 = model.geom_rgba.copy()
        self._watch: tuple[int, Callable[[], None]] | None = None
        mujoco.mj_forward(model, self.data)
        self.robots: dict[str, RobotAdapter] = {
            prefix: spec.adapter_class()(model, self.data, prefix, spec.resolve_constants())
            for prefix, spec in robots
        }
        self.reset()

    # --- stepping ----------------------------------------------------------------------------
    def reset(self) -> None:
        """Deterministic initial state: qpos0, initial welds and colours, zero commands."""
        self.model.eq_data[:] = self._eq_data0
        self.model.geom_rgba[:] = self._geom_rgba0
        mujoco.mj_resetData(self.model, self.data)
        for robot in self.robots.values():
            robot.set_initial_pose()
        mujoco.mj_forward(self.model, self.data)
        for robot in self.robots.values():
            robot.reset()

    def start_state(self) -> mujoco.MjData:
        """A new ``MjData`` in the posture :meth:`reset` starts from (``qpos0``, each robot's
        start posture, positions computed), for reading the scene as built whatever episode
        the live data is in. The live data is left bit for bit as it was."""
        live = mujoco.MjData(self.model)
        mujoco.mj_copyData(live, self.model, self.data)
        try:  # a robot writes its start posture into the data it is bound to
            mujoco.mj_resetData(self.model, self.data)
            for robot in self.robots.values():
                robot.set_initial_pose()
            mujoco.mj_kinematics(self.model, self.data)
            start = mujoco.MjData(self.model)
            mujoco.mj_copyData(start, self.model, self.data)
        finally:
            mujoco.mj_copyData(self.data, self.model, live)
        return start

    def _schedule(self, seconds: float) -> tuple[int, int]:
        """(physics steps in this advance, steps between control updates)."""
        n = round(seconds / self.timestep)
        if n < 1 or abs(n * self.timestep - seconds) > 1e-6 * max(1.0, seconds):
            raise ValueError(
                f"advance({seconds}) is not a multiple of the timestep {self.timestep}"
            )
        chunk = n
        for robot in self.robots.values():
            if robot.control_hz is not None:
                chunk = math.gcd(chunk, max(1, round(1.0 / (robot.control_hz * self.timestep))))
        return n, chunk

    def advance(self, seconds: float) -> None:
        """Step the physics ``seconds`` forward, refreshing every robot's actuator set-points.

        Robots with ``control_hz=None`` get one ``apply()`` per call (their servos run in
        MuJoCo's actuators), so the common case is a single ``mj_step(nstep=n)`` call. After
        ``mj_step`` the position-derived fields (``xpos``, ``site_xpos``, ...) still describe the
        state one step earlier; the closing ``mj_forward`` makes everything a task observes or
        renders describe the current state (and keeps ``drive_to``'s arrival exact).

        Raises :class:`PhysicsInstability` when MuJoCo counted a warning meanwhile.
        """
        # Counted from zero in every advance: MuJoCo's reset on instability zeroes the counters
        # before counting the warning, so a count kept across advances would miss a repeat.
        warnings = self.data.warning
        for warning in _WARNING_MEANING:
            warnings[warning].number = 0
        start = self.data.time  # a reset restarts the clock
        self._step(seconds)
        for warning, meaning in _WARNING_MEANING.items():
            if warnings[warning].number:
                raise self._instability(warning, meaning, start, seconds)

    def watch_substeps(self, frames: int, listener: Callable[[], None] | None) -> None:
        """Call ``listener()`` ``frames - 1`` times inside every :meth:`advance`, after the
        physics steps ``round(n * j / frames)`` (``j = 1 .. frames - 1`` of its ``n`` steps; fewer
        when ``n < frames``), so that, with the state the advance ends in, a tick is seen
        ``frames`` times evenly spaced; ``None`` stops watching.

        At each call ``data`` holds the physics state reached there, with positions, cameras and
        lights computed from it (``mj_kinematics``, ``mj_camlight``): what a renderer draws and
        a task's labels read. The listener must change nothing. The trajectory stays bit for bit
        what it is unwatched: ``mj_step`` is only split at those steps (n steps in two calls are
        the same n steps), and the positions computed there are derived fields that the next
        ``mj_step`` computes afresh from ``qpos``.
        """
        if frames < 1:
            raise ValueError(f"frames must be at least 1, got {frames}")
        self._watch = None if listener is None else (frames, listener)

    def _marks(self, n: int) -> list[int]:
        """The steps (counted from the advance's start) after which the watcher is called."""
        if self._watch is None:
            return []
        frames = self._watch[0]
        return sorted({round(n * j / frames) for j in range(1, frames)} - {0, n})

    def _mj_steps(self, done: int, count: int, marks: list[int]) -> None:
        """``count`` physics steps, ``done`` of the advance's already taken; the watcher is
        called after each step in ``marks``."""
        model, data = self.model, self.data
        end = done + count
        for mark in marks:
            if done < mark <= end:
                mujoco.mj_step(model, data, nstep=mark - done)
                done = mark
                mujoco.mj_kinematics(model, data)
                mujoco.mj_camlight(model, data)
                self._watch[1]()  # type: ignore[index]  (marks exist only while watched)
        if done < end:
            mujoco.mj_step(model, data, nstep=end - done)

    def _step(self, seconds: float) -> None:
        n, chunk = self._schedule(seconds)
        model, data = self.model, self.data
        marks = self._marks(n)
        if chunk == n:
            for robot in self.robots.values():
                robot.control_dt = seconds
                robot.apply()
            self._mj_steps(0, n, marks)
            mujoco.mj_forward(model, data)
            return
        for start in range(0, n, chunk):
            if start:
                mujoco.mj_kinematics(model, data)  # fresh poses for the controllers
            for robot in self.robots.values():
                if robot.control_hz is None:
                    if start == 0:
                        robot.control_dt = seconds
                        robot.apply()
                else:
                    period = max(1, round(1.0 / (robot.control_hz * self.timestep)))
                    if start % period == 0:
                        robot.control_dt = period * self.timestep
                        robot.apply()
            self._mj_steps(start, chunk, marks)
        mujoco.mj_forward(model, data)

    def _instability(
        self, warning: mujoco.mjtWarning, meaning: str, start: float, seconds: float
    ) -> PhysicsInstability:
        """The exception for ``warning``, naming the joint or actuator it reports (its
        ``lastinfo``: a ``qpos`` or DOF index, or an actuator index) and so the robot."""
        model, info = self.model, int(self.data.warning[warning].lastinfo)
        kind, name = "", ""
        if warning == mujoco.mjtWarning.mjWARN_BADCTRL and 0 <= info < model.nu:
            kind, name = "actuator", model.actuator(info).name
        elif warning == mujoco.mjtWarning.mjWARN_BADQPOS and 0 <= info < model.nq:
            kind = "joint"
            name = model.joint(int(np.searchsorted(model.jnt_qposadr, info, "right")) - 1).name
        elif warning in _DOF_WARNINGS and 0 <= info < model.nv:
            kind, name = "joint", model.joint(int(model.dof_jntid[info])).name
        owner = name.partition("/")[0]
        robot = owner if name and owner in self.robots else None
        where = f" at {kind} '{name}'" if name else ""
        where += f" of robot '{robot}'" if robot else ""
        return PhysicsInstability(
            f"physics unstable between t={start:.3f} s and {start + seconds:.3f} s: "
            f"{warning.name}{where} ({meaning}); "
            "lower the robot's gains, or the timestep",
            warning.name,
            robot,
        )

    # --- welds ---------------------------------------------------------------------------------
    def attach(self, body: str, holder: str | None) -> None:
        """Hold ``body`` by ``holder`` (None = world) at their CURRENT relative pose (no jump).

        Deactivates the body's other welds. The weld stores the body's pose in the holder's
        frame (``eq_data[3:10]``, MuJoCo's ``relpose``), computed from fresh kinematics.
        """
        try:
            eq = self._weld_id[(body, holder)]
        except KeyError:
            known = sorted(str(h) for b, h in self._weld_id if b == body)
            raise KeyError(
                f"no weld declared between '{body}' and holder {holder!r} (declared: {known})"
            ) from None
        model, data = self.model, self.data
        mujoco.mj_kinematics(model, data)
        h = model.eq_obj1id[eq]
        b = model.eq_obj2id[eq]
        inv = np.empty(4)
        mujoco.mju_negQuat(inv, data.xquat[h])
        rel_pos = np.empty(3)
        mujoco.mju_rotVecQuat(rel_pos, data.xpos[b] - data.xpos[h], inv)
        rel_quat = np.empty(4)
        mujoco.mju_mulQuat(rel_quat, inv, data.xquat[b])
        for other in self._welds_of[body]:
            data.eq_active[other] = 0
        model.eq_data[eq, 0:3] = 0.0
        model.eq_data[eq, 3:6] = rel_pos
        model.eq_data[eq, 6:10] = rel_quat
        data.eq_active[eq] = 1

    def holder_of(self, body: str) -> str | None:
        """The holder whose weld on ``body`` is active (None = world)."""
        for (b, h), eq in self._weld_id.items():
            if b == body and self.data.eq_active[eq]:
                return h
        raise ValueError(f"'{body}' is not held by anything")

    def place(self, body: str, pos: Sequence[float], quat: Sequence[float] | None = None) -> None:
        """Put a free body at a world pose at rest and weld it to the world there.

        For hand-overs with no manipulator (e.g. the human taking a delivered tool).
        """
        bid = self._id(mujoco.mjtObj.mjOBJ_BODY, body)
        jnt = self.model.body_jntadr[bid]
        if jnt < 0 or self.model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE:
            raise ValueError(f"'{body}' has no free joint to place")
        qadr, vadr = self.model.jnt_qposadr[jnt], self.model.jnt_dofadr[jnt]
        self.data.qpos[qadr : qadr + 3] = pos
        self.data.qpos[qadr + 3 : qadr + 7] = [1.0, 0.0, 0.0, 0.0] if quat is None else quat
        self.data.qvel[vadr : vadr + 6] = 0.0
        self.attach(body, None)

    # --- queries and looks ---------------------------------------------------------------------
    def _id(self, objtype: mujoco.mjtObj, name: str) -> int:
        idx = mujoco.mj_name2id(self.model, objtype, name)
        if idx < 0:
            kind = objtype.name.removeprefix("mjOBJ_").lower()
            raise KeyError(f"the scene has no {kind} named '{name}'")
        return idx

    def body_position(self, name: str) -> np.ndarray:
        return self.data.xpos[self._id(mujoco.mjtObj.mjOBJ_BODY, name)].copy()

    def site_position(self, name: str) -> np.ndarray:
        return self.data.site_xpos[self._id(mujoco.mjtObj.mjOBJ_SITE, name)].copy()

    def set_geom_rgba(self, name: str, rgba: Sequence[float]) -> None:
        """Recolour a geom (e.g. a stage indicator); :meth:`reset` restores the MJCF colours."""
        self.model.geom_rgba[self._id(mujoco.mjtObj.mjOBJ_GEOM, name)] = rgba

    def state(self) -> dict[str, Any]:
        """Copies of the physical state (qpos, qvel, act, time) for comparisons and logging."""
        d = self.data
        return {"qpos": d.qpos.copy(), "qvel": d.qvel.copy(), "act": d.act.copy(), "time": d.time}
