"""Scene composition, registry errors, welds (attach/detach) and determinism, on real physics."""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import warnings

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np
import pytest

from maopg.sim import robots
from maopg.sim.render import CameraRenderer
from maopg.sim.robots import ASSETS_DIR, get_robot, register_robot, robot_names
from maopg.sim.robots.turtlebot import TurtlebotAdapter, TurtlebotConstants
from maopg.sim.scene import MJCFError, PhysicsInstability, Scene, SceneBuilder
from maopg.tasks.tool_delivery.config import Config as TDConfig
from maopg.tasks.tool_delivery.scene import build_scene as build_td_scene


def test_composed_scene_has_prefixed_robots_props_and_cameras(td_scene) -> None:
    scene = td_scene()
    assert set(scene.robots) == {"fetch", "turtlebot0", "turtlebot1"}
    assert scene.robots["turtlebot1"].camera_name == "turtlebot1/camera"
    np.testing.assert_allclose(scene.robots["turtlebot1"].position, (3.0, 2.5, 0.0), atol=1e-9)
    np.testing.assert_allclose(scene.site_position("desk/slot0"), (1.6, 1.8, 0.75), atol=1e-9)
    # every tool starts on its shelf slot, held by the world
    for i in range(3):
        tool = scene.body_position(f"tool{i}/tool")
        assert np.linalg.norm(tool[:2] - scene.site_position(f"shelf/slot{i}")[:2]) < 1e-9
        assert scene.holder_of(f"tool{i}/tool") is None
    assert scene.model.vis.global_.offwidth >= 640 and scene.model.vis.global_.offheight >= 480


def test_unknown_robot_lists_known_names() -> None:
    with pytest.raises(KeyError) as err:
        get_robot("r2d2")
    for name in ("turtlebot", "fetch", "vehicle", "drone", "diffbot"):
        assert name in str(err.value)
    builder = SceneBuilder("arenas/tool_delivery.xml", timestep=0.02)
    with pytest.raises(KeyError, match=r"known robots: .*turtlebot"):
        builder.add_robot("x", "r2d2", (1.0, 1.0, 0.0))


def test_malformed_mjcf_names_the_file_and_mujocos_message(tmp_path, monkeypatch) -> None:
    bad = tmp_path / "broken_robot.xml"
    bad.write_text("<mujoco><worldbody><body name='base'><geom type='box'/></bodyy></worldbody>")
    with pytest.raises(MJCFError) as err:
        SceneBuilder(bad, timestep=0.02)
    assert str(bad) in str(err.value) and "MISMATCHED_ELEMENT" in str(err.value)

    wrong = tmp_path / "wrong_attr.xml"  # well-formed XML that MuJoCo's schema rejects
    wrong.write_text("<mujoco><worldbody><geom type='box' sizee='1 1 1'/></worldbody></mujoco>")
    with pytest.raises(MJCFError) as err:
        SceneBuilder(wrong, timestep=0.02)
    assert str(wrong) in str(err.value) and "sizee" in str(err.value)

    # the same through the registry: a user robot whose file is broken
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    register_robot("broken", bad, TurtlebotAdapter)
    builder = SceneBuilder("arenas/tool_delivery.xml", timestep=0.02)
    with pytest.raises(MJCFError, match=r"broken_robot\.xml"):
        builder.add_robot("b", "broken", (1.0, 1.0, 0.0))


def test_user_robot_registered_from_a_file_and_duplicates_refused(monkeypatch) -> None:
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    slow = TurtlebotConstants(max_speed=0.3)
    register_robot("slowbot", "robots/turtlebot.xml", TurtlebotAdapter, slow)
    assert "slowbot" in robot_names()
    with pytest.raises(ValueError, match="already registered"):
        register_robot("slowbot", "robots/turtlebot.xml", TurtlebotAdapter)
    builder = SceneBuilder("arenas/tool_delivery.xml", timestep=0.02)
    builder.add_robot("s", "slowbot", (4.0, 2.5, 0.0))
    scene = builder.build()
    scene.robots["s"].drive_to((6.0, 2.5))
    scene.advance(1.0)
    assert scene.robots["s"].position[0] == pytest.approx(4.3, abs=0.01)


def test_advance_rejects_a_duration_that_is_not_whole_steps(td_scene) -> None:
    scene = td_scene()
    with pytest.raises(ValueError, match="multiple of the timestep"):
        scene.advance(0.013)


def _random_episode(scene: Scene, seed: int, ticks: int = 40) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    fetch = scene.robots["fetch"]
    for t in range(ticks):
        for name in ("turtlebot0", "turtlebot1"):
            scene.robots[name].set_velocity(*rng.uniform(-0.6, 0.6, 2))
        fetch.set_arm_targets(rng.uniform(-1.0, 1.0, 4))
        fetch.set_gripper(bool(rng.integers(2)))
        if t == 10:
            scene.attach("tool1/tool", "turtlebot0/basket")
        scene.advance(1.0)
    return scene.data.qpos.copy(), scene.data.qvel.copy()


def test_same_seed_gives_bit_identical_state_across_builds(td_scene) -> None:
    qpos_a, qvel_a = _random_episode(td_scene(), seed=7)
    qpos_b, qvel_b = _random_episode(td_scene(), seed=7)
    assert np.array_equal(qpos_a, qpos_b) and np.array_equal(qvel_a, qvel_b)
    qpos_c, _ = _random_episode(td_scene(), seed=8)
    assert not np.array_equal(qpos_a, qpos_c)


def test_tool_travels_shelf_to_gripper_to_desk_to_basket_without_jumps(td_scene) -> None:
    scene = td_scene(tb0=(0.8, 3.0))
    fetch, tb0 = scene.robots["fetch"], scene.robots["turtlebot0"]
    tool = "tool2/tool"
    grasp_point = scene.body_position(tool)

    fetch.set_arm_targets(fetch.ik(grasp_point))
    scene.advance(3.0)
    before = scene.body_position(tool)
    np.testing.assert_allclose(before, grasp_point, atol=1e-3)  # the world weld held it
    scene.attach(tool, fetch.gripper_body)
    fetch.set_gripper(True)
    assert scene.holder_of(tool) == "fetch/gripper"
    scene.advance(0.02)
    assert np.linalg.norm(scene.body_position(tool) - before) < 1e-3, "jump on attach"

    # carried to the desk slot, the tool follows the gripper at a constant offset
    offset = scene.body_position(tool) - fetch.grasp_site_position
    slot = scene.site_position("desk/slot1") + np.array((0.0, 0.0, 0.03))
    fetch.set_arm_targets(fetch.ik(slot))
    for _ in range(3):
        scene.advance(1.0)
        drift = scene.body_position(tool) - fetch.grasp_site_position - offset
        assert np.linalg.norm(drift) < 0.01
    assert np.linalg.norm(scene.body_position(tool) - slot) < 0.02

    # put down: welded to the world, it stays while the arm leaves
    placed = scene.body_position(tool)
    scene.attach(tool, None)
    fetch.set_gripper(False)
    fetch.set_arm_targets(np.zeros(4))
    scene.advance(2.0)
    assert np.linalg.norm(scene.body_position(tool) - placed) < 1e-3
    assert np.linalg.norm(fetch.grasp_site_position - placed) > 0.3

    # into the basket of Turtlebot 0, which then drives off with it
    fetch.set_arm_targets(fetch.ik(placed))
    scene.advance(3.0)
    scene.attach(tool, fetch.gripper_body)
    basket = scene.body_position(tb0.basket_body) + np.array((0.0, 0.0, 0.06))
    fetch.set_arm_targets(fetch.ik(basket))
    scene.advance(3.0)
    scene.attach(tool, tb0.basket_body)
    start = scene.body_position(tool)
    tb0.drive_to((2.5, 3.5))
    scene.advance(2.0)
    moved = scene.body_position(tool) - start
    np.testing.assert_allclose(moved[:2], tb0.position[:2] - (0.8, 3.0), atol=0.01)


def test_place_and_reset_restore_welds_colours_and_state(td_scene) -> None:
    scene = td_scene()
    scene.place("tool0/tool", scene.site_position("human/slot0") + np.array((0.0, 0.0, 0.01)))
    scene.advance(1.0)
    np.testing.assert_allclose(
        scene.body_position("tool0/tool"),
        scene.site_position("human/slot0") + np.array((0.0, 0.0, 0.01)),
        atol=1e-3,
    )
    scene.set_geom_rgba("human/stage0", (0.0, 1.0, 0.0, 1.0))
    scene.robots["turtlebot0"].drive_to((6.0, 3.0))
    scene.advance(1.0)
    scene.reset()
    fresh = td_scene()
    assert np.array_equal(scene.data.qpos, fresh.data.qpos)
    assert np.array_equal(scene.model.geom_rgba, fresh.model.geom_rgba)
    assert scene.holder_of("tool0/tool") is None
    scene.advance(1.0)
    fresh.advance(1.0)
    assert np.array_equal(scene.data.qpos, fresh.data.qpos), "a stale weld or command survived"


def test_attach_to_an_undeclared_holder_is_refused(td_scene) -> None:
    scene = td_scene()
    with pytest.raises(KeyError, match="no weld declared"):
        scene.attach("tool0/tool", "fetch/base")


def _standalone_turtlebot(path) -> None:
    """The Turtlebot as a stand-alone file of a robot collection: its own ``<option>``,
    ``<size>`` and ``<visual>``, a keyframe, and lights (one in the world, one on the robot)."""
    text = (ASSETS_DIR / "robots" / "turtlebot.xml").read_text()
    text = text.replace(
        "<worldbody>",
        '<option timestep="0.002" integrator="RK4" density="1.2"/>'
        '<size njmax="500" nkey="1"/><visual><map znear="0.5"/></visual>'
        '<worldbody><light name="lamp" pos="0 0 2" dir="0 0 -1" diffuse="1 0.2 0.2"/>',
    )
    text = text.replace('<body name="base">', '<body name="base"><light name="led" pos="0 0 0.5"/>')
    text = text.replace(
        "</actuator>", '</actuator><keyframe><key name="home" qpos="1 0 0"/></keyframe>'
    )
    path.write_text(text)


def test_a_robot_files_settings_keyframes_and_lights_stay_out_of_the_scene(
    tmp_path, monkeypatch, capfd
) -> None:
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    monkeypatch.chdir(tmp_path)  # where MuJoCo would write MUJOCO_LOG.TXT
    _standalone_turtlebot(tmp_path / "standalone.xml")
    register_robot("standalone", tmp_path / "standalone.xml", TurtlebotAdapter)
    plain = build_td_scene(TDConfig())
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # MuJoCo's "Attach conflict" is a Python warning too
        scene = build_td_scene(TDConfig(turtlebot_robot="standalone"))
    assert capfd.readouterr() == ("", ""), "nothing printed"
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists(), "nothing written"
    model = scene.model
    assert model.nkey == 0 and model.nlight == plain.model.nlight
    assert model.opt.timestep == 0.02 and model.opt.density == 0.0
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert model.vis.map.znear == plain.model.vis.map.znear
    # the same robot, so with its lights gone every camera sees exactly what it saw before
    cameras = [r.camera_name for r in plain.robots.values()]
    with CameraRenderer(plain.model) as a, CameraRenderer(model) as b:
        assert np.array_equal(a.render(plain.data, cameras), b.render(scene.data, cameras))
    scene.advance(1.0)
    plain.advance(1.0)
    assert np.array_equal(scene.data.qpos, plain.data.qpos)


def test_advance_raises_when_mujoco_resets_unstable_physics(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    monkeypatch.chdir(tmp_path)  # where MuJoCo's own handler would write MUJOCO_LOG.TXT
    stiff = TurtlebotConstants(yaw_kp=1e5, yaw_kv=0.0)  # far too stiff for a 20 ms step
    register_robot("stiff", "robots/turtlebot.xml", TurtlebotAdapter, stiff)
    builder = SceneBuilder("arenas/tool_delivery.xml", timestep=0.02)
    builder.add_robot("tb", "stiff", (4.5, 2.5, 0.0))
    scene = builder.build()
    scene.robots["tb"].drive_to((4.5, 4.0))  # turning north: the heading servo explodes
    with pytest.raises(PhysicsInstability) as err:
        for _ in range(5):
            scene.advance(1.0)
    assert err.value.warning == "mjWARN_BADQACC" and err.value.robot == "tb"
    assert "joint 'tb/yaw' of robot 'tb'" in str(err.value) and "reset" in str(err.value)
    with pytest.raises(PhysicsInstability):  # and again: each advance is checked afresh
        for _ in range(5):
            scene.advance(1.0)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()  # MuJoCo's warnings are logged instead
