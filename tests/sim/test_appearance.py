"""``env.appearance`` on the built-in scene tasks: ``off`` is the scene as it was, a look
follows the episode seed and goes through the model's arrays only, the physics never sees it,
and the held-out looks are never training looks."""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import hashlib
import itertools

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np
import pytest

from maopg.env import make_env
from maopg.env.rollout import run_episode, scripted_policy
from maopg.sim.appearance import CLEARANCE, DISTRACTOR, MOUNT_MARGIN, Appearance, Surfaces
from maopg.sim.egl_check import gl_strings
from maopg.sim.look_draws import (
    CAMERA_SHIFT,
    CAMERA_TURN,
    COLOUR_JITTER,
    HELDOUT_LIGHT_SHIFT,
    HELDOUT_LIGHT_TURN,
    HELDOUT_PALETTE,
    HELDOUT_SCALES,
    HELDOUT_TEXTURES,
    LIGHT_SHIFT,
    LIGHT_TURN,
    LOOK_SETS,
    MOUNT_SHIFT,
    MOUNT_TURN,
    ROLES,
    TRAINING_PALETTE,
    TRAINING_SCALES,
    TRAINING_TEXTURES,
    Layout,
    draw,
)
from maopg.sim.looks import APPEARANCES, HELDOUT, MOUNTS, OFF, PRESETS, TRAINING
from maopg.tasks import make_config, task_class

TASKS = ("tool_delivery", "water_filling", "box_pushing")

BEFORE = {
    "tool_delivery": (
        "5ffb0b7f10c238e8a895e189d2b2365e5cff88fe9acb049ec266d2885fbd8e73",
        "85a0a67d1ef29d567951adc73a189bb7a7d02d2a5e9fe690c9cc8d7a31942fea",
    ),
    "water_filling": (
        "60c072b185107ec04b10a9614e646b8502d652eb9fa09b598fbc5d58c893e462",
        "1054066a7e9f4c6ae3fedbdd41d61901cd8d10a396f52b58b859c196e5ee5b78",
    ),
    "box_pushing": (
        "b2f6d6b40091f365e11fb1f385dd4e963318aa0aa0bbdceb759a9ee4281e02b5",
        "30348cd9564d0a1ae3a80933eb80cab5e0a352b6401c2d9a9931a6dd63378699",
    ),
}
"""Each task's compiled model (``mj_saveModel``'s bytes) and the first observation images of
the episode with seed 0 (64 px) as SHA-256, taken before ``env.appearance`` existed."""
RECORDED_ON = "llvmpipe (LLVM 15.0.6, 256 bits)"
"""The GL renderer the images were recorded on; another rasteriser draws other pixels."""

LOOK_ARRAYS = (
    "geom_rgba",
    "geom_matid",
    "light_pos",
    "light_dir",
    "light_diffuse",
    "light_ambient",
    "light_specular",
    "cam_pos",
    "cam_quat",
    "body_pos",
    "body_quat",
)
"""The model arrays a look writes."""


def _model_digest(model: mujoco.MjModel) -> str:
    buffer = np.zeros(mujoco.mj_sizeModel(model), np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return hashlib.sha256(buffer.tobytes()).hexdigest()


@pytest.mark.parametrize("task", TASKS)
def test_off_and_light_compile_the_model_of_before_and_off_draws_its_images(task):
    env = make_env(task, seed=0, images=True, image_size=64)
    try:
        images = env.reset(seed=0).images
        assert _model_digest(env.task.scene.model) == BEFORE[task][0]
        if gl_strings()[1] == RECORDED_ON:
            assert hashlib.sha256(images.tobytes()).hexdigest() == BEFORE[task][1]
    finally:
        env.close()
    light = task_class(task)(make_config(task, {"appearance": "light"}))
    assert _model_digest(light.scene.model) == BEFORE[task][0]


def _look_state(env) -> dict[str, np.ndarray]:
    model = env.task.scene.model
    state = {name: getattr(model, name).copy() for name in LOOK_ARRAYS}
    state["headlight"] = np.array(model.vis.headlight.diffuse)
    return state


@pytest.mark.parametrize("task", TASKS)
def test_a_look_follows_the_episode_seed_through_the_models_arrays(task, monkeypatch):
    """Same seed, same look and images (in another environment, after another episode's
    look); another seed, another look; and no compile while looks change."""
    one, two = (
        make_env(task, seed=0, images=True, image_size=32, overrides={"appearance": "full"})
        for _ in range(2)
    )
    try:
        first = one.reset(seed=5)
        look = _look_state(one)
        model = two.task.scene.model
        compiles = []
        monkeypatch.setattr(mujoco.MjSpec, "compile", lambda *a: compiles.append(a))
        other = two.reset(seed=6).images.copy()
        again = two.reset(seed=5)
        assert two.task.scene.model is model and not compiles
    finally:
        one.close()
        two.close()
    assert np.array_equal(first.images, again.images)
    assert all(np.array_equal(v, _look_state(two)[k]) for k, v in look.items())
    assert not np.array_equal(first.images, other)


@pytest.mark.parametrize("task", TASKS)
def test_the_scripted_trajectory_is_the_same_in_every_look(task):
    """Every tick's physical state and reward, with the looks off and on."""

    def played(appearance: str) -> list[tuple[float, bytes, bytes]]:
        env = make_env(task, seed=0, overrides={"appearance": appearance})
        ticks = []
        data = env.task.scene.data
        env.add_tick_listener(
            lambda _, reward: ticks.append((reward, data.qpos.tobytes(), data.qvel.tobytes()))
        )
        try:
            run_episode(env, scripted_policy(env), seed=3)
        finally:
            env.close()
        return ticks

    off = played(OFF)
    assert len(off) > 10 and played("full") == off


def test_distractors_stand_by_the_walls_and_touch_nothing():
    env = make_env("tool_delivery", seed=0, overrides={"appearance": "full"})
    try:
        env.reset(seed=1)
        model, data = env.task.scene.model, env.task.scene.data
        bodies = [b for b in range(model.nbody) if model.body(b).name.startswith(DISTRACTOR)]
        assert len(bodies) == 4
        for body in bodies:
            assert model.body_jntnum[body] == 0 and model.body_parentid[body] == 0
            geom = model.body_geomadr[body]
            assert (model.geom_contype[geom], model.geom_conaffinity[geom]) == (0, 0)
        sites = data.site_xpos[:, :2]
        shown = 0
        for seed in range(12):
            env.reset(seed=seed)
            for body in bodies:
                if model.geom_rgba[model.body_geomadr[body], 3] > 0:
                    shown += 1
                    gap = np.linalg.norm(sites - data.xpos[body, :2], axis=1).min()
                    assert gap >= CLEARANCE
        assert shown > 0
    finally:
        env.close()


def _distractors_shown(env) -> list[int]:
    model = env.task.scene.model
    bodies = [b for b in range(model.nbody) if model.body(b).name.startswith(DISTRACTOR)]
    return [b for b in bodies if model.geom_rgba[model.body_geomadr[b], 3] > 0]


def test_the_distractors_are_a_setting_of_their_own():
    """``env.appearance_distractors=false``: the same looks (colours, lights, cameras), no
    distractor shown."""
    arrays = ("geom_matid", "light_pos", "light_diffuse", "cam_pos", "cam_quat")
    looks = {}
    for distractors in (True, False):
        overrides = {"appearance": "full", "appearance_distractors": distractors}
        env = make_env("tool_delivery", seed=0, overrides=overrides)
        try:
            seen, shown = [], 0
            for seed in range(6):
                env.reset(seed=seed)
                model = env.task.scene.model
                seen.append([getattr(model, name).copy() for name in arrays])
                shown += len(_distractors_shown(env))
            looks[distractors] = (seen, shown)
        finally:
            env.close()
    assert looks[True][1] > 0 and looks[False][1] == 0
    for with_them, without in zip(looks[True][0], looks[False][0], strict=True):
        assert all(np.array_equal(a, b) for a, b in zip(with_them, without, strict=True))


def test_where_distractors_and_cameras_may_go_is_read_in_the_start_posture():
    """The distractor spots and the cameras' clearances come from the scene in the posture every
    episode starts from (:meth:`maopg.sim.scene.Scene.start_state`), not from the state the
    first look finds: on Tool Delivery with the Fetch's arm stretched out and on Box Pushing
    with every box pushed aside when the looks are made, 50 ``full`` looks place the cameras and
    the distractors as looks made in the start posture do; and reading the start posture leaves
    the live data as it was."""
    for task_name, disturb in (("tool_delivery", _stretch_the_arm), ("box_pushing", _push_boxes)):
        env = make_env(task_name, seed=0, overrides={"appearance": "full"})
        try:
            env.reset(seed=0)
            scene, task = env.task.scene, env.task
            model, data = scene.model, scene.data
            cameras = [robot.camera_id for robot in task.agent_robots]
            robots = tuple(scene.robots)
            scene.reset()  # the start posture itself, live
            home = Appearance(model, data, robots, task.surfaces, cameras, start=data)
            disturb(model, data)
            before = [data.qpos.copy(), data.qvel.copy(), data.xpos.copy()]
            start = scene.start_state()
            after = [data.qpos, data.qvel, data.xpos]
            assert all(np.array_equal(a, b) for a, b in zip(before, after, strict=True))
            made = Appearance(model, data, robots, task.surfaces, cameras, start=start)
            expected, found = _placed(home, cameras), _placed(made, cameras)
            assert all(np.array_equal(a, b) for a, b in zip(expected, found, strict=True))
        finally:
            env.close()


def _inside_own_robot(
    model: mujoco.MjModel, data: mujoco.MjData, camera: int, margin: float = 0.0
) -> set[int]:
    """The visible geoms of ``camera``'s robot whose bounding box, grown by ``margin``, holds
    the camera."""
    root = model.body_rootid[model.cam_bodyid[camera]]
    point, inside = data.cam_xpos[camera], set()
    for g in range(model.ngeom):
        if model.body_rootid[model.geom_bodyid[g]] != root or model.geom_rgba[g, 3] == 0:
            continue
        rot = data.geom_xmat[g].reshape(3, 3)
        local = rot.T @ (point - data.geom_xpos[g]) - model.geom_aabb[g, :3]
        if model.geom_group[g] < 3 and (np.abs(local) <= model.geom_aabb[g, 3:] + margin).all():
            inside.add(g)
    return inside


def test_a_jittered_camera_stays_out_of_its_robot_as_every_episode_starts():
    """In the posture every episode starts from (a Fetch's arm folded), no ``full`` look puts
    a camera inside a part of its own robot that the mounted camera is not already in (within
    the mount's margin, where the check lets a camera be)."""
    off = make_env("tool_delivery", seed=0)
    try:
        off.reset(seed=0)
        model, data = off.task.scene.model, off.task.scene.data
        cameras = [robot.camera_id for robot in off.task.agent_robots]
        mounted = {cam: _inside_own_robot(model, data, cam, MOUNT_MARGIN) for cam in cameras}
    finally:
        off.close()
    env = make_env("tool_delivery", seed=0, overrides={"appearance": "full"})
    try:
        model, data = env.task.scene.model, env.task.scene.data
        for seed in range(50):
            env.reset(seed=seed)
            for cam in cameras:
                assert _inside_own_robot(model, data, cam) <= mounted[cam], (seed, cam)
    finally:
        env.close()


def _placed(looks: Appearance, cameras: list[int]) -> list[np.ndarray]:
    """Where 50 ``full`` looks put the cameras and the distractors."""
    shown = []
    for seed in range(50):
        looks.show("full", seed)
        shown += [looks.model.cam_pos[cameras].copy(), looks.model.body_pos.copy()]
    return shown


def _stretch_the_arm(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Every hinge of the Fetch at its ``qpos0`` (the arm stretched out, not folded)."""
    for j in range(model.njnt):
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE and "fetch" in model.joint(j).name:
            data.qpos[model.jnt_qposadr[j]] = model.qpos0[model.jnt_qposadr[j]]
    mujoco.mj_kinematics(model, data)


def _push_boxes(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    for box in ("small_box0", "small_box1", "big_box"):
        address = model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, box)]
        data.qpos[address : address + 2] += (1.0, -0.8)
    mujoco.mj_kinematics(model, data)


def test_a_scene_built_without_the_looks_assets_is_told_how_to_build_it():
    """A user's scene task whose builder was not given ``appearance=`` (``light`` needs
    nothing compiled in; ``full`` does)."""
    task = task_class("box_pushing")(make_config("box_pushing"))
    scene, cameras = task.scene, [r.camera_id for r in task.agent_robots]
    robots, start = tuple(scene.robots), scene.start_state()
    appearance = Appearance(scene.model, scene.data, robots, Surfaces(), cameras, start=start)
    appearance.show("light", 0)
    with pytest.raises(ValueError, match=r"appearance=config\.appearance"):
        appearance.show("full", 0)


def _near(rgb, palette) -> bool:
    return any(np.abs(np.subtract(rgb, c)).max() <= COLOUR_JITTER + 1e-9 for c in palette)


def _angle(move) -> float:
    """Degrees a move turns by."""
    return float(np.degrees(2 * np.arccos(np.clip(move.turn[0], -1.0, 1.0))))


def test_held_out_looks_are_never_training_looks():
    """By construction (:mod:`maopg.sim.look_draws`): the palettes are farther apart than
    twice the jitter, the textures and scales differ, the light and headlight intensities and
    casts lie outside the training ranges, ``heldout``'s lights move and turn further than
    training's, and in ``mounts`` (training's looks otherwise) the cameras' turns and shifts
    do; and so are the looks drawn."""
    assert set(APPEARANCES) == {*TRAINING, HELDOUT, MOUNTS, *PRESETS} and set(LOOK_SETS) == {
        *APPEARANCES
    } - {OFF}
    for train, held in itertools.product(TRAINING_PALETTE, HELDOUT_PALETTE):
        assert np.abs(np.subtract(train, held)).max() > 2 * COLOUR_JITTER
    assert not {t.name for t in TRAINING_TEXTURES} & {t.name for t in HELDOUT_TEXTURES}
    for role in ROLES:
        assert not set(TRAINING_SCALES[role]) & set(HELDOUT_SCALES[role])
    train_scale = [
        interval for name in ("light", "full") for interval in LOOK_SETS[name].lights.scale
    ]
    low, high = min(a for a, _ in train_scale), max(b for _, b in train_scale)
    train_head = [i for name in ("light", "full") for i in LOOK_SETS[name].lights.headlight]
    head_low, head_high = min(a for a, _ in train_head), max(b for _, b in train_head)
    max_tint = max(LOOK_SETS[name].lights.tint[1] for name in ("light", "full"))
    layout = Layout(roles=ROLES, lights=3, cameras=2, spots=20, distractors=4)
    for name, seed in itertools.product(("light", "full", HELDOUT, MOUNTS, *PRESETS), range(60)):
        look = draw(name, seed, layout)
        held_out = name not in (*TRAINING, MOUNTS)  # mounts holds out the cameras alone
        colours = [f.rgb for f in look.finishes] + [p.rgb for p in look.distractors if p]
        palette = HELDOUT_PALETTE if held_out else TRAINING_PALETTE
        assert all(_near(rgb, palette) for rgb in colours), name
        textures = {f.texture for f in look.finishes} - {None}
        allowed = HELDOUT_TEXTURES if held_out else TRAINING_TEXTURES
        assert textures <= {t.name for t in allowed}
        inside = low <= look.light_scale <= high
        assert inside != held_out, (name, look.light_scale)
        head_inside = head_low <= look.headlight_scale <= head_high
        assert head_inside != held_out, (name, look.headlight_scale)
        tinted = max(abs(t - 1.0) for t in look.tint) > max_tint
        assert tinted == held_out, (name, look.tint)
        for move in look.lights:  # heldout: every light moved and turned further than training
            if name == HELDOUT:
                assert HELDOUT_LIGHT_TURN[0] - 1e-9 <= _angle(move) <= HELDOUT_LIGHT_TURN[1] + 1e-9
                assert (np.abs(move.shift) >= HELDOUT_LIGHT_SHIFT[0]).all(), move
            elif not held_out:
                assert _angle(move) <= LIGHT_TURN[1] + 1e-9, (name, move)
                assert (np.abs(move.shift) <= LIGHT_SHIFT[1]).all(), (name, move)
        for move in look.cameras:  # mounts: each camera turned and moved further than training
            angle = _angle(move)
            shift = np.abs(move.shift)
            if name == MOUNTS:
                assert MOUNT_TURN[0] - 1e-9 <= angle <= MOUNT_TURN[1] + 1e-9
                assert (shift >= MOUNT_SHIFT[0]).all(), move
            else:
                assert angle <= CAMERA_TURN[1] + 1e-9 and (shift <= CAMERA_SHIFT[1]).all()
    assert CAMERA_TURN[1] < MOUNT_TURN[0] and CAMERA_SHIFT[1] < MOUNT_SHIFT[0]
    assert LIGHT_TURN[1] < HELDOUT_LIGHT_TURN[0] and LIGHT_SHIFT[1] < HELDOUT_LIGHT_SHIFT[0]
    for preset in PRESETS:  # a preset is one look
        assert draw(preset, 1, layout) == draw(preset, 2, layout)
    assert draw(HELDOUT, 1, layout) != draw(HELDOUT, 2, layout)
