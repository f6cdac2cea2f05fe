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
every role  its adapter binds (``compose``), no physics warning (``stable``), and the camera
            renders a non-flat image (``camera``).

``python -m eval check-robot --robot NAME --role ROLE`` prints the report
(:func:`cmd_check_robot`); the every-robot test in ``tests/sim`` asserts that every registered
robot passes, so a shipped robot that breaks one of them fails the suite.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from maopg.sim.render import CameraRenderer
from maopg.sim.robots import (
    ArmAdapter,
    DroneAdapter,
    GroundAdapter,
    RobotAdapter,
    RobotSpec,
    get_robot,
)
from maopg.sim.robots.base import wrap_angle
from maopg.sim.scene import PhysicsInstability, Scene, SceneBuilder

ROLES: dict[str, type[RobotAdapter]] = {
    "ground": GroundAdapter,
    "drone": DroneAdapter,
    "arm": ArmAdapter,
}
"""Each role and the adapter class a robot in it must have."""
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


def role_of(adapter: type[RobotAdapter]) -> str:
    """The role an adapter class plays (the first of :data:`ROLES` it subclasses)."""
    for role, base in ROLES.items():
        if issubclass(adapter, base):
            return role
    bases = ", ".join(b.__name__ for b in ROLES.values())
    raise ValueError(f"{adapter.__name__} is none of {bases}: it has no role to check")


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
    scene: Scene, robot: RobotAdapter, name: str, target: Sequence[float], tol: float
) -> CheckResult:
    """The trip to ``target`` commanded already: it must come within ``tol`` at a tick
    before its full-speed travel time plus :data:`SLACK` (the figure: the time it took)."""
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
    detail = (
        f"to {where}: {'error' if t is not None else 'closest'} {closest:.3f} m (tolerance {tol} m)"
    )
    return CheckResult(name, t is not None, limit if t is None else t, limit, "s", detail)


def _hold(scene: Scene, robot: RobotAdapter) -> CheckResult:
    """After a tick to stop, ``hold()`` keeps the robot where it stopped."""
    robot.hold()
    scene.advance(TICK)
    start = robot.position
    drift = 0.0
    for _ in range(round(HOLD_SECONDS / TICK)):
        scene.advance(TICK)
        drift = max(drift, float(np.linalg.norm(robot.position - start)))
    return bounded("hold", drift, HOLD_TOL, "m", f"largest drift over {HOLD_SECONDS:.0f} s")


# --- ground -----------------------------------------------------------------------------------
def _ground_leg(leg: int) -> Check:
    def check(scene: Scene, robot: GroundAdapter) -> CheckResult:
        target = GROUND_LEGS[leg]
        robot.drive_to(target)
        return _trip(scene, robot, f"reach {leg + 1}", target, GROUND_TOL)

    return check


def _ground_heading(scene: Scene, robot: GroundAdapter) -> CheckResult:
    """After the second leg the robot faces the way it drove (a 130 degree turn)."""
    (x0, y0), (x1, y1) = GROUND_LEGS
    travel = math.atan2(y1 - y0, x1 - x0)
    error = abs(wrap_angle(robot.yaw - travel))
    return bounded("heading", error, HEADING_TOL, "rad", f"travel direction {travel:.2f} rad")


# --- drone ------------------------------------------------------------------------------------
def _drone_altitude(scene: Scene, robot: DroneAdapter) -> CheckResult:
    x, y, _ = robot.position
    robot.fly_to((x, y, CRUISE))
    t = run_until(scene, lambda: abs(robot.position[2] - CRUISE) < ALTITUDE_TOL, CLIMB_SECONDS)
    if t is None:
        error = abs(float(robot.position[2]) - CRUISE)
        return bounded("altitude", error, ALTITUDE_TOL, "m", f"no climb in {CLIMB_SECONDS} s")
    error = 0.0
    for _ in range(round(HOLD_SECONDS / TICK)):
        scene.advance(TICK)
        error = max(error, abs(float(robot.position[2]) - CRUISE))
    return bounded(
        "altitude", error, ALTITUDE_TOL, "m", f"climbed in {t:.1f} s, then held {HOLD_SECONDS} s"
    )


def _drone_reach(scene: Scene, robot: DroneAdapter) -> CheckResult:
    target = (*DRONE_TARGET, CRUISE)
    robot.fly_to(target)
    return _trip(scene, robot, "reach", target, DRONE_TOL)


def _drone_yaw(scene: Scene, robot: DroneAdapter) -> CheckResult:
    goal = wrap_angle(robot.yaw + YAW_TURN)
    robot.fly_to(robot.position, yaw=goal)
    scene.advance(YAW_SECONDS)
    error = abs(wrap_angle(robot.yaw - goal))
    return bounded("yaw", error, YAW_TOL, "rad", f"a {YAW_TURN:.2f} rad turn in {YAW_SECONDS} s")


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
    return bounded("reach", worst, ARM_TOL, "m", detail)


def _arm_hold(scene: Scene, robot: ArmAdapter) -> CheckResult:
    start = robot.grasp_site_position
    robot.hold()
    scene.advance(HOLD_SECONDS)
    drift = float(np.linalg.norm(robot.grasp_site_position - start))
    return bounded("hold", drift, ARM_HOLD_TOL, "m", f"grasp site drift over {HOLD_SECONDS} s")


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
    return bounded("camera", spread, CAMERA_MIN_STD, "grey std", at_least=True)


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
        return [CheckResult("role", False, detail=detail)]
    timestep = TIMESTEPS[role] if timestep is None else timestep
    try:
        scene = compose(spec, timestep)
    except (ValueError, KeyError, TypeError) as err:  # what a robot file or adapter gets wrong
        return [CheckResult("compose", False, detail=f"{type(err).__name__}: {err}")]
    robot = scene.robots[PREFIX]
    results = [CheckResult("compose", True, detail=f"{adapter.__name__}, timestep {timestep} s")]
    checks = MOTION_CHECKS[role]
    for k, (check_name, check) in enumerate(checks):
        try:
            results.append(check(scene, robot))
        except PhysicsInstability as err:
            results.append(CheckResult(check_name, False, detail="physics went unstable"))
            results += [CheckResult(n, False, detail="not run") for n, _ in checks[k + 1 :]]
            results.append(CheckResult("stable", False, detail=str(err)))
            break
    else:
        results.append(CheckResult("stable", True, detail="no physics warning"))
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
