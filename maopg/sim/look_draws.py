"""What each value of ``env.appearance`` draws: palettes, textures, light and camera ranges,
and the draw of one episode's :class:`Look` from its seed.

A :class:`LookSet` is one distribution; :data:`LOOK_SETS` holds one per value but ``off``.
:func:`draw` turns a set, an episode seed and the scene's :class:`Layout` (how many surface
groups, lights, cameras, distractor spots it has) into a :class:`Look`, plain numbers that
:class:`maopg.sim.appearance.Appearance` writes into the model. Drawing knows nothing of
MuJoCo, so a look can be inspected and tested on its own.

**Its own random stream.** A look is drawn from ``numpy.random.default_rng([seed, STREAM])``:
the episode seed the task gets, with :data:`STREAM` beside it, so that no draw of the task's own
generators (seeded from the same seed) is consumed or shifted by it, and the same episode seed
gives the same look in every process (a resumed run replays its episodes bit for bit). A preset
draws from its own fixed seed instead, so every episode looks the same.

**Training and held-out never meet**, by construction, in each of three ways at once:

- colours: each is a palette colour moved by at most :data:`COLOUR_JITTER` per channel, and
  every colour of :data:`HELDOUT_PALETTE` differs from every colour of
  :data:`TRAINING_PALETTE` by more than twice that in some channel (the training colours are
  mid-tones, between 0.3 and 0.75 in every channel; the held-out ones dark, saturated or pale);
- textures: the held-out sets use :data:`HELDOUT_TEXTURES` (gradients, crosses, bold checks)
  at :data:`HELDOUT_SCALES`, none of which a training set uses;
- lights: a held-out light intensity scale lies outside the training interval (0.7 to 1.3),
  and its colour is a cast (one channel raised and another lowered by 0.12 or more) where
  training jitters each channel by at most 0.06; each light moves 0.6 to 1 m along each axis
  and turns 20 to 30 degrees where training moves it at most 0.5 m and 15 degrees.

Geometry is held out apart, in ``mounts``: the training looks (``full``'s colours, textures,
lights and distractors), with each robot camera turned by :data:`MOUNT_TURN` (5 to 8 degrees)
where training turns it by at most :data:`CAMERA_TURN` (3), and moved by 4 to 6 cm along each of
its axes where training moves it by at most 3. Apart, so that each shift is measured on its own:
``heldout`` changes what the world looks like (the cameras jittered as in training), ``mounts``
only where the cameras sit, which is what a depth camera, blind to colours and lights, can meet
anew. The turn is outside
training on every draw; a shift is halved where the camera would enter its own robot
(:class:`maopg.sim.appearance.Appearance`), which may bring it back into training's range, so
the shift alone is not guaranteed new.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

RGB = tuple[float, float, float]
Quat = tuple[float, float, float, float]

LOOKS_VERSION = 3
"""The version of what the looks draw: raise it when a draw changes (a range, a palette, the
order of the draws). The vision study's cached evaluations are keyed on it, and
``tests/test_behaviour_versions.py`` pins each scene task's looks to it."""

STREAM = 0x61707065
"""Beside the episode seed in the look's seed sequence (``"appe"`` in ASCII): a stream no task
draws from."""

ROLES = ("floor", "wall", "prop")
"""What a restyled surface is; each role has materials and texture scales of its own."""

COLOUR_JITTER = 0.04
"""Each channel of a drawn colour is its palette colour's moved by at most this."""

TRAINING_PALETTE: tuple[RGB, ...] = (
    (0.62, 0.45, 0.30),  # wood
    (0.55, 0.55, 0.52),  # concrete
    (0.70, 0.66, 0.58),  # beige
    (0.45, 0.50, 0.56),  # slate
    (0.60, 0.38, 0.32),  # brick
    (0.42, 0.52, 0.40),  # sage
    (0.66, 0.60, 0.45),  # sand
    (0.50, 0.42, 0.52),  # mauve
    (0.38, 0.45, 0.50),  # steel
    (0.72, 0.70, 0.66),  # light grey
    (0.48, 0.40, 0.34),  # brown
    (0.58, 0.58, 0.46),  # khaki
)
"""Mid-tones: what floors, walls and furniture of an office or a workshop look like."""

DARK: tuple[RGB, ...] = ((0.12, 0.10, 0.14), (0.18, 0.12, 0.08), (0.08, 0.14, 0.18))
NEON: tuple[RGB, ...] = (
    (1.00, 0.10, 0.70),
    (0.10, 1.00, 0.90),
    (0.90, 1.00, 0.10),
    (0.30, 0.10, 1.00),
    (1.00, 0.45, 0.00),
)
PALE: tuple[RGB, ...] = ((0.96, 0.96, 1.00), (0.98, 0.93, 0.96), (0.93, 0.98, 0.95))
HELDOUT_PALETTE = DARK + NEON + PALE
"""Colours no training draw comes near (module docstring)."""


@dataclass(frozen=True)
class Texture:
    """A MuJoCo builtin 2-D texture (``<texture builtin=...>``), grey, so that a surface's
    colour tints it; ``builtin=None`` is a plain material without a texture."""

    name: str
    builtin: str | None
    rgb2: RGB = (1.0, 1.0, 1.0)
    """The second colour (the first is white): a checker's other squares, a gradient's end."""
    mark: str = "none"
    """MuJoCo's marks drawn over it: ``edge`` (tile joints), ``cross``, ``random`` (speckles)."""
    markrgb: RGB = (0.0, 0.0, 0.0)
    random: float = 0.0
    """The share of speckled pixels of a ``random`` mark."""
    size: int = 64
    """Pixels a side; 64 keeps a texture a few kilobytes and its lookups cheap."""


TRAINING_TEXTURES = (
    Texture("plain", None),
    Texture("checker", "checker", rgb2=(0.78, 0.78, 0.78)),
    Texture("speckle", "flat", mark="random", markrgb=(0.68, 0.68, 0.68), random=0.08),
    Texture("tiles", "flat", mark="edge", markrgb=(0.6, 0.6, 0.6)),
)
HELDOUT_TEXTURES = (
    Texture("gradient", "gradient", rgb2=(0.35, 0.35, 0.35)),
    Texture("cross", "flat", mark="cross", markrgb=(0.3, 0.3, 0.3)),
    Texture("bold", "checker", rgb2=(0.2, 0.2, 0.2)),
)
TEXTURES = TRAINING_TEXTURES + HELDOUT_TEXTURES

TRAINING_SCALES: Mapping[str, tuple[float, ...]] = {
    "floor": (0.6, 1.0),
    "wall": (1.5, 2.5),
    "prop": (3.0, 5.0),
}
"""Texture repeats per metre, by role: each a material of its own, because a GL context copies
the materials' repeats when it is made (``MjrContext.mat_texrepeat``), so a repeat cannot
change after a renderer exists."""
HELDOUT_SCALES: Mapping[str, tuple[float, ...]] = {"floor": (2.0,), "wall": (4.0,), "prop": (8.0,)}


def scales_of(texture: Texture) -> Mapping[str, tuple[float, ...]]:
    """The repeats per metre each role uses ``texture`` at (one for a plain material)."""
    if texture.builtin is None:
        return {role: (1.0,) for role in ROLES}
    return HELDOUT_SCALES if texture in HELDOUT_TEXTURES else TRAINING_SCALES


@dataclass(frozen=True)
class LightRange:
    """How the lights change: intensity scales as unions of intervals, colour, moves."""

    scale: tuple[tuple[float, float], ...]
    """Every light's diffuse, ambient and specular colour is multiplied by one scale."""
    headlight: tuple[tuple[float, float], ...]
    """The same for the headlight (MuJoCo's light at the camera, most of a scene's light)."""
    tint: tuple[float, float]
    """Without ``cast``: each channel of the light's colour is multiplied by ``1 + d``, ``|d|
    <= tint[1]``. With it: one channel by ``1 + u``, another by ``1 - u``, ``u`` in ``tint``."""
    cast: bool = False
    cast_channels: tuple[int, int] | None = None
    """The channels (raised, lowered) of a cast; ``None``: two drawn."""
    shift: tuple[float, float] = (0.0, 0.0)
    """How far each light's position moves along each axis (m), between the two (:func:`_move`)."""
    turn: tuple[float, float] = (0.0, 0.0)
    """How far each light's direction turns (degrees), between the two."""


@dataclass(frozen=True)
class LookSet:
    """One distribution of looks (one value of ``env.appearance``)."""

    palette: tuple[RGB, ...]
    lights: LightRange
    textures: tuple[Texture, ...] | None = None
    """``None``: each surface keeps its own material and is only recoloured."""
    camera_shift: tuple[float, float] = (0.0, 0.0)
    """How far each robot camera moves along each of its axes (m), between the two."""
    camera_turn: tuple[float, float] = (0.0, 0.0)
    """How far each robot camera turns about a random axis (degrees), between the two."""
    distractors: bool = False
    fixed_seed: int | None = None
    """A preset's: its look is drawn from this seed, whatever the episode's."""

    @property
    def needs_assets(self) -> bool:
        """Whether the scene must be compiled with the textures, materials and distractors."""
        return self.textures is not None or self.distractors


CAMERA_SHIFT, CAMERA_TURN = (0.0, 0.03), (0.0, 3.0)
"""A robot camera's jitter in training (m along each axis, degrees): a few centimetres and
degrees of a mounting that is never quite where the drawing says."""
MOUNT_SHIFT, MOUNT_TURN = (0.04, 0.06), (5.0, 8.0)
"""A camera's in ``mounts``: a mounting further off than any training draw (module docstring)."""
LIGHT_SHIFT, LIGHT_TURN = (0.0, 0.5), (0.0, 15.0)
HELDOUT_LIGHT_SHIFT, HELDOUT_LIGHT_TURN = (0.6, 1.0), (20.0, 30.0)
"""How far the lights move (m along each axis) and turn (degrees), in training and held out."""

FULL_LIGHTS = LightRange(
    scale=((0.7, 1.3),),
    headlight=((0.8, 1.2),),
    tint=(0.0, 0.06),
    shift=LIGHT_SHIFT,
    turn=LIGHT_TURN,
)
"""The lights of ``full`` (and of ``mounts``, which changes only the cameras)."""

LOOK_SETS: Mapping[str, LookSet] = {
    "light": LookSet(
        TRAINING_PALETTE,
        LightRange(scale=((0.85, 1.15),), headlight=((0.9, 1.1),), tint=(0.0, 0.03)),
    ),
    "full": LookSet(
        TRAINING_PALETTE,
        FULL_LIGHTS,
        textures=TRAINING_TEXTURES,
        camera_shift=CAMERA_SHIFT,
        camera_turn=CAMERA_TURN,
        distractors=True,
    ),
    "heldout": LookSet(
        HELDOUT_PALETTE,
        LightRange(
            scale=((0.35, 0.55), (1.5, 1.9)),
            headlight=((0.45, 0.65), (1.35, 1.6)),
            tint=(0.12, 0.22),
            cast=True,
            shift=HELDOUT_LIGHT_SHIFT,
            turn=HELDOUT_LIGHT_TURN,
        ),
        textures=HELDOUT_TEXTURES,
        camera_shift=CAMERA_SHIFT,
        camera_turn=CAMERA_TURN,
        distractors=True,
    ),
    "mounts": LookSet(
        TRAINING_PALETTE,
        FULL_LIGHTS,
        textures=TRAINING_TEXTURES,
        camera_shift=MOUNT_SHIFT,
        camera_turn=MOUNT_TURN,
        distractors=True,
    ),
    "dusk": LookSet(
        DARK,
        LightRange(
            scale=((0.4, 0.4),),
            headlight=((0.5, 0.5),),
            tint=(0.2, 0.2),
            cast=True,
            cast_channels=(0, 2),
        ),
        textures=HELDOUT_TEXTURES,
        distractors=True,
        fixed_seed=1,
    ),
    "neon": LookSet(
        NEON,
        LightRange(
            scale=((1.6, 1.6),),
            headlight=((0.55, 0.55),),
            tint=(0.18, 0.18),
            cast=True,
            cast_channels=(2, 1),
        ),
        textures=HELDOUT_TEXTURES,
        distractors=True,
        fixed_seed=2,
    ),
    "glare": LookSet(
        PALE,
        LightRange(
            scale=((1.9, 1.9),),
            headlight=((1.55, 1.55),),
            tint=(0.12, 0.12),
            cast=True,
            cast_channels=(2, 0),
        ),
        textures=HELDOUT_TEXTURES,
        distractors=True,
        fixed_seed=3,
    ),
}
"""Every value of ``env.appearance`` but ``off`` (:mod:`maopg.sim.looks` describes them)."""


@dataclass(frozen=True)
class Layout:
    """What of a scene a look restyles: the role of each surface group, and how many lights,
    robot cameras, distractor spots and distractors it has."""

    roles: tuple[str, ...]
    lights: int
    cameras: int
    spots: int
    distractors: int


@dataclass(frozen=True)
class Finish:
    """A surface group's look: its colour, and the texture and repeats per metre of its
    material (``texture=None``: the group keeps its own material)."""

    rgb: RGB
    texture: str | None = None
    scale: float = 1.0


@dataclass(frozen=True)
class Move:
    """A small rigid move: a shift (m) and a turn (unit quaternion)."""

    shift: tuple[float, float, float] = (0.0, 0.0, 0.0)
    turn: Quat = (1.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Placement:
    """A shown distractor: the index of its spot, its heading (rad) and its colour."""

    spot: int
    yaw: float
    rgb: RGB


@dataclass(frozen=True)
class Look:
    """One episode's appearance, in numbers (see :func:`draw`)."""

    finishes: tuple[Finish, ...]
    """One per surface group, in :attr:`Layout.roles`' order."""
    light_scale: float
    headlight_scale: float
    tint: RGB
    lights: tuple[Move, ...]
    cameras: tuple[Move, ...]
    distractors: tuple[Placement | None, ...]
    """One per distractor; ``None``: hidden."""


def draw(name: str, seed: int, layout: Layout) -> Look:
    """The look of an episode with ``seed`` under ``env.appearance=name`` (not ``off``)."""
    looks = LOOK_SETS[name]
    rng = np.random.default_rng([seed if looks.fixed_seed is None else looks.fixed_seed, STREAM])
    finishes = tuple(_finish(looks, role, rng) for role in layout.roles)
    light = looks.lights
    light_scale = _in_union(light.scale, rng)
    headlight_scale = _in_union(light.headlight, rng)
    tint = _tint(light, rng)
    lights = tuple(_move(light.shift, light.turn, rng) for _ in range(layout.lights))
    cameras = tuple(
        _move(looks.camera_shift, looks.camera_turn, rng) for _ in range(layout.cameras)
    )
    shown: tuple[Placement | None, ...] = (None,) * layout.distractors
    if looks.distractors and layout.spots:
        count = min(int(rng.integers(0, layout.distractors + 1)), layout.spots)
        spots = rng.choice(layout.spots, size=count, replace=False)
        shown = tuple(
            Placement(int(spots[k]), float(rng.uniform(0.0, math.pi)), _colour(looks, rng))
            if k < count
            else None
            for k in range(layout.distractors)
        )
    return Look(finishes, light_scale, headlight_scale, tint, lights, cameras, shown)


def _colour(looks: LookSet, rng: np.random.Generator) -> RGB:
    base = np.asarray(looks.palette[int(rng.integers(len(looks.palette)))])
    rgb = np.clip(base + rng.uniform(-COLOUR_JITTER, COLOUR_JITTER, 3), 0.0, 1.0)
    return (float(rgb[0]), float(rgb[1]), float(rgb[2]))


def _finish(looks: LookSet, role: str, rng: np.random.Generator) -> Finish:
    rgb = _colour(looks, rng)
    if looks.textures is None:
        return Finish(rgb)
    texture = looks.textures[int(rng.integers(len(looks.textures)))]
    scales = scales_of(texture)[role]
    return Finish(rgb, texture.name, scales[int(rng.integers(len(scales)))])


def _in_union(intervals: tuple[tuple[float, float], ...], rng: np.random.Generator) -> float:
    low, high = intervals[int(rng.integers(len(intervals)))]
    return float(rng.uniform(low, high))


def _tint(light: LightRange, rng: np.random.Generator) -> RGB:
    if not light.cast:
        d = rng.uniform(-light.tint[1], light.tint[1], 3)
        return (1.0 + float(d[0]), 1.0 + float(d[1]), 1.0 + float(d[2]))
    up, down = light.cast_channels or tuple(int(c) for c in rng.choice(3, 2, replace=False))
    u = float(rng.uniform(*light.tint))
    tint = [1.0, 1.0, 1.0]
    tint[up], tint[down] = 1.0 + u, 1.0 - u
    return (tint[0], tint[1], tint[2])


def _move(shift: tuple[float, float], turn: tuple[float, float], rng: np.random.Generator) -> Move:
    """A shift along each axis of size uniform in ``shift`` (m) and either sign, and a turn by
    an angle uniform in ``turn`` (degrees) about a uniformly random axis; the identity where
    both are ``(0, 0)``. A range from 0 draws the shift uniform in ``[-high, high]``."""
    if shift[1] == 0.0 and turn[1] == 0.0:
        return Move()
    low, high = shift
    if low == 0.0:
        d = rng.uniform(-high, high, 3)
    else:
        d = rng.uniform(low, high, 3) * rng.choice((-1.0, 1.0), 3)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    half = math.radians(float(rng.uniform(*turn))) / 2
    q = (math.cos(half), *(float(a) * math.sin(half) for a in axis))
    return Move((float(d[0]), float(d[1]), float(d[2])), q)  # type: ignore[arg-type]
