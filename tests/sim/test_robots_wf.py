"""Water Filling robots (vehicle, drone, diffbot) and the jar prop, in the real WF scene."""

from __future__ import annotations

# isort: off
import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
# isort: on

import inspect
import math

import numpy as np
import pytest

from maopg.sim import robots
from maopg.sim.checks import check_robot, format_report
from maopg.sim.props import JarHandle
from maopg.sim.render import CameraRenderer
from maopg.sim.robots import ASSETS_DIR, DroneAdapter, get_robot, register_robot, robot_names
from maopg.sim.scene import Scene, SceneBuilder
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.scene import read_arena

JARS = read_arena(Config()).jar_xy


def run_until(scene: Scene, done, limit: float, dt: float = 0.05) -> float | None:
    """Advance in ``dt`` steps until ``done()``; the elapsed time, or None after ``limit``."""
    t = 0.0
    while t < limit:
        scene.advance(dt)
        t += dt
        if done():
            return t
    return None


def test_vehicle_reaches_waypoint_3m_away_at_half_a_metre_per_second(wf_scene) -> None:
    scene = wf_scene()
    vehicle = scene.robots["vehicle"]
    start = vehicle.position
    goal = (start[0] + 3.0, start[1])
    vehicle.drive_to(goal)
    speeds = []
    last = start.copy()

    def arrived() -> bool:
        nonlocal last
        pos = vehicle.position
        speeds.append(np.linalg.norm(pos[:2] - last[:2]) / 0.05)
        last = pos
        return vehicle.at(goal, 0.05)

    t = run_until(scene, arrived, limit=10.0)
    assert t is not None, f"vehicle stuck at {vehicle.position}"
    assert 5.9 <= t <= 7.0, f"3 m took {t:.2f} s (0.5 m/s -> 6 s)"
    cruise = np.median(speeds[20:100])
    assert cruise == pytest.approx(0.5, abs=0.02)
    scene.advance(2.0)  # it stays there
    assert vehicle.at(goal, 0.05)


def test_drone_takes_off_holds_altitude_and_flies_5m_at_2mps(wf_scene) -> None:
    scene = wf_scene()
    drone = scene.robots["drone"]
    ground = drone.position
    assert ground[2] < 0.15  # starts on its skids
    cruise_z = 1.5
    drone.fly_to((ground[0], ground[1], cruise_z))
    t_up = run_until(scene, lambda: abs(drone.position[2] - cruise_z) < 0.02, limit=4.0)
    assert t_up is not None, f"did not climb: {drone.position}"
    alt_err = []
    run_until(scene, lambda: alt_err.append(abs(drone.position[2] - cruise_z)) and False, 3.0)
    assert max(alt_err) < 0.05

    start = drone.position
    goal = start + np.array([-4.0, 3.0, 0.0])  # 5 m, over the north-west partition
    drone.fly_to(goal)
    speeds, alt_err = [], []

    def arrived() -> bool:
        speeds.append(float(np.linalg.norm(drone.velocity[:2])))
        alt_err.append(abs(drone.position[2] - cruise_z))
        return drone.at(goal, 0.1)

    t = run_until(scene, arrived, limit=6.0)
    assert t is not None, f"drone did not arrive: {drone.position}"
    assert t <= 5.0 / 2.0 + 1.0, f"5 m took {t:.2f} s"
    assert np.median(speeds[len(speeds) // 3 : 2 * len(speeds) // 3]) == pytest.approx(
        2.0, abs=0.15
    )
    assert max(speeds) < 2.3
    assert max(alt_err) < 0.05
    # it really flies: it must tilt to accelerate (a sliding body would stay level)
    scene.advance(1.0)
    assert drone.at(goal, 0.05)


def test_drone_turns_to_a_commanded_yaw_while_hovering(wf_scene) -> None:
    scene = wf_scene()
    drone = scene.robots["drone"]
    p = drone.position
    drone.fly_to((p[0], p[1], 1.2), yaw=math.pi / 2)
    scene.advance(4.0)
    assert abs(drone.yaw - math.pi / 2) < 0.05
    assert drone.at((p[0], p[1], 1.2), 0.05)


def test_drone_adapters_take_the_documented_fly_to_with_a_yaw() -> None:
    """Water Filling turns the drone to face a jar through ``fly_to(..., yaw=...)``; the base
    class documents that signature, so an adapter written to it works there."""
    documented = inspect.signature(DroneAdapter.fly_to)
    assert list(documented.parameters) == ["self", "xyz", "speed", "yaw"]
    drones = [get_robot(n).adapter_class() for n in robot_names()]
    drones = [cls for cls in drones if issubclass(cls, DroneAdapter)]
    assert drones
    for cls in drones:
        assert inspect.signature(cls.fly_to) == documented, cls.__name__


def test_drone_controller_scales_by_the_body_frame_inertia(tmp_path, monkeypatch) -> None:
    """A full inertia has a rotated principal frame (``body_iquat``): the attitude loop must use
    R diag(I) R^T, not the principal moments as if they were about the body axes."""
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    diagonal = 'diaginertia="0.012 0.012 0.022"'
    text = (ASSETS_DIR / "robots" / "drone.xml").read_text()
    assert diagonal in text
    path = tmp_path / "tilted_inertia_drone.xml"
    path.write_text(text.replace(diagonal, 'fullinertia="0.011 0.016 0.022 0.003 0 0"'))
    register_robot("tilted", path, "maopg.sim.robots.drone:DroneAdapter")
    builder = SceneBuilder("arenas/water_filling.xml", timestep=0.005)
    builder.add_robot("d", "tilted", (0.0, 0.0, 0.0))
    scene = builder.build()
    assert not np.allclose(scene.model.body_iquat[scene.robots["d"].root_body_id], (1, 0, 0, 0))
    body_frame = [[0.011, 0.003, 0.0], [0.003, 0.016, 0.0], [0.0, 0.0, 0.022]]
    np.testing.assert_allclose(scene.robots["d"].inertia, body_frame, atol=1e-12)
    results = check_robot("tilted", "drone")
    assert all(r.passed for r in results), format_report("tilted", "drone", results)


def test_drone_tilts_to_move(wf_scene) -> None:
    scene = wf_scene()
    drone = scene.robots["drone"]
    p = drone.position
    drone.fly_to((p[0], p[1], 1.2))
    scene.advance(2.0)
    drone.fly_to((p[0] + 3.0, p[1], 1.2))
    scene.advance(0.5)
    zaxis = scene.data.xmat[drone.root_body_id].reshape(3, 3)[:, 2]
    assert zaxis[0] > 0.1, "accelerating toward +x needs the thrust axis tilted toward +x"


def test_diffbot_rolls_to_a_waypoint_3m_away(wf_scene) -> None:
    scene = wf_scene(vehicle_robot="diffbot", vehicle_start=(-1.0, 0.5))  # a swapped vehicle
    bot = scene.robots["vehicle"]
    goal = (2.0, 0.5)
    bot.drive_to(goal)
    t = run_until(scene, lambda: bot.at(goal, 0.08), limit=10.0)
    assert t is not None, f"diffbot stuck at {bot.position}"
    assert t <= 3.0 / 0.55 + 1.5, f"3 m took {t:.2f} s"
    wheel = scene.model.joint("vehicle/wheel_left")
    # motion came from the wheels: ~3 m / 0.06 m radius of rolling
    assert scene.data.qpos[wheel.qposadr[0]] == pytest.approx(3.0 / 0.06, rel=0.1)
    # a target behind it: it turns round and gets there too
    bot.drive_to((1.0, -0.5))
    assert run_until(scene, lambda: bot.at((1.0, -0.5), 0.08), limit=8.0) is not None


def test_jar_liquid_level_is_visible_from_the_drone_camera(wf_scene) -> None:
    scene = wf_scene()
    drone = scene.robots["drone"]
    spot = JARS[1] + 0.95 * np.array([-math.sqrt(0.5), -math.sqrt(0.5)])
    drone.fly_to((spot[0], spot[1], 1.15), yaw=math.pi / 4)  # face the jar
    run_until(scene, lambda: drone.at((spot[0], spot[1], 1.15), 0.03), limit=8.0)
    handle = JarHandle(scene.model, "jar1", scene.data)
    with CameraRenderer(scene.model, 64, 64) as renderer:
        handle.set_level(1.0)
        full = renderer.render(scene.data, [drone.camera_name])[0].astype(int)
        handle.set_level(0.2)
        low = renderer.render(scene.data, [drone.camera_name])[0].astype(int)
    assert handle.level == pytest.approx(0.2)

    def yellow(img: np.ndarray) -> int:
        """Liquid-coloured pixels: strongly yellow, unlike the brown floor and the grey walls."""
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        return int(np.sum((r - b > 80) & (g - b > 50)))

    changed = np.abs(full - low).sum(axis=-1) > 60
    assert changed.sum() >= 20, f"only {changed.sum()} pixels changed"
    assert yellow(full) >= 2 * yellow(low) + 10, (yellow(full), yellow(low))


def test_jar_level_geometry_follows_level_and_clips(wf_scene) -> None:
    scene = wf_scene()
    handle = JarHandle(scene.model, "jar0", scene.data)
    g = handle.geom_id
    full_top = scene.model.geom_pos[g, 2] + scene.model.geom_size[g, 1]
    bottom = scene.model.geom_pos[g, 2] - scene.model.geom_size[g, 1]
    handle.set_level(0.5)
    assert scene.model.geom_pos[g, 2] - scene.model.geom_size[g, 1] == pytest.approx(bottom)
    assert scene.model.geom_size[g, 1] * 2 == pytest.approx((full_top - bottom) / 2)
    handle.set_level(-3.0)
    assert handle.level == 0.0 and scene.model.geom_size[g, 1] > 0
    handle.set_level(7.0)
    assert scene.model.geom_pos[g, 2] + scene.model.geom_size[g, 1] == pytest.approx(full_top)
    with pytest.raises(KeyError, match="nojar/liquid"):
        JarHandle(scene.model, "nojar")
