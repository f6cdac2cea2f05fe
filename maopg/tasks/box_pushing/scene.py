"""The Box Pushing scene, built in code (``MjSpec``) for each arena size: floor, walls, the
goal strip, three boxes as free bodies, the robots, the overview camera.

Physics choices, and why:

- **Boxes slide on the floor by explicit contact pairs** (``box_friction``, condim 3), and
  against everything else at ``BOX_SIDE_FRICTION``: the floor friction is what a push must
  overcome, the low side friction keeps a bumper from wedging a box into the floor (with the
  floor's 0.6 at the bumpers too, two Turtlebots stall under a big box of 50 kg, which they
  deliver at 0.05).
- **Elliptic friction cones with ``impratio`` 10**: MuJoCo's soft contacts let a box loaded
  below its static friction creep (pyramidal cones, ``impratio`` 1: one Turtlebot turned the
  big box 0.46 rad in 40 ticks of pushing); a stiffer friction impedance holds it (4 mm).
- **One contact per convex pair** (multi-point convex collision off): with it, a bumper
  touching a box's face next to its corner got the contact normal along the other face, so it
  drove on into the box unresisted until the collider pushed the box out upwards and tipped it
  over (random episodes did this); the single contact's normal is the right one.
- **Robots collide with each other**: the robot files keep ground robots apart from each
  other (Tool Delivery's Turtlebots share waypoints); here every collision geom of a robot
  also takes its own ``contype`` into its ``conaffinity``, so a robot stops another, or shoves
  it, as it would a box.

Looks: the floor's checks are cells, the goal strip along the north wall is yellow, a red dot
marks each waypoint, small boxes are orange and the big box blue (a delivered box turns
green), so a robot's camera tells the boxes apart and the overview shows their progress. No
light casts a shadow: on a floor this large the shadow map speckles the checks.
"""

from __future__ import annotations

import math

import mujoco

from maopg.sim.robots import get_robot
from maopg.sim.scene import Scene, SceneBuilder
from maopg.tasks.box_pushing.arena import (
    BIG_BOX_LENGTH,
    BOX_HEIGHT,
    BOX_SIDE_FRICTION,
    BOX_WIDTH,
    Arena,
)
from maopg.tasks.box_pushing.config import Config
from maopg.tasks.box_pushing_grid.world import agent_names

BOXES = ("small_box0", "small_box1", "big_box")
"""Body (and geom) names of the boxes, in the grid's order."""
SMALL_BOX_RGBA, BIG_BOX_RGBA, DELIVERED_RGBA = (
    (0.93, 0.6, 0.18, 1.0),
    (0.22, 0.4, 0.85, 1.0),
    (0.2, 0.75, 0.3, 1.0),
)
GOAL_RGBA = (0.98, 0.86, 0.35, 1.0)
WAYPOINT_RGBA = (0.75, 0.12, 0.12, 1.0)
WALL_HEIGHT = 0.4
WALL_THICKNESS = 0.1
OVERVIEW_PITCH = math.radians(62)
"""The overview camera looks down at this angle from the south (Tool Delivery's ~60 degrees),
so robots and boxes show their sides as well as their tops."""
OVERVIEW_FOVY = 47.0
OVERVIEW_DISTANCE = 1.45
"""The overview camera's distance from the arena's centre, in arena sides: the whole arena,
walls included, fits the 4:3 frame."""

SOLIMP = [0.95, 0.99, 0.001, 0.5, 2.0]
"""Box contacts' impedance: harder than MuJoCo's default (0.9, 0.95), so a bumper shoving a
small box into a wall sinks a few millimetres into it rather than a centimetre."""

NEAR = 0.001
"""m: the cameras' near clipping plane. A robot's camera may sit a few millimetres behind its
bumper (the Turtlebot's: 2 mm), so a box it pushes would be clipped away at MuJoCo's default
(1% of the model's extent: 7.5 cm on 6x6); the depth buffer is a reversed floating-point one,
so the far end loses nothing."""

_GEOM = mujoco.mjtGeom
VISUAL = {"contype": 0, "conaffinity": 0}


def arena_spec(config: Config, arena: Arena) -> mujoco.MjSpec:
    """The arena of ``config`` without robots (see the module docstring)."""
    spec = mujoco.MjSpec()
    spec.modelname = "box_pushing"
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_MULTICCD
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.45, 0.45, 0.45]
    spec.visual.headlight.specular = [0.05, 0.05, 0.05]
    side, cell, half = arena.side, arena.cell, arena.side / 2
    for name, kind, builtin, rgb1, rgb2, px in (
        ("floor", "2D", "CHECKER", [0.66, 0.65, 0.62], [0.56, 0.55, 0.52], 64),
        ("sky", "SKYBOX", "GRADIENT", [0.85, 0.88, 0.92], [0.55, 0.6, 0.68], 32),
    ):
        spec.add_texture(
            name=name,
            type=getattr(mujoco.mjtTexture, f"mjTEXTURE_{kind}"),
            builtin=getattr(mujoco.mjtBuiltin, f"mjBUILTIN_{builtin}"),
            rgb1=rgb1,
            rgb2=rgb2,
            width=px,
            height=px,
        )
    floor = spec.add_material(name="floor", texrepeat=[arena.size / 2, arena.size / 2])
    floor.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "floor"
    world = spec.worldbody
    world.add_light(
        name="sun",
        pos=[half, half, 6.0],
        dir=[0.2, 0.3, -1.0],
        diffuse=[0.55] * 3,
        castshadow=False,
    )
    world.add_light(name="fill", pos=[half, -2.0, 4.0], dir=[0.0, 0.6, -0.8], diffuse=[0.2] * 3)
    distance = OVERVIEW_DISTANCE * side
    world.add_camera(
        name="overview",
        pos=[half, half - distance * math.cos(OVERVIEW_PITCH), distance * math.sin(OVERVIEW_PITCH)],
        xyaxes=[1, 0, 0, 0, math.sin(OVERVIEW_PITCH), math.cos(OVERVIEW_PITCH)],
        fovy=OVERVIEW_FOVY,
    )
    world.add_geom(
        name="floor", type=_GEOM.mjGEOM_PLANE, pos=[half, half, 0], size=[half, half, 0.1]
    ).material = "floor"
    world.add_geom(
        name="goal",
        type=_GEOM.mjGEOM_BOX,
        pos=[half, side - cell / 2, 0.001],
        size=[half, cell / 2, 0.001],
        rgba=GOAL_RGBA,
        **VISUAL,
    )
    for k, (x, y) in enumerate(arena.waypoints):
        world.add_geom(
            name=f"waypoint{k}",
            type=_GEOM.mjGEOM_CYLINDER,
            pos=[x, y, 0.002],
            size=[0.04, 0.001, 0],
            rgba=WAYPOINT_RGBA,
            **VISUAL,
        )
    length, t = side + 2 * WALL_THICKNESS, WALL_THICKNESS / 2
    for name, pos, size in (
        ("wall_s", (half, -t), (length / 2, t)),
        ("wall_n", (half, side + t), (length / 2, t)),
        ("wall_w", (-t, half), (t, half)),
        ("wall_e", (side + t, half), (t, half)),
    ):
        world.add_geom(
            name=name,
            type=_GEOM.mjGEOM_BOX,
            pos=[*pos, WALL_HEIGHT / 2],
            size=[*size, WALL_HEIGHT / 2],
            rgba=[0.82, 0.8, 0.76, 1],
        )
    masses = (config.small_box_mass, config.small_box_mass, config.big_box_mass)
    for name, (x, y), mass in zip(BOXES, arena.boxes, masses, strict=True):
        big = name == BOXES[2]
        body = world.add_body(name=name, pos=[x, y, BOX_HEIGHT / 2])
        body.add_freejoint(name=name)
        body.add_geom(
            name=name,
            type=_GEOM.mjGEOM_BOX,
            size=[
                (BIG_BOX_LENGTH if big else BOX_WIDTH) * cell / 2,
                BOX_WIDTH * cell / 2,
                BOX_HEIGHT / 2,
            ],
            mass=mass,
            friction=[BOX_SIDE_FRICTION, 0.005, 0.0001],
            priority=1,
            solimp=SOLIMP,
            rgba=BIG_BOX_RGBA if big else SMALL_BOX_RGBA,
        )
        mu = config.box_friction
        spec.add_pair(
            name=f"{name}@floor",
            geomname1=name,
            geomname2="floor",
            condim=3,
            friction=[mu, mu, 0.005, 0.0001, 0.0001],
        )
    return spec


def build_scene(config: Config, arena: Arena) -> Scene:
    """Compile the arena with the robots at their starts, colliding with each other."""
    builder = SceneBuilder(
        arena_spec(config, arena),
        timestep=config.timestep,
        render_size=config.image_size,
        appearance=config.appearance,
    )
    robot = get_robot(config.turtlebot_robot)
    root = robot.adapter_class().root_body
    for name, (x, y, yaw) in zip(agent_names(config.agents), arena.starts, strict=True):
        builder.add_robot(name, robot, (x, y, 0.0), yaw)
        for geom in builder.spec.body(f"{name}/{root}").find_all(mujoco.mjtObj.mjOBJ_GEOM):
            geom.conaffinity |= geom.contype
    scene = builder.build()
    scene.model.vis.map.znear = NEAR / scene.model.stat.extent
    return scene
