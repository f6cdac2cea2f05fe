"""Every registered robot in a real scene, and the Tool Delivery robots' controllers."""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import math

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np
import pytest

from maopg.sim.checks import check_robot, format_report, role_of
from maopg.sim.robots import get_robot, robot_names
from maopg.sim.scene import SceneBuilder

TICK = 1.0


# --- every registered robot ------------------------------------------------------------------
@pytest.mark.parametrize("name", robot_names())
def test_registered_robot_passes_the_checks_of_its_role(name: str) -> None:
    """What ``python -m eval check-robot --robot NAME`` checks (maopg/sim/checks.py)."""
    spec = get_robot(name)
    assert spec.mjcf.exists(), f"{name}: {spec.mjcf} is missing"
    role = role_of(spec.adapter_class())
    results = check_robot(name, role)
    assert all(r.passed for r in results), format_report(name, role, results)


@pytest.mark.parametrize("name", robot_names())
def test_registered_robot_survives_raw_controls(name: str) -> None:
    builder = SceneBuilder("arenas/tool_delivery.xml", timestep=0.01)
    builder.add_robot("r", name, (5.0, 2.0, 0.0), yaw=0.3)
    scene = builder.build()
    model, data = scene.model, scene.data
    # 1,000 ticks of zero actuator commands (a drone simply falls and lands), then 1,000 of
    # random raw commands (within ctrlrange where limited).
    for _ in range(1000):
        mujoco.mj_step(model, data, nstep=50)
    assert np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()
    rng = np.random.default_rng(0)
    lo, hi = model.actuator_ctrlrange[:, 0], model.actuator_ctrlrange[:, 1]
    limited = model.actuator_ctrllimited.astype(bool)
    for _ in range(1000):
        ctrl = rng.uniform(-1.0, 1.0, model.nu)
        data.ctrl[:] = np.where(limited, lo + (ctrl + 1.0) / 2.0 * (hi - lo), ctrl)
        mujoco.mj_step(model, data, nstep=50)
    assert np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()
    assert data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0, f"{name} went unstable"


# --- Turtlebot -------------------------------------------------------------------------------
def test_turtlebot_drives_3m_at_0p6_and_arrives_without_overshoot(td_scene) -> None:
    scene = td_scene(tb0=(3.0, 2.5), tb1=(3.0, 1.5))
    tb = scene.robots["turtlebot0"]
    goal = (6.0, 2.5)
    tb.drive_to(goal)
    xs = [tb.position[0]]
    for _ in range(6):
        scene.advance(TICK)
        xs.append(tb.position[0])
    steps = np.diff(xs)
    # full speed every tick (the first loses ~6 mm to the servo lag), arriving in the 6th
    assert steps[:5] == pytest.approx([0.6] * 5, abs=0.01)
    assert np.all(steps[:5] > 0), "it must not reverse"
    assert max(xs) < goal[0] + 0.002, "overshoot"
    assert tb.at(goal, tol=0.002)
    assert abs(tb.position[1] - goal[1]) < 0.01
    assert abs(tb.yaw) < 0.05, "heading follows the motion (east)"


def test_turtlebot_heading_follows_motion_and_stops_at_walls(td_scene) -> None:
    scene = td_scene()
    tb = scene.robots["turtlebot0"]
    tb.set_velocity(0.0, -0.6)  # south, into the south wall (inner face y = 0)
    for _ in range(5):
        scene.advance(TICK)
    assert tb.yaw == pytest.approx(-math.pi / 2, abs=0.05)
    radius = 0.177
    assert radius - 0.02 < tb.position[1] < radius + 0.02, "walls stop the base"


def test_turtlebots_share_a_waypoint(td_scene) -> None:
    """Ground robots do not collide with each other: both can stand at WA0."""
    scene = td_scene()
    for name in ("turtlebot0", "turtlebot1"):
        scene.robots[name].drive_to((6.0, 3.0))
    for _ in range(8):
        scene.advance(TICK)
    assert scene.robots["turtlebot0"].at((6.0, 3.0), 0.02) and scene.robots["turtlebot1"].at(
        (6.0, 3.0), 0.02
    )


# --- Fetch -----------------------------------------------------------------------------------
def test_fetch_reaches_joint_targets_in_bounded_time(td_scene) -> None:
    scene = td_scene()
    fetch = scene.robots["fetch"]
    for target in ([1.0, 0.4, -1.2, -0.8], [-2.5, 0.9, -2.0, -0.4], [0.0, 0.0, 0.0, 0.0]):
        fetch.set_arm_targets(np.array(target))
        scene.advance(2.0)
        np.testing.assert_allclose(fetch.joint_positions(), target, atol=0.01)
        assert fetch.reached(0.01)


@pytest.mark.parametrize(
    "where",
    ["shelf/slot0", "shelf/slot1", "shelf/slot2", "desk/slot0", "desk/slot1", "basket0", "basket1"],
)
def test_fetch_ik_reaches_shelf_desk_and_baskets(where: str, td_scene) -> None:
    # Turtlebots parked at their desk spots, as during a pass.
    scene = td_scene(tb0=(0.8, 3.0), tb1=(1.2, 3.0))
    fetch = scene.robots["fetch"]
    if where.startswith("basket"):
        target = scene.body_position(f"turtlebot{where[-1]}/basket") + np.array((0.0, 0.0, 0.06))
    else:
        target = scene.site_position(where) + np.array((0.0, 0.0, 0.03))
    fetch.set_arm_targets(fetch.ik(target))
    scene.advance(3.0)
    assert np.linalg.norm(fetch.grasp_site_position - target) < 0.02


def test_fetch_ik_rejects_unreachable_targets(td_scene) -> None:
    scene = td_scene()
    with pytest.raises(ValueError, match="out of reach"):
        scene.robots["fetch"].ik((6.0, 3.0, 0.5))
