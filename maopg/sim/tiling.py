"""A bigger room made of copies of an arena: ``cols x rows`` tiles of its furniture in one room.

A task whose team can grow (Water Filling: more robots, more jars) keeps the density of
furniture, jar stands and spawn points of its hand-made arena by tiling it, instead of
stretching the furniture or shipping an MJCF file per size. The arena follows the conventions of
``assets/arenas/water_filling.xml``:

* the floor is a plane geom named ``floor`` centred on the origin; its half sizes are the tile's
  half extent;
* the outer walls are boxes named ``wall_*`` along the floor's edges;
* everything else in the world body (furniture, layout sites) is the tile's content.

The tiled room is one open-plan room: one floor and one set of outer walls (both stretched to
the whole room), the directional lights once, the cameras moved back (away from the origin) so
that they frame the whole room as they framed one tile, and each tile's content copied under a
frame at the tile's offset with the name prefix ``t<k>/`` (row-major, tile 0 at the
south-west). A copy keeps its
own materials (prefixed); the floor's texture repeat grows with the floor, so the checker keeps
its size. The near clipping plane is given relative to the model's extent, which grows with the
room, so it is scaled back to keep the robots' cameras clipping where they did in one tile.

The arena's other lights (Water Filling's two ceiling lamps) are not copied: every light is
shaded per pixel in every camera, and past eight MuJoCo's renderer needs more passes: with
four tiles' lamps (9 lights) a camera frame on llvmpipe cost several times what it costs
without them. A tiled room is lit by the directional light and the headlight alone, a little
darker than one tile under its lamps.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from maopg.sim.scene import load_spec, strip_for_attaching

FLOOR = "floor"
WALL_PREFIX = "wall_"
CAMERA_ASPECT = 4 / 3
"""Width over height of the pictures the arena's cameras take (a video's 640 x 480 overview):
a room wider than tall needs the cameras moved back by ``cols / aspect``, not ``cols``."""


def tile_prefix(tile: int) -> str:
    """The name prefix of tile ``tile``'s copy (its sites are ``t<k>/jar_0``, ...)."""
    return f"t{tile}/"


def tile_offsets(half_extent: tuple[float, float], cols: int, rows: int) -> list[np.ndarray]:
    """Planar offset of each tile's centre, row-major from the south-west, the room centred on
    the origin."""
    hx, hy = half_extent
    return [
        np.array([(c - (cols - 1) / 2) * 2 * hx, (r - (rows - 1) / 2) * 2 * hy])
        for r in range(rows)
        for c in range(cols)
    ]


def _is_shell(geom: mujoco.MjsGeom) -> bool:
    return geom.name == FLOOR or geom.name.startswith(WALL_PREFIX)


def _is_directional(light: mujoco.MjsLight) -> bool:
    return light.type == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL


def _shell(path: Path, cols: int, rows: int) -> mujoco.MjSpec:
    """The arena with only its floor, walls, directional lights and cameras, all scaled."""
    spec = load_spec(path)
    world = spec.worldbody
    for element in [*world.bodies, *world.sites, *world.frames]:
        spec.delete(element)
    for geom in list(world.geoms):
        if not _is_shell(geom):
            spec.delete(geom)
    for light in list(world.lights):
        if not _is_directional(light):
            spec.delete(light)
    floor = spec.geom(FLOOR)
    if floor is None:
        raise ValueError(f"{path}: tiling needs a floor geom named {FLOOR!r}")
    half = np.array(floor.size[:2], dtype=float)
    grow = np.array([cols, rows], dtype=float)
    floor.size[:2] = half * grow
    if floor.material:
        material = spec.material(floor.material)
        material.texrepeat = np.asarray(material.texrepeat) * grow
    for wall in (g for g in world.geoms if g.name.startswith(WALL_PREFIX)):
        for axis in (0, 1):
            extra = half[axis] * (grow[axis] - 1.0)
            if abs(wall.pos[axis]) >= half[axis]:  # a wall across this axis: move it out
                wall.pos[axis] += np.sign(wall.pos[axis]) * extra
            else:  # a wall along this axis: stretch it
                wall.size[axis] += extra
    scale = max(rows, cols / CAMERA_ASPECT, 1.0)
    for camera in world.cameras:
        camera.pos = np.asarray(camera.pos) * scale
    return spec


def _content(path: Path, parent: mujoco.MjSpec) -> mujoco.MjSpec:
    """The arena without its shell (floor, walls, cameras) and lights, ready to attach to
    ``parent``: no skybox or material left that only the shell used."""
    spec = load_spec(path)
    world = spec.worldbody
    for element in [*(g for g in world.geoms if _is_shell(g)), *world.lights, *world.cameras]:
        spec.delete(element)
    used = {g.material for g in spec.geoms if g.material}
    for material in list(spec.materials):
        if material.name not in used:
            spec.delete(material)
    textures = {name for m in spec.materials for name in m.textures if name}
    for texture in list(spec.textures):
        if texture.name not in textures:
            spec.delete(texture)
    strip_for_attaching(spec, parent, lights=False)
    return spec


def tile_arena(path: str | Path, cols: int, rows: int) -> mujoco.MjSpec:
    """An open-plan room of ``cols x rows`` copies of the arena at ``path`` (see the module
    docstring), as a spec to build a scene on."""
    if cols < 1 or rows < 1:
        raise ValueError(f"tiles must be at least 1 x 1, got {cols} x {rows}")
    path = Path(path)
    spec = _shell(path, cols, rows)
    spec.modelname = f"{spec.modelname}_{cols}x{rows}"
    half = tuple(float(v) / n for v, n in zip(spec.geom(FLOOR).size[:2], (cols, rows), strict=True))
    for k, (x, y) in enumerate(tile_offsets(half, cols, rows)):
        frame = spec.worldbody.add_frame(pos=[x, y, 0.0])
        spec.attach(_content(path, spec), prefix=tile_prefix(k), frame=frame)
    one_tile = load_spec(path).compile().stat.extent
    spec.visual.map.znear *= one_tile / spec.compile().stat.extent
    return spec
