"""Controller checks of one registered robot: does it do what its role's tasks ask of it?

A robot that composes and steps can still fail a task quietly: a drone whose rotors cannot
yaw never faces a jar, a base whose gains are too stiff for the task's timestep has its
physics reset by MuJoCo every few ticks. These checks put the robot alone in the open half of
the Tool Delivery arena (floor, walls and a human in view) and measure what the tasks rely on,
each against a stated threshold taken from the tasks' own tolerances:

``ground``  drive to a target, then to a second one 130 degrees round (tolerance and time of
            Water Filling's ``NavTo``), face the direction of travel, hold still;
``drone``   take off to cruise altitude and hold it, fly 3 m, turn to a commanded yaw;
``arm``     reach three points around the start grasp position (IK + servos), hold still;
every role  its adapter binds (``compose``); no physics warning, and holding still at the end
            it stays where it is (``stable``: a servo too stiff for the timestep can wander
            without MuJoCo warning of anything); the camera renders a non-flat image
            (``camera``).

A failing check names what to change: the robot's constants (``TurtlebotConstants.kv``), the
setting, or the part of its MJCF, with the way to change it (raise, lower), where the check can
tell (:data:`ADVICE`).

``python -m eval check-robot --robot NAME --role ROLE`` prints the report
(:func:`cmd_check_robot`); the every-robot test in ``tests/sim`` asserts that every registered
robot passes, so a shipped robot that breaks one of them fails the suite.
"""

from __future__ import annotations

import argparse
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from maopg.sim.render import CameraRenderer
from maopg.sim.robots import (
    ROLES,
    ArmAdapter,
    DroneAdapter,
    GroundAdapter,
    RobotAdapter,
    RobotSpec,
    get_robot,
    role_of,
)
from maopg.sim.robots.base import wrap_angle
from maopg.sim.scene import PhysicsInstability, Scene, SceneBuilder

TIMESTEPS = {"ground": 0.02, "drone": 0.005, "arm": 0.02}
"""Default physics step per role: that of the coarsest task using it (Tool Delivery's 20 ms
for bases and arms, Water Filling's 5 ms for drones), where stiff gains go unstable first."""
ARENA = "arenas/tool_delivery.xml"
PREFIX = "robot"
SPAWN = (4.2, 1.2, 0.0)
SPAWN_YAW = 0.3
"""A start heading off the world axes, so frame mistakes of an adapter show."""
TICK = 0.5
"""Seconds per ``Scene.advance`` (Water Filling's tick)."""
SLACK = 4.0
"""Seconds allowed beyond a trip's full-speed travel time (Water Filling's NavTo slack)."""

GROUND_LEGS = ((6.0, 1.2), (4.8, 3.0))
GROUND_TOL = 0.05  # m: both tasks' ground arrival tolerance
HEADING_TOL = 0.2  # rad: within Water Filling's face_tol (0.35)
HOLD_SECONDS = 3.0
HOLD_TOL = 0.02  # m
CRUISE = 1.5  # m: Water Filling's cruise altitude
ALTITUDE_TOL = 0.05  # m
CLIMB_SECONDS = 5.0
DRONE_TARGET = (6.0, 3.7)
DRONE_TOL = 0.15  # m: Water Filling's drone arrival tolerance
YAW_TURN = math.pi / 2
YAW_TOL = 0.1  # rad
YAW_SECONDS = 4.0
ARM_OFFSETS = ((0.1, 0.0, 0.0), (0.0, 0.1, 0.0), (0.0, 0.0, -0.1))
ARM_TOL = 0.02  # m
ARM_SECONDS = 3.0
ARM_HOLD_TOL = 0.005  # m
CAMERA_MIN_STD = 5.0
"""A camera image with less grey-level spread than this is flat (inside a geom, black)."""
STABLE_DRIFT = {"ground": HOLD_TOL, "drone": HOLD_TOL, "arm": ARM_HOLD_TOL}
"""How far (m) the robot (an arm: its grasp site) may move while it holds still at the end."""
SETTLING = 0.8
"""A drift that slows tick by tick to less than this share of its first tick's is a servo still
bringing the robot to a stop (too weak); one that does not is a servo too stiff for the step."""

Change = tuple[str, str]
"""A constant of a robot's constants a failing check suggests, and which way: ("kv", "raise")."""
ADVICE: dict[str, tuple[Change, ...]] = {
    "ground reach": (("kv", "raise"), ("wheel_kv", "raise"), ("pos_kp", "raise")),
    "ground heading": (("yaw_kp", "raise"), ("heading_kp", "raise")),
    "drone altitude": (("vel_kp_z", "raise"), ("max_climb", "raise")),
    "drone reach": (("vel_kp", "raise"), ("accel", "raise"), ("max_tilt", "raise")),
    "drone yaw": (("yaw_kp", "raise"),),
    "drone yaw max_yaw_accel": (("max_yaw_accel", "raise"),),
    "drone yaw yaw_share": (("yaw_share", "raise"),),
    "arm reach": (("kp", "raise"),),
    "ground stiff": (("kv", "lower"), ("wheel_kv", "lower"), ("yaw_kp", "lower")),
    "drone stiff": (("att_kp", "lower"), ("att_kd", "lower")),
    "arm stiff": (("kp", "lower"), ("kv", "lower")),
    "ground weak": (("kv", "raise"), ("wheel_kv", "raise")),
    "drone weak": (("pos_kp", "raise"), ("vel_kp", "raise")),
    "arm weak": (("kp", "raise"), ("kv", "raise")),
}
"""What each failing check suggests, by role and check ("stiff"/"weak": a robot that does not
hold still, its servos too stiff for the timestep or too weak to stop it); the shipped
adapters' constants' names, so a user's constants that reuse them get the advice too."""


@dataclass(frozen=True)
class CheckResult:
    """One check: what was measured against which threshold, and whether it passed."""

    name: str
    passed: bool
    measured: float | None = None
    """The figure measured (None when the check could not run)."""
    threshold: float | None = None
    unit: str = ""
    detail: str = ""
    at_least: bool = False
    """The check passes when ``measured >= threshold`` (else ``<=``)."""

    def line(self) -> str:
        verdict = "PASS" if self.passed else "FAIL"
        figure = ""
        if self.measured is not None and self.threshold is not None:
            bound = ">=" if self.at_least else "<="
            figure = f"{self.measured:.3g} {self.unit} ({bound} {self.threshold:.3g})"
        return "  ".join(part for part in (verdict, f"{self.name:<9}", figure, self.detail) if part)


def bounded(
    name: str,
    value: float,
    threshold: float,
    unit: str,
    detail: str = "",
    *,
    at_least: bool = False,
) -> CheckResult:
    passed = value >= threshold if at_least else value <= threshold
    return CheckResult(name, bool(passed), float(value), threshold, unit, detail, at_least)


def format_report(name: str, role: str, results: Sequence[CheckResult]) -> str:
    """The report ``check-robot`` prints: one line per check, then the verdict."""
    failed = [r.name for r in results if not r.passed]
    verdict = f"FAILED: {', '.join(failed)}" if failed else "all checks passed"
    lines = [f"robot '{name}' as {role}:", *(f"  {r.line()}" for r in results), verdict]
    return "\n".join(lines)


def advice(robot: RobotAdapter, key: str) -> str:
    """What to change, as ``"TurtlebotConstants: raise kv (now 300)"``: the changes of
    :data:`ADVICE` ``[key]`` that the robot's constants have; a general line where none."""
    constants = robot.constants
    present = [(f, way) for f, way in ADVICE[key] if hasattr(constants, f)]
    if not present:
        return f"tune {type(robot).__name__}'s gains"
    parts = []
    for way in dict.fromkeys(way for _, way in present):
        fields = [f"{f} (now {_shown(getattr(constants, f))})" for f, w in present if w == way]
        parts.append(f"{way} {' or '.join(fields)}")
    return f"{type(constants).__name__}: {'; '.join(parts)}"


def _shown(value: object) -> str:
    if isinstance(value, tuple):
        return "(" + ", ".join(_shown(v) for v in value) + ")"
    return f"{value:.3g}" if isinstance(value, float) else repr(value)


def compose(spec: RobotSpec, timestep: float) -> Scene:
    """The check scene: the arena with this robot alone at :data:`SPAWN`."""
    builder = SceneBuilder(ARENA, timestep=timestep)
    builder.add_robot(PREFIX, spec, SPAWN, yaw=SPAWN_YAW)
    return builder.build()


def run_until(scene: Scene, done: Callable[[], bool], limit: float) -> float | None:
    """Advance tick by tick until ``done()``; the time it took, or None after ``limit`` s."""
    t = 0.0
    while t < limit - 1e-9:
        scene.advance(TICK)
        t += TICK
        if done():
            return t
    return None


def _planar_error(robot: RobotAdapter, xy: Sequence[float]) -> float:
    pos = robot.position
    return math.hypot(pos[0] - xy[0], pos[1] - xy[1])


def _trip(
    scene: Scene, robot: RobotAdapter, name: str, target: Sequence[float], tol: float, hint: str
) -> CheckResult:
    """The trip to ``target`` commanded already: it must come within ``tol`` at a tick
    before its full-speed travel time plus :data:`SLACK` (the figure: the time it took;
    ``hint``: what to change when it does not)."""
    limit = _planar_error(robot, target) / float(robot.constants.max_speed) + SLACK
    goal = np.asarray(target, dtype=float)
    closest = math.inf

    def error() -> float:
        nonlocal closest
        pos = robot.position[: len(goal)]
        closest = min(closest, float(np.linalg.norm(pos - goal)))
        return closest

    t = run_until(scene, lambda: error() <= tol, limit)
    where = tuple(round(float(v), 2) for v in target)
    if t is not None:
        detail = f"to {where}: error {closest:.3f} m (tolerance {tol} m)"
    else:
        detail = f"to {where}: closest {closest:.3f} m (tolerance {tol} m); {hint}"
    return CheckResult(name, t is not None, limit if t is None else t, limit, "s", detail)


@dataclass(frozen=True)
class Drift:
    """How a robot moved while it held still, tick by tick."""

    largest: float
    """The farthest it got from where it started (m)."""
    steps: tuple[float, ...]
    """How far it moved in each tick (m)."""

    @property
    def settling(self) -> bool:
        """It is coming to a stop, each tick moving less than the last (a servo too weak to
        stop it sooner), instead of wandering or creeping on (a servo too stiff)."""
        steps = self.steps
        slowing = all(b <= a + 1e-9 for a, b in itertools.pairwise(steps))
        return slowing and steps[-1] < SETTLING * steps[0]


def drift(scene: Scene, point: Callable[[], np.ndarray], seconds: float) -> Drift:
    """Advance ``seconds`` tick by tick, following ``point()`` (the robot's held position)."""
    start = previous = point()
    largest, steps = 0.0, []
    for _ in range(round(seconds / TICK)):
        scene.advance(TICK)
        now = point()
        steps.append(float(np.linalg.norm(now - previous)))
        largest = max(largest, float(np.linalg.norm(now - start)))
        previous = now
    return Drift(largest, tuple(steps))


def _drift_advice(scene: Scene, robot: RobotAdapter, role: str, moved: Drift) -> str:
    """Why a robot did not hold still, and what to change."""
    if moved.settling:
        return f"still coming to a stop: its servos are too weak; {advice(robot, role + ' weak')}"
    step = scene.model.opt.timestep
    return (
        f"it wanders instead of settling: a servo too stiff for the {step:g} s timestep; "
        f"{advice(robot, role + ' stiff')}, or the timestep"
    )


def _held_point(robot: RobotAdapter) -> Callable[[], np.ndarray]:
    """What holding still keeps in place: an arm's grasp site, any other robot's root body."""
    if isinstance(robot, ArmAdapter):
        return lambda: robot.grasp_site_position
    return lambda: robot.position


def _hold(scene: Scene, robot: RobotAdapter) -> CheckResult:
    """After a tick to stop, ``hold()`` keeps the robot where it stopped."""
    robot.hold()
    scene.advance(TICK)
    moved = drift(scene, _held_point(robot), HOLD_SECONDS)
    detail = f"largest drift over {HOLD_SECONDS:.0f} s"
    if moved.largest > HOLD_TOL:
        detail += f"; {_drift_advice(scene, robot, role_of(type(robot)), moved)}"
    return bounded("hold", moved.largest, HOLD_TOL, "m", detail)


def _stable(scene: Scene, robot: RobotAdapter, role: str) -> CheckResult:
    """At the end, holding still for :data:`HOLD_SECONDS` after a tick to stop, the robot
    stays within :data:`STABLE_DRIFT` of where it stopped (a physics warning meanwhile is
    raised, as in any check)."""
    robot.hold()
    scene.advance(TICK)
    moved = drift(scene, _held_point(robot), HOLD_SECONDS)
    limit = STABLE_DRIFT[role]
    detail = f"drift holding still {HOLD_SECONDS:.0f} s, no physics warning"
    if moved.largest > limit:
        detail += f"; {_drift_advice(scene, robot, role, moved)}"
    return bounded("stable", moved.largest, limit, "m", detail)


# --- ground -----------------------------------------------------------------------------------
def _ground_leg(leg: int) -> Check:
    def check(scene: Scene, robot: GroundAdapter) -> CheckResult:
        target = GROUND_LEGS[leg]
        robot.drive_to(target)
        hint = advice(robot, "ground reach")
        return _trip(scene, robot, f"reach {leg + 1}", target, GROUND_TOL, hint)

    return check


def _ground_heading(scene: Scene, robot: GroundAdapter) -> CheckResult:
    """After the second leg the robot faces the way it drove (a 130 degree turn)."""
    (x0, y0), (x1, y1) = GROUND_LEGS
    travel = math.atan2(y1 - y0, x1 - x0)
    error = abs(wrap_angle(robot.yaw - travel))
    detail = f"travel direction {travel:.2f} rad"
    if error > HEADING_TOL:
        detail += f"; {advice(robot, 'ground heading')}"
    return bounded("heading", error, HEADING_TOL, "rad", detail)


# --- drone ------------------------------------------------------------------------------------
def _drone_altitude(scene: Scene, robot: DroneAdapter) -> CheckResult:
    x, y, _ = robot.position
    robot.fly_to((x, y, CRUISE))
    t = run_until(scene, lambda: abs(robot.position[2] - CRUISE) < ALTITUDE_TOL, CLIMB_SECONDS)
    if t is None:
        error = abs(float(robot.position[2]) - CRUISE)
        detail = f"no climb in {CLIMB_SECONDS} s; {advice(robot, 'drone altitude')}"
        return bounded("altitude", error, ALTITUDE_TOL, "m", detail)
    error = 0.0
    for _ in range(round(HOLD_SECONDS / TICK)):
        scene.advance(TICK)
        error = max(error, abs(float(robot.position[2]) - CRUISE))
    detail = f"climbed in {t:.1f} s, then held {HOLD_SECONDS} s"
    if error > ALTITUDE_TOL:
        detail += f"; {advice(robot, 'drone altitude')}"
    return bounded("altitude", error, ALTITUDE_TOL, "m", detail)


def _drone_reach(scene: Scene, robot: DroneAdapter) -> CheckResult:
    target = (*DRONE_TARGET, CRUISE)
    robot.fly_to(target)
    return _trip(scene, robot, "reach", target, DRONE_TOL, advice(robot, "drone reach"))


def _drone_yaw(scene: Scene, robot: DroneAdapter) -> CheckResult:
    goal = wrap_angle(robot.yaw + YAW_TURN)
    robot.fly_to(robot.position, yaw=goal)
    scene.advance(YAW_SECONDS)
    error = abs(wrap_angle(robot.yaw - goal))
    detail = f"a {YAW_TURN:.2f} rad turn in {YAW_SECONDS} s"
    if error > YAW_TOL:
        bounds = getattr(robot, "yaw_torque_bounds", None)  # the shipped quadrotor controller's
        if bounds is None:
            detail += f"; {advice(robot, 'drone yaw')}"
        else:
            binding = min(bounds, key=bounds.__getitem__)
            detail += (
                f"; the yaw torque cap, {bounds[binding]:.3g} N m, is {binding}'s: "
                f"{advice(robot, 'drone yaw ' + binding)}"
            )
            if binding == "yaw_share":
                detail += " (at most 1), or the rotors' drag torques (gear[5])"
    return bounded("yaw", error, YAW_TOL, "rad", detail)


# --- arm --------------------------------------------------------------------------------------
def _arm_reach(scene: Scene, robot: ArmAdapter) -> CheckResult:
    start = robot.grasp_site_position
    worst = 0.0
    for offset in ARM_OFFSETS:
        target = start + np.asarray(offset)
        try:
            robot.set_arm_targets(robot.ik(target))
        except ValueError as err:  # out of reach
            return CheckResult("reach", False, detail=str(err))
        scene.advance(ARM_SECONDS)
        worst = max(worst, float(np.linalg.norm(robot.grasp_site_position - target)))
    detail = f"{len(ARM_OFFSETS)} points 0.1 m around the start, {ARM_SECONDS} s each"
    if worst > ARM_TOL:
        detail += f"; {advice(robot, 'arm reach')}"
    return bounded("reach", worst, ARM_TOL, "m", detail)


def _arm_hold(scene: Scene, robot: ArmAdapter) -> CheckResult:
    start = robot.grasp_site_position
    robot.hold()
    scene.advance(HOLD_SECONDS)
    moved = float(np.linalg.norm(robot.grasp_site_position - start))
    detail = f"grasp site drift over {HOLD_SECONDS} s"
    if moved > ARM_HOLD_TOL:
        detail += f"; {advice(robot, 'arm weak')}"
    return bounded("hold", moved, ARM_HOLD_TOL, "m", detail)


Check = Callable[[Scene, RobotAdapter], CheckResult]
MOTION_CHECKS: dict[str, tuple[tuple[str, Check], ...]] = {
    "ground": (
        ("reach 1", _ground_leg(0)),
        ("reach 2", _ground_leg(1)),
        ("heading", _ground_heading),
        ("hold", _hold),
    ),
    "drone": (("altitude", _drone_altitude), ("reach", _drone_reach), ("yaw", _drone_yaw)),
    "arm": (("reach", _arm_reach), ("hold", _arm_hold)),
}
"""Each role's checks, run in this order on one scene (each starts where the last ended)."""


def _camera(scene: Scene, robot: RobotAdapter) -> CheckResult:
    with CameraRenderer(scene.model, 64, 64) as renderer:
        image = renderer.render(scene.data, [robot.camera_name])[0]
    spread = float(image.std())
    detail = ""
    if spread < CAMERA_MIN_STD:
        detail = (
            f"a flat image: move the camera '{robot.camera}' (the MJCF's; "
            f"{type(robot).__name__}.camera names it) out of the robot's geoms, facing the scene"
        )
    return bounded("camera", spread, CAMERA_MIN_STD, "grey std", detail, at_least=True)


def check_robot(
    name: str, role: str | None = None, timestep: float | None = None
) -> list[CheckResult]:
    """Run the checks of ``role`` (default: the adapter's own) on registered robot ``name``.

    A robot that cannot be composed fails ``compose`` and nothing else runs; a physics warning
    fails ``stable`` and the check it happened in, and the remaining motion checks do not run.
    """
    spec = get_robot(name)
    adapter = spec.adapter_class()
    role = role or role_of(adapter)
    if role not in ROLES:
        raise ValueError(f"unknown role {role!r}; roles: {', '.join(ROLES)}")
    if not issubclass(adapter, ROLES[role]):
        detail = f"{adapter.__name__} is not a {ROLES[role].__name__}"
        try:
            detail += f": check it as --role {role_of(adapter)}"
        except ValueError:
            detail += f" (subclass one of {', '.join(b.__name__ for b in ROLES.values())})"
        return [CheckResult("role", False, detail=detail)]
    timestep = TIMESTEPS[role] if timestep is None else timestep
    try:
        scene = compose(spec, timestep)
    except (ValueError, KeyError, TypeError) as err:  # what a robot file or adapter gets wrong
        message = err.args[0] if isinstance(err, KeyError) and err.args else err
        return [CheckResult("compose", False, detail=f"{type(err).__name__}: {message}")]
    robot = scene.robots[PREFIX]
    results = [CheckResult("compose", True, detail=f"{adapter.__name__}, timestep {timestep} s")]
    checks = MOTION_CHECKS[role]
    for k, (check_name, check) in enumerate((*checks, ("stable", None))):
        try:
            results.append(_stable(scene, robot, role) if check is None else check(scene, robot))
        except PhysicsInstability as err:
            if check is not None:
                results.append(CheckResult(check_name, False, detail="physics went unstable"))
                results += [CheckResult(n, False, detail="not run") for n, _ in checks[k + 1 :]]
            detail = f"{err} ({advice(robot, role + ' stiff')})"
            results.append(CheckResult("stable", False, detail=detail))
            break
    results.append(_camera(scene, robot))
    return results


# --- command line -----------------------------------------------------------------------------
def add_check_robot_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``check-robot`` (for :func:`cmd_check_robot`)."""
    parser.add_argument("--robot", required=True, help="registered robot name")
    parser.add_argument(
        "--role", choices=tuple(ROLES), help="the role to check (default: its adapter's)"
    )
    parser.add_argument(
        "--timestep",
        type=float,
        help="physics step in s (default: ground/arm 0.02 as Tool Delivery, drone 0.005)",
    )


def cmd_check_robot(args: argparse.Namespace) -> int:
    """Print the report of :func:`check_robot`; exit status 0 if every check passed, else 1."""
    role = args.role or role_of(get_robot(args.robot).adapter_class())
    results = check_robot(args.robot, role, args.timestep)
    print(format_report(args.robot, role, results))
    return 0 if all(r.passed for r in results) else 1
