"""The quadrotor controller takes its scale from the model: a drone of another size and layout
than the shipped one flies with the shipped constants, and a rotor layout it cannot use is
refused with what to change."""

from __future__ import annotations

# isort: off
import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
# isort: on

import mujoco
import numpy as np
import pytest

from maopg.sim import robots
from maopg.sim.checks import check_robot, compose, format_report
from maopg.sim.robots import get_robot, register_robot
from maopg.sim.robots.drone import DroneAdapter, DroneConstants, subtree_inertia

ROTORS = ("thrust_a", "thrust_b", "thrust_c", "thrust_d")
"""Rear right, rear left, front left, front right: round the frame, as collections order them."""
CORNERS = ((-0.16, -0.21), (-0.16, 0.21), (0.16, 0.21), (0.16, -0.21))
"""Rotor positions (m): 0.26 m arms, where the shipped drone's are 0.17 m."""
SPINS = (-1, 1, -1, 1)
"""Diagonal rotors spin the same way, adjacent ones opposite ways."""
CONSTANTS = DroneConstants(rotors=ROTORS)


def quadrotor(
    spins=SPINS, *, motor_range: str = 'ctrlrange="0 14"', props_as_bodies: bool = True
) -> str:
    """A 1.58 kg quadrotor (the shipped one: 1.2 kg): a 0.7 kg core and four 0.22 kg props,
    each prop a child body of the frame (or, ``props_as_bodies=False``, a geom of it), thrust
    sites on the frame, and the rotors' drag torques (gear[5], N m per N) of signs ``spins``."""
    props, sites, motors = [], [], []
    for name, (x, y), spin in zip(ROTORS, CORNERS, spins, strict=True):
        prop = f'<geom type="cylinder" size="0.1 0.01" pos="{x} {y} 0.045" mass="0.22"/>'
        props.append(f"<body>{prop}</body>" if props_as_bodies else prop)
        sites.append(f'<site name="{name}" pos="{x} {y} 0.045"/>')
        motors.append(
            f'<motor name="{name}" site="{name}" gear="0 0 1 0 0 {0.02 * spin}" {motor_range}/>'
        )
    return f"""<mujoco model="quad">
  <default><default class="quad"><geom contype="0" conaffinity="0" group="2"/></default></default>
  <worldbody>
    <body name="frame" pos="0 0 0.12" childclass="quad">
      <freejoint/>
      <geom name="core" type="box" size="0.1 0.07 0.04" mass="0.7"/>
      <geom name="hull" type="box" size="0.22 0.27 0.05" contype="1" conaffinity="1" mass="0"/>
      <camera name="fpv" pos="0.12 0 -0.02" xyaxes="0 -1 0 0.574 0 0.819" fovy="80"/>
      {"".join(sites)}
      {"".join(props)}
    </body>
  </worldbody>
  <actuator>{"".join(motors)}</actuator>
</mujoco>"""


class QuadAdapter(DroneAdapter):
    root_body = "frame"
    camera = "fpv"


@pytest.fixture
def register(tmp_path, monkeypatch):
    """Registers a quadrotor file under a name, in a private copy of the registry."""
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))

    def add(name: str, text: str, constants: DroneConstants = CONSTANTS) -> str:
        path = tmp_path / f"{name}.xml"
        path.write_text(text)
        register_robot(name, path, QuadAdapter, constants)
        return name

    return add


def test_a_quadrotor_of_another_size_passes_the_checks_with_the_shipped_gains(register) -> None:
    """Its yaw inertia (0.069 kg m^2 against 0.022) needs three times the shipped drone's yaw
    torque for the same turn: the shipped drone's 0.04 N m cap, as an absolute constant, left it
    1.08 rad short of the check's 90 degree turn."""
    name = register("quad", quadrotor())
    results = check_robot(name, "drone")
    assert all(r.passed for r in results), format_report(name, "drone", results)
    drone = compose(get_robot(name), 0.005).robots["robot"]
    assert drone.inertia[2, 2] == pytest.approx(0.069, abs=0.001)
    assert drone.yaw_torque_cap == pytest.approx(CONSTANTS.max_yaw_accel * drone.inertia[2, 2])


def test_the_inertia_is_the_whole_subtrees_about_its_centre_of_mass() -> None:
    """Props as child bodies weigh in as if they were geoms of the frame (where MuJoCo sums
    them itself)."""
    split = mujoco.MjModel.from_xml_string(quadrotor())
    merged = mujoco.MjModel.from_xml_string(quadrotor(props_as_bodies=False))
    assert split.nbody == 6 and merged.nbody == 2
    com, inertia = subtree_inertia(split, 1)
    expected_com, expected = subtree_inertia(merged, 1)
    np.testing.assert_allclose(com, merged.body_ipos[1], atol=1e-12)
    np.testing.assert_allclose(com, expected_com, atol=1e-12)
    np.testing.assert_allclose(inertia, expected, atol=1e-12)
    assert inertia[1, 1] < inertia[0, 0] < inertia[2, 2]  # the frame is wider than it is long


def test_the_shipped_drone_keeps_its_yaw_torque_cap() -> None:
    """0.04 N m, as when the cap was a constant: Water Filling's trajectories are unchanged."""
    drone = compose(get_robot("drone"), 0.005).robots["robot"]
    assert drone.yaw_torque_cap == 0.04
    assert drone.yaw_torque_bounds["yaw_share"] > 0.04


def test_diagonal_rotors_spinning_opposite_ways_are_refused_with_the_signs_to_set(
    register,
) -> None:
    """Adjacent rotors sharing a spin (as in a collection's file whose yaw signs follow the
    rotor numbers) make the yaw column a copy of the roll column."""
    name = register("x_signs", quadrotor(spins=(-1, 1, 1, -1)))
    results = check_robot(name, "drone")
    assert [r.name for r in results] == ["compose"]
    detail = results[0].detail
    assert (
        "cannot produce roll torque or yaw torque (their wrench matrix has rank 3 of 4)" in detail
    )
    assert "diagonal rotors (thrust_a/thrust_c, thrust_b/thrust_d) spin the same way" in detail
    assert "now thrust_a -0.02, thrust_b +0.02, thrust_c +0.02, thrust_d -0.02" in detail
    assert detail.endswith("make the signs thrust_a -, thrust_b +, thrust_c -, thrust_d +")


def test_rotors_without_a_ctrlrange_are_unlimited(register) -> None:
    """MuJoCo leaves an unlimited actuator's range at 0 0: read as limits, it grounds the
    drone."""
    scene = compose(get_robot(register("free", quadrotor(motor_range=""))), 0.005)
    drone = scene.robots["robot"]
    start = drone.position
    drone.fly_to((start[0], start[1], start[2] + 1.0))
    scene.advance(1.0)
    assert drone.position[2] > start[2] + 0.3


def test_rotors_too_weak_to_hover_are_refused_naming_the_ctrlrange(register) -> None:
    name = register("weak", quadrotor(motor_range='ctrlrange="0 3"'))
    (result,) = check_robot(name, "drone")
    assert "rotor thrust_a must push 3.87 N to hover the drone's 1.58 kg" in result.detail
    assert "raise the rotors' ctrlrange upper bound" in result.detail
