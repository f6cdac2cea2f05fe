"""Domain randomisation of a scene's looks (``env.appearance``), shown through the compiled
model's own arrays: an episode's look costs no compile and no GL upload.

Two halves:

- **Compiled in once** (:func:`add_assets`, by :class:`maopg.sim.scene.SceneBuilder` for a
  value whose looks need them: ``full``, ``heldout``, ``mounts`` and the presets; never for
  ``off`` or ``light``, whose model is the task's own): MuJoCo builtin textures
  (:data:`~maopg.sim.look_draws.TEXTURES`), a material per role, texture and repeat scale
  (``appearance/<role>/<texture>@<repeats>``: a GL context copies a material's texture and
  repeats when it is made, so they are chosen by switching a geom's material, never by editing
  one), and :data:`DISTRACTORS` static bodies named ``distractor<k>``, one geom each, without
  contacts (``contype = conaffinity = 0``, no joint, no mass), hidden (alpha 0, which MuJoCo's
  scene skips) until a look places them.
- **Written per episode** (:meth:`Appearance.show`): ``geom_rgba`` and ``geom_matid`` of the
  restyled surfaces, the lights' ``light_pos``/``light_dir``/``light_diffuse``/
  ``light_ambient``/``light_specular`` and the headlight's colours, the robot cameras'
  ``cam_pos``/``cam_quat`` (jittered around the pose the task was built with, read when the
  first look is shown) and the distractors' ``body_pos``/``body_quat``/``geom_rgba``; then
  ``mj_kinematics`` and ``mj_camlight`` place what moved for the next render. Both compute
  derived fields only, from the unchanged ``qpos``; the next physics step recomputes them: the
  trajectory is the same with every look (``tests/sim/test_appearance.py`` plays each task's
  scripted episode both ways).

**What is restyled.** A task names its surfaces in :class:`Surfaces` (geom name patterns of
floors, walls and furniture; the defaults find floors and walls by their usual names).
Geoms that look alike in the task's scene (same role, same material, same colour) form a
group and share one finish, so a scene keeps its structure (a tool room's floor stays unlike
the workshop's). Robots, and whatever the task's rules or display give a colour (a jar's
water, a delivered box, a human's stage lights), are never touched; neither are invisible
geoms (alpha 0, or a group MuJoCo does not draw).

**Where distractors stand.** On the floor within :data:`BAND` of its edge, at least
:data:`CLEARANCE` (in the plane) from every other geom and every site of the scene as the task
built it (in the posture every episode starts from, ``qpos0`` and each robot's start posture:
robots, furniture, jars, boxes, goals, waypoints: the task's places, and so its paths, lie
between them), and clear of the walls. Read there, not from the episode being reset, so the
spots are the same whichever episode shows the first look (a resumed run, an evaluation) and a
prop a task moves per episode cannot move them. They are
visual only: nothing collides with them, so a task's physics cannot see them.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from maopg.sim.look_draws import (
    LOOK_SETS,
    ROLES,
    TEXTURES,
    Finish,
    Layout,
    Look,
    Texture,
    draw,
    scales_of,
)
from maopg.sim.segmentation import DISTRACTOR

PREFIX = "appearance/"
"""The names of the compiled-in textures and materials start with it."""
DISTRACTOR_SHAPES: tuple[tuple[str, tuple[float, float, float]], ...] = (
    ("box", (0.14, 0.14, 0.14)),
    ("cylinder", (0.1, 0.22, 0.0)),
    ("sphere", (0.15, 0.0, 0.0)),
    ("box", (0.06, 0.06, 0.3)),
)
"""Each distractor's MuJoCo geom type and size: a crate, a bin, a ball, a post."""
DISTRACTORS = len(DISTRACTOR_SHAPES)
HIDDEN = (0.5, 0.5, 0.5, 0.0)
"""A hidden distractor's colour: alpha 0, which MuJoCo's scene skips (every renderer's)."""
BAND = 1.0
"""m: distractors stand at most this far from the floor's edge (by the walls, out of the way)."""
CLEARANCE = 0.6
"""m: ... and at least this far from every other geom and every site."""
WALL_CLEARANCE = 0.25
"""m: ... and this far from the walls."""
STEP = 0.25
"""m: the spacing of the candidate spots."""


def needs_assets(appearance: str) -> bool:
    """Whether a scene shown under ``env.appearance=appearance`` must compile in
    :func:`add_assets`' textures, materials and distractors."""
    looks = LOOK_SETS.get(appearance)
    return looks is not None and looks.needs_assets


def material_name(role: str, texture: str, scale: float) -> str:
    return f"{PREFIX}{role}/{texture}@{scale:g}"


def add_assets(spec: mujoco.MjSpec) -> None:
    """Add the textures, materials and hidden distractors every non-``off`` look may show
    (module docstring) to ``spec``, after everything of the task's (so no index of the task's
    own textures, materials, bodies or geoms moves)."""
    for texture in TEXTURES:
        if texture.builtin is not None:
            _add_texture(spec, texture)
        for role, scales in scales_of(texture).items():
            for scale in scales:
                material = spec.add_material(
                    name=material_name(role, texture.name, scale),
                    rgba=[1.0, 1.0, 1.0, 1.0],
                    texrepeat=[scale, scale],
                    texuniform=True,
                )
                if texture.builtin is not None:
                    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = PREFIX + texture.name
    for k, (shape, size) in enumerate(DISTRACTOR_SHAPES):
        body = spec.worldbody.add_body(name=f"{DISTRACTOR}{k}")
        body.add_geom(
            name=f"{DISTRACTOR}{k}",
            type=getattr(mujoco.mjtGeom, f"mjGEOM_{shape.upper()}"),
            size=list(size),
            rgba=list(HIDDEN),
            contype=0,
            conaffinity=0,
            density=0.0,
        )


def _add_texture(spec: mujoco.MjSpec, texture: Texture) -> None:
    spec.add_texture(
        name=PREFIX + texture.name,
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=getattr(mujoco.mjtBuiltin, f"mjBUILTIN_{texture.builtin.upper()}"),  # type: ignore[union-attr]
        mark=getattr(mujoco.mjtMark, f"mjMARK_{texture.mark.upper()}"),
        rgb1=[1.0, 1.0, 1.0],
        rgb2=list(texture.rgb2),
        markrgb=list(texture.markrgb),
        random=texture.random,
        width=texture.size,
        height=texture.size,
    )


@dataclass(frozen=True)
class Surfaces:
    """Which geoms a task's looks restyle, as ``fnmatch`` patterns of geom names (a geom takes
    the first role whose patterns it matches; a robot's geoms never match). A task declares
    its furniture in ``props``; the defaults find floors and walls by their usual names, in a
    tiled arena's copies too (``t0/floor``)."""

    floors: tuple[str, ...] = ("floor", "*_floor", "*/floor")
    walls: tuple[str, ...] = ("wall_*", "*/wall_*", "partition*", "*/partition*")
    props: tuple[str, ...] = ()

    def role(self, name: str) -> str | None:
        for role, patterns in zip(ROLES, (self.floors, self.walls, self.props), strict=True):
            if any(fnmatch.fnmatchcase(name, pattern) for pattern in patterns):
                return role
        return None


class Appearance:
    """Shows one look after another on a scene (module docstring).

    Made when the first look is shown, after the task finished building (so the cameras' poses
    are the ones the task mounted them at): it reads the surface groups, the lights' and the
    cameras' poses and colours, and the distractor spots and the cameras' clearances from the
    scene in its start posture (module docstring), never from the state ``data`` holds then.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        robots: Sequence[str],
        surfaces: Surfaces,
        cameras: Sequence[int],
        *,
        start: mujoco.MjData,
        distractors: bool = True,
    ) -> None:
        """A scene's ``model`` and ``data``, its robots' name prefixes (never restyled), what
        it restyles and the robot cameras it jitters; ``start``: the scene in the posture every
        episode starts from (:meth:`maopg.sim.scene.Scene.start_state`), where the distractor
        spots and the cameras' clearances are read; ``distractors=False`` never shows one
        (``env.appearance_distractors``: no spots, so a look draws none)."""
        self.model, self.data = model, data
        robots = tuple(f"{prefix}/" for prefix in robots)
        groups: dict[tuple[str, int, tuple[float, ...]], list[int]] = {}
        for g in range(model.ngeom):
            name = model.geom(g).name
            role = None if name.startswith(robots) else surfaces.role(name)
            rgba = self._colour(g)
            if role is None or rgba[3] == 0.0 or model.geom_group[g] >= 3:
                continue
            groups.setdefault((role, int(model.geom_matid[g]), tuple(rgba)), []).append(g)
        self._groups = [np.array(geoms) for geoms in groups.values()]
        self._alpha = [model.geom_rgba[geoms, 3].copy() for geoms in self._groups]
        self._gain = [_texture_gain(model, material) for _, material, _ in groups]
        roles = tuple(role for role, _, _ in groups)
        self._roles = roles
        head = model.vis.headlight
        self._lights = {
            name: getattr(model, name).copy()
            for name in (
                "light_pos",
                "light_dir",
                "light_diffuse",
                "light_ambient",
                "light_specular",
            )
        }
        self._headlight = {
            name: np.array(getattr(head, name)) for name in ("ambient", "diffuse", "specular")
        }
        self._cameras = np.array(cameras, dtype=int)
        self._cam_pos = model.cam_pos[self._cameras].copy()
        self._cam_quat = model.cam_quat[self._cameras].copy()
        self._mounts = [_Mount(model, start, int(cam)) for cam in self._cameras]
        bodies = [
            mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{DISTRACTOR}{k}")
            for k in range(DISTRACTORS)
        ]
        self.has_assets = all(b >= 0 for b in bodies)
        self._materials = {
            model.material(m).name: m
            for m in range(model.nmat)
            if model.material(m).name.startswith(PREFIX)
        }
        self._distractors = bodies if self.has_assets else []
        placed = self.has_assets and distractors
        self._spots = _spots(model, start, surfaces, robots) if placed else np.zeros((0, 3))
        self.layout = Layout(
            roles, int(model.nlight), len(self._cameras), len(self._spots), len(self._distractors)
        )

    def _colour(self, geom: int) -> np.ndarray:
        """What colour the geom shows: its own, or its material's where its own is MuJoCo's
        default grey (MuJoCo's rule)."""
        model = self.model
        rgba, material = model.geom_rgba[geom], int(model.geom_matid[geom])
        if material >= 0 and np.array_equal(rgba, np.float32([0.5, 0.5, 0.5, 1.0])):
            return model.mat_rgba[material].copy()
        return rgba.copy()

    def show(self, appearance: str, seed: int) -> Look:
        """Draw the look of the episode with ``seed`` and write it into the model (and the
        derived positions into the data), ready for the episode's first render."""
        if LOOK_SETS[appearance].needs_assets and not self.has_assets:
            raise ValueError(
                f"env.appearance={appearance} needs the scene compiled with its textures and "
                "distractors: the task's SceneBuilder must be given appearance=config.appearance"
            )
        look = draw(appearance, seed, self.layout)
        self._restyle(look.finishes)
        self._light(look)
        self._jitter(look)
        self._place(look)
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        return look

    def _restyle(self, finishes: Sequence[Finish]) -> None:
        """A group on a material of its own shows the drawn colour on its texture (white and
        grey, so the colour is the surface's); a group that keeps its material (``light``) is
        tinted so that its texture shows the drawn colour on average (a geom's colour
        multiplies its texture's)."""
        model = self.model
        for geoms, alpha, gain, role, finish in zip(
            self._groups, self._alpha, self._gain, self._roles, finishes, strict=True
        ):
            rgb = np.asarray(finish.rgb)
            if finish.texture is None:
                rgb = np.clip(rgb * gain, 0.0, 1.0)
            else:
                model.geom_matid[geoms] = self._materials[
                    material_name(role, finish.texture, finish.scale)
                ]
            model.geom_rgba[geoms, :3] = _not_default_grey(rgb)
            model.geom_rgba[geoms, 3] = alpha

    def _light(self, look: Look) -> None:
        model, base = self.model, self._lights
        colour = look.light_scale * np.asarray(look.tint)
        model.light_diffuse[:] = base["light_diffuse"] * colour
        model.light_ambient[:] = base["light_ambient"] * colour
        model.light_specular[:] = base["light_specular"] * look.light_scale
        for i, move in enumerate(look.lights):
            model.light_pos[i] = base["light_pos"][i] + move.shift
            turned = np.empty(3)
            mujoco.mju_rotVecQuat(turned, base["light_dir"][i], np.asarray(move.turn))
            model.light_dir[i] = turned
        head = model.vis.headlight
        for name, value in self._headlight.items():
            setattr(head, name, value * look.headlight_scale * np.asarray(look.tint))

    def _jitter(self, look: Look) -> None:
        """Each camera moves along its own axes (the move halved until the camera is clear of
        its robot: :class:`_Mount`) and turns about an axis of its own frame."""
        model = self.model
        for i, (cam, move) in enumerate(zip(self._cameras, look.cameras, strict=True)):
            shift = np.empty(3)
            mujoco.mju_rotVecQuat(shift, np.asarray(move.shift), self._cam_quat[i])
            model.cam_pos[cam] = self._mounts[i].clear(self._cam_pos[i], shift)
            turned = np.empty(4)
            mujoco.mju_mulQuat(turned, self._cam_quat[i], np.asarray(move.turn))
            model.cam_quat[cam] = turned

    def _place(self, look: Look) -> None:
        model = self.model
        for body, placement in zip(self._distractors, look.distractors, strict=True):
            geom = int(model.body_geomadr[body])
            if placement is None:  # as compiled: a look leaves nothing of the one before
                model.body_pos[body], model.body_quat[body] = (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)
                model.geom_rgba[geom] = HIDDEN
                continue
            x, y, floor = self._spots[placement.spot]
            model.body_pos[body] = (x, y, floor + _half_height(model, geom))
            yaw = placement.yaw / 2
            model.body_quat[body] = (np.cos(yaw), 0.0, 0.0, np.sin(yaw))
            model.geom_rgba[geom] = (*_not_default_grey(placement.rgb), 1.0)


MOUNT_MARGIN = 0.01
"""m: a jittered camera keeps at least this from its robot's geoms' bounding boxes."""


class _Mount:
    """Where a robot's camera may be moved: not into its own robot (a camera a few
    millimetres in front of its housing, moved back or down, would film the housing from
    inside or below). The robot's visible geoms are taken in the camera body's frame in the
    robot's start posture (a Fetch's arm folded, as every episode starts); those the camera
    already sits in (within :data:`MOUNT_MARGIN`) are left out, so the check never refuses the
    task's own mounting."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, camera: int) -> None:
        body = int(model.cam_bodyid[camera])
        rot = data.xmat[body].reshape(3, 3)
        ours = model.body_rootid[model.geom_bodyid] == model.body_rootid[body]
        shown = (model.geom_rgba[:, 3] > 0.0) & (model.geom_group < 3)
        geoms = np.flatnonzero(ours & shown)
        # each geom's bounding box in the camera body's frame: centre, axes (columns), half size
        axes = np.einsum("ji,gjk->gik", rot, data.geom_xmat[geoms].reshape(-1, 3, 3))
        centres = (data.geom_xpos[geoms] - data.xpos[body]) @ rot + np.einsum(
            "gij,gj->gi", axes, model.geom_aabb[geoms, :3]
        )
        halves = model.geom_aabb[geoms, 3:] + MOUNT_MARGIN
        self._boxes = (centres, axes, halves)
        keep = ~self._inside(model.cam_pos[camera][None])[0]
        self._boxes = (centres[keep], axes[keep], halves[keep])

    def _inside(self, points: np.ndarray) -> np.ndarray:
        """``[P, B]``: whether each point lies in each box."""
        centres, axes, halves = self._boxes
        local = np.einsum("bji,pbj->pbi", axes, points[:, None, :] - centres[None])
        return (np.abs(local) <= halves).all(axis=2)

    def clear(self, pos: np.ndarray, shift: np.ndarray) -> np.ndarray:
        """``pos + f * shift`` for the largest ``f`` of 1, 1/2, 1/4 that keeps the camera out
        of its robot; ``pos`` if none does."""
        moved = pos + np.array([[1.0], [0.5], [0.25]]) * shift
        free = ~self._inside(moved).any(axis=1)
        return moved[int(np.argmax(free))] if free.any() else pos.copy()


def _texture_gain(model: mujoco.MjModel, material: int) -> np.ndarray:
    """What a colour is multiplied by so that ``material``'s RGB texture, tinted by it, shows
    it on average: the inverse of the texture's mean colour (1 without a texture)."""
    texture = (
        -1 if material < 0 else int(model.mat_texid[material, mujoco.mjtTextureRole.mjTEXROLE_RGB])
    )
    if texture < 0 or model.tex_type[texture] != mujoco.mjtTexture.mjTEXTURE_2D:
        return np.ones(3)
    adr, channels = int(model.tex_adr[texture]), int(model.tex_nchannel[texture])
    size = int(model.tex_width[texture]) * int(model.tex_height[texture]) * channels
    pixels = model.tex_data[adr : adr + size].reshape(-1, channels)[:, :3]
    return 255.0 / np.maximum(pixels.mean(axis=0), 1.0)


def _not_default_grey(rgb: Sequence[float]) -> tuple[float, float, float]:
    """``rgb``, nudged off MuJoCo's default geom grey, which would show the material's colour
    instead (a draw hits it with probability zero; the nudge is invisible)."""
    if tuple(rgb) == (0.5, 0.5, 0.5):
        return (0.5, 0.5, 0.5 + 1 / 512)
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]))


def _half_height(model: mujoco.MjModel, geom: int) -> float:
    """How far a distractor's geom reaches below its centre, standing upright."""
    kind, size = model.geom_type[geom], model.geom_size[geom]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return float(size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return float(size[1])
    return float(size[2])


def _xy_boxes(model: mujoco.MjModel, data: mujoco.MjData, geoms: Sequence[int]) -> np.ndarray:
    """``[N, 4]`` world ``(x_low, y_low, x_high, y_high)`` of the geoms' bounding boxes."""
    boxes = np.empty((len(geoms), 4))
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    for i, g in enumerate(geoms):
        centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            centre, half = np.zeros(3), np.array([*model.geom_size[g, :2], 0.0])
        corners = (centre + signs * half) @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
        boxes[i] = (*corners[:, :2].min(axis=0), *corners[:, :2].max(axis=0))
    return boxes


def _distance(points: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """``[P]``: each point's planar distance to the nearest box (0 inside one)."""
    if len(boxes) == 0:
        return np.full(len(points), np.inf)
    x, y = points[:, None, 0], points[:, None, 1]
    dx = np.maximum(np.maximum(boxes[None, :, 0] - x, x - boxes[None, :, 2]), 0.0)
    dy = np.maximum(np.maximum(boxes[None, :, 1] - y, y - boxes[None, :, 3]), 0.0)
    return np.hypot(dx, dy).min(axis=1)


def _spots(
    model: mujoco.MjModel, data: mujoco.MjData, surfaces: Surfaces, robots: tuple[str, ...]
) -> np.ndarray:
    """``[S, 3]``: the distractor spots ``(x, y, floor height)`` (module docstring)."""
    floors, walls, others = [], [], []
    for g in range(model.ngeom):
        name = model.geom(g).name
        if name.startswith(DISTRACTOR):
            continue
        role = None if name.startswith(robots) else surfaces.role(name)
        {"floor": floors, "wall": walls}.get(role or "", others).append(g)
    if not floors:
        return np.zeros((0, 3))
    extent = _xy_boxes(model, data, floors)
    low, high = extent[:, :2].min(axis=0), extent[:, 2:].max(axis=0)
    xs = np.arange(low[0] + STEP, high[0] - STEP / 2, STEP)
    ys = np.arange(low[1] + STEP, high[1] - STEP / 2, STEP)
    points = np.array([(x, y) for x in xs for y in ys]).reshape(-1, 2)
    edge = np.minimum(points - low, high - points).min(axis=1)
    sites = np.concatenate([data.site_xpos[:, :2]] * 2, axis=1)
    keep = (
        (edge <= BAND)
        & (_distance(points, _xy_boxes(model, data, walls)) >= WALL_CLEARANCE)
        & (_distance(points, _xy_boxes(model, data, others)) >= CLEARANCE)
        & (_distance(points, sites) >= CLEARANCE)
    )
    top = max(
        float(data.geom_xpos[g, 2])
        + (0.0 if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE else model.geom_size[g, 2])
        for g in floors
    )
    chosen = points[keep]
    return np.concatenate([chosen, np.full((len(chosen), 1), top)], axis=1)
