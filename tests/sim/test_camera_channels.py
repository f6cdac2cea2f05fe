"""Camera channels and mounts on real scenes: depth against geometry, segmentation classes of
known pixels and their stability, every robot role with every channel combination, the camera
settings per role, and default images left as they were."""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import hashlib
import itertools

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np
import pytest

from maopg.env import make_env
from maopg.sim.channels import CHANNELS, ImageChannels, parse_channels
from maopg.sim.egl_check import gl_strings
from maopg.sim.render import CameraRenderer, depth_range, project_points
from maopg.sim.robots import get_robot, robot_names, role_of
from maopg.sim.segmentation import FIXED_CLASSES, class_table
from maopg.tasks import make_config, task_class
from maopg.tasks.tool_delivery.scene import build_scene

COMBINATIONS = ["+".join(c) for n in range(1, 4) for c in itertools.combinations(CHANNELS, n)]
"""Every non-empty set of channels: rgb, depth, seg, rgb+depth, ..., rgb+depth+seg."""

WALL = """
<mujoco>
  <visual><map znear="0.01" zfar="50"/></visual>
  <worldbody>
    <light pos="0 0 3"/>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="wall" type="box" pos="{x} 0 1" size="0.05 {half} {half}"/>
    <body name="distractor0" pos="1 0.2 0.8"><geom type="sphere" size="0.05"/></body>
    <body name="crate1" pos="1 -0.2 0.8"><geom type="box" size="0.05 0.05 0.05"/></body>
    <camera name="eye" pos="0 0 1" xyaxes="0 -1 0 0 0 1" fovy="60"/>
  </worldbody>
</mujoco>
"""
"""A camera 1 m up looking along +x at a wall whose face is ``x - 0.05`` m away, narrower than
the view (half its 60 degrees), so the sky shows around it; a distractor and a prop (a crate)
1 m ahead, a little lower."""


def _wall_scene(face: float) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(WALL.format(x=face + 0.05, half=0.25 * face))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _channels(names: str, model: mujoco.MjModel, classes=()) -> ImageChannels:
    chosen = parse_channels(names)
    near_far = depth_range(model) if "depth" in chosen else None
    return ImageChannels(chosen, near_far, tuple(classes) if "seg" in chosen else ())


@pytest.mark.parametrize("face", [0.5, 2.0, 3.7])
def test_a_camera_facing_a_wall_reads_its_distance(face):
    """Depth is the distance along the view axis, so every pixel of a wall square to the view
    reads the same: the wall's distance, to a millimetre; the sky around it reads ``far``."""
    model, data = _wall_scene(face)
    channels = _channels("depth", model)
    with CameraRenderer(model, 48, 48, channels=channels) as renderer:
        depth = renderer.render(data, ["eye"])[0, ..., 0]
    assert depth.dtype == np.float32
    wall = project_points(model, data, "eye", np.array([[face, 0.0, 1.0]]), 48, 48)[0]
    centre = depth[int(wall[1]) - 4 : int(wall[1]) + 4, int(wall[0]) - 4 : int(wall[0]) + 4]
    np.testing.assert_allclose(centre, face, atol=1e-3)
    near, far = depth_range(model)
    assert depth[0, 0] == np.float32(far), "the sky above the wall reads far"
    assert near <= depth.min() and depth.max() <= far


def test_segmentation_classes_a_distractor_and_an_undeclared_prop():
    model, data = _wall_scene(2.0)
    table = class_table(model, [], {})
    assert table.classes == (*FIXED_CLASSES, "crate")
    channels = _channels("seg", model, table.classes)
    with CameraRenderer(model, 64, 64, channels=channels, classes=table) as renderer:
        seg = renderer.render(data, ["eye"])[0, ..., 0]
    ids = {name: i for i, name in enumerate(table.classes)}
    points = np.array([[2.0, 0.0, 1.0], [1.0, 0.2, 0.8], [1.0, -0.2, 0.8]])
    (wx, wy), (dx, dy), (cx, cy) = project_points(model, data, "eye", points, 64, 64).astype(int)
    assert seg[wy, wx] == ids["wall"] and seg[dy, dx] == ids["distractor"]
    assert seg[cy, cx] == ids["crate"]
    assert seg[0, 0] == ids["background"] and seg[-1, 32] == ids["floor"]


CLASSES = {
    "tool_delivery": ("desk", "shelf", "human", "tool"),
    "water_filling": ("jar", "furniture"),
    "box_pushing": ("small_box", "big_box", "goal", "waypoint"),
}
"""Each built-in task's prop classes, after the classes every scene has (docs/reference)."""


@pytest.mark.parametrize("task", sorted(CLASSES))
def test_a_tasks_class_map_is_its_documented_list_on_every_build(task):
    """Two builds give the same class of every geom; a bigger team the same class list."""
    first, second = (task_class(task)(make_config(task, {})) for _ in range(2))
    try:
        assert first.segmentation.classes == (*FIXED_CLASSES, *CLASSES[task])
        np.testing.assert_array_equal(first.segmentation.geom_class, second.segmentation.geom_class)
        np.testing.assert_array_equal(first.segmentation.site_class, second.segmentation.site_class)
        assert set(first.segmentation.geom_class) >= {1, 2, 3}, "floor, walls and robots are seen"
    finally:
        first.close()
        second.close()
    big = {"water_filling": {"vehicles": 3, "drones": 2, "jars": 5}}.get(task, {})
    if big:
        assert (
            task_class(task)(make_config(task, big)).segmentation.classes
            == first.segmentation.classes
        )


def test_known_pixels_of_the_box_pushing_robots_cameras():
    """The robots look down the arena: floor at the bottom of their images, sky at the top,
    and each box where its centre projects (each robot has one in view)."""
    env = make_env("box_pushing", images=True, overrides={"camera_channels": "seg"})
    try:
        point = env.reset(seed=0)
        task, classes = env.task, env.spec.image_channels.classes
        model, data = task.scene.model, task.scene.data
        for agent, robot in enumerate(task.agent_robots):
            seg, seen = point.images[agent, ..., 0], 0
            assert classes[seg[-1, 32]] == "floor" and classes[seg[0, 32]] == "background"
            for body in ("small_box0", "small_box1", "big_box"):
                centre = data.body(body).xpos[None]
                x, y = project_points(model, data, robot.camera_id, centre, 64, 64)[0]
                if 0 <= x < 64 and 0 <= y < 64:
                    assert classes[seg[int(y), int(x)]] == body.rstrip("01"), body
                    seen += 1
            assert seen >= 1, f"{robot.prefix} sees a box ahead"
    finally:
        env.close()


HOSTS = {
    "ground": ("box_pushing", "turtlebot_robot"),
    "drone": ("water_filling", "drone_robot"),
    "arm": ("tool_delivery", "fetch_robot"),
}
"""A task and its setting that puts a robot of each role in a scene."""


def _role(robot: str) -> str:
    return role_of(get_robot(robot).adapter_class())


@pytest.mark.parametrize("robot", robot_names())
def test_every_robots_camera_gives_every_channel(robot):
    """Each registered robot, in its role's task, with its camera re-mounted for its role:
    the observations of all three channels, shaped and typed as the spec says."""
    role = _role(robot)
    task, field = HOSTS[role]
    overrides = {
        field: robot,
        "camera_channels": "seg+depth+rgb",
        "camera_fovy": f"{role}:65",
        "camera_offset": f"{role}:0 0.02 0",
        "camera_rotation": f"{role}:-5 0 0",
    }
    env = make_env(task, images=True, image_size=36, overrides=overrides)
    try:
        images = env.reset(seed=0).images
        spec, robots = env.spec, env.task.agent_robots
        agent = next(i for i, a in enumerate(spec.agents) if a.robot == robot)
        assert spec.image_channels.names == CHANNELS
        assert spec.image_shape == (36, 36, 5) and images.dtype == np.float32
        assert env.task.scene.model.cam_fovy[robots[agent].camera_id] == 65
        assert images[agent, ..., :3].std() > 1.0 and len(np.unique(images[agent, ..., 4])) >= 2
    finally:
        env.close()


@pytest.mark.parametrize("role", sorted(HOSTS))
def test_every_role_renders_every_channel_combination_alike(role):
    """Each combination of channels renders the same values as the planes of the full image
    (colour and depth from one pass, or depth from the segmentation pass, alike)."""
    task, _ = HOSTS[role]
    env = make_env(task, images=True, image_size=36, overrides={"camera_channels": "rgb+depth+seg"})
    try:
        point = env.reset(seed=0)
        channels = env.spec.image_channels
        agent = next(i for i, r in enumerate(env.task.agent_robots) if _role_of(r) == role)
        model, data = env.task.scene.model, env.task.scene.data
        camera = env.task.agent_robots[agent].camera_id
        for combination in COMBINATIONS:
            chosen = _channels(combination, model, channels.classes)
            classes = env.task.segmentation if "seg" in chosen.names else None
            with CameraRenderer(model, 36, 36, channels=chosen, classes=classes) as renderer:
                image = renderer.render(data, [camera])[0]
            assert image.shape == (36, 36, chosen.planes) and image.dtype == chosen.dtype
            for name in chosen.names:
                np.testing.assert_array_equal(
                    image[..., chosen.plane_slice(name)],
                    point.images[agent, ..., channels.plane_slice(name)],
                    err_msg=f"{role} {combination}: {name}",
                )
    finally:
        env.close()


def _role_of(robot) -> str:
    return role_of(type(robot))


def test_camera_settings_per_role_move_turn_and_widen_each_robots_camera():
    config = {
        "camera_fovy": "ground:70,drone:110",
        "camera_offset": "drone:0 0 0.5",
        "camera_rotation": "ground:-10 0 0",
    }
    plain = task_class("water_filling")(make_config("water_filling", {}))
    task = task_class("water_filling")(make_config("water_filling", config))
    try:
        vehicle, drone = (r.camera_id for r in task.agent_robots)
        pm, pd, m, d = plain.scene.model, plain.scene.data, task.scene.model, task.scene.data
        assert (m.cam_fovy[vehicle], m.cam_fovy[drone]) == (70.0, 110.0)
        np.testing.assert_array_equal(d.cam_xpos[vehicle], pd.cam_xpos[vehicle])
        back = pd.cam_xmat[drone].reshape(3, 3)[:, 2]  # the camera's +z: away from its view
        np.testing.assert_allclose(d.cam_xpos[drone], pd.cam_xpos[drone] + 0.5 * back, atol=1e-9)
        view, tilted = (-x.cam_xmat[vehicle].reshape(3, 3)[:, 2] for x in (pd, d))
        pitch = np.degrees(np.arcsin(tilted[2]) - np.arcsin(view[2]))
        assert pitch == pytest.approx(-10.0, abs=1e-6), "tilted 10 degrees down"
        task.agent_robots = task.agent_robots  # mounted again: from the compiled mount
        assert m.cam_fovy[vehicle] == 70.0
        np.testing.assert_allclose(m.cam_pos[drone], pm.cam_pos[drone] + 0.5 * _back(pm, drone))
    finally:
        plain.close()
        task.close()


def _back(model: mujoco.MjModel, camera: int) -> np.ndarray:
    """The camera's +z axis in its body's frame."""
    axes = np.empty(9)
    mujoco.mju_quat2Mat(axes, model.cam_quat[camera])
    return axes.reshape(3, 3)[:, 2]


def test_default_settings_leave_the_compiled_cameras_untouched():
    config = make_config("tool_delivery", {})
    task = task_class("tool_delivery")(config)
    compiled = build_scene(config).model
    try:
        for name in ("cam_fovy", "cam_pos", "cam_quat"):
            assert getattr(task.scene.model, name).tobytes() == getattr(compiled, name).tobytes()
    finally:
        task.close()


FIRST_IMAGES = {
    "tool_delivery": "85a0a67d1ef29d567951adc73a189bb7a7d02d2a5e9fe690c9cc8d7a31942fea",
    "water_filling": "1054066a7e9f4c6ae3fedbdd41d61901cd8d10a396f52b58b859c196e5ee5b78",
}
"""sha256 of the first observation's images (64 px, seed 0) before camera channels existed,
on this GL renderer: a ground robot, an arm and a drone."""
RECORDED_ON = ("Mesa/X.org", "llvmpipe (LLVM 15.0.6, 256 bits)")


@pytest.mark.parametrize("task", sorted(FIRST_IMAGES))
def test_default_images_are_the_bytes_they_were(task):
    if gl_strings() != RECORDED_ON:
        pytest.skip(f"the checksums were taken on {RECORDED_ON[1]}; this is {gl_strings()[1]}")
    env = make_env(task, images=True, image_size=64, seed=0)
    try:
        images = env.reset(seed=0).images
    finally:
        env.close()
    assert images.dtype == np.uint8 and images.shape[-1] == 3
    assert hashlib.sha256(images.tobytes()).hexdigest() == FIRST_IMAGES[task]
