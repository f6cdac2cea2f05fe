"""Grid planner on the Water Filling room: clearance, reachability, and a physical drive."""

from __future__ import annotations

# isort: off
import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
# isort: on

import itertools
import math

import mujoco
import numpy as np
import pytest

from maopg.sim.planning import GridPlanner, occupancy_grid, path_length
from maopg.sim.robots.vehicle import VehicleConstants
from maopg.sim.scene import Scene
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.constants import GROUND_BAND
from maopg.tasks.water_filling.scene import JAR_PROP, arena_path, read_arena

ROOM = read_arena(Config())
JARS = list(ROOM.jar_xy)
SPAWNS = [np.array(ROOM.starts[0]), np.array(ROOM.starts[1]), np.array([0.5, -0.6])]


@pytest.fixture(scope="module")
def scene(wf_scene) -> Scene:
    return wf_scene()


@pytest.fixture(scope="module")
def planner(scene: Scene) -> GridPlanner:
    return GridPlanner.for_model(scene.model, radius=VehicleConstants.radius, z_band=GROUND_BAND)


def test_grid_blocks_furniture_and_walls_but_not_robots_or_the_open_floor(
    scene: Scene, planner: GridPlanner
) -> None:
    grid = planner.grid
    assert not grid.is_free((-2.4, -1.2))  # coffee table
    assert not grid.is_free((2.9, 2.2))  # sofa
    assert not grid.is_free((-2.75, 1.5))  # partition
    assert not grid.is_free((4.9, 0.0))  # east wall minus clearance
    assert not grid.is_free(JARS[0])  # jar stand
    assert not grid.is_free((20.0, 0.0))  # outside the room
    assert grid.is_free((0.0, 0.5))  # open floor
    assert grid.is_free(ROOM.starts[0])  # robots are not obstacles
    # the drone flies over partitions and furniture, not over the bookshelf or walls
    high = occupancy_grid(scene.model, radius=0.3, z_band=(1.3, 1.7))
    assert high.is_free((-2.75, 1.5)) and high.is_free((2.9, 2.2))
    assert not high.is_free((-2.8, -4.6))


@pytest.mark.parametrize("jar", range(3))
@pytest.mark.parametrize("spawn", range(3))
def test_paths_reach_every_jar_from_every_spawn_with_clearance(
    scene: Scene, planner: GridPlanner, spawn: int, jar: int
) -> None:
    start = SPAWNS[spawn]
    path = planner.plan(start, JARS[jar])
    end = path[-1]
    assert np.linalg.norm(end - JARS[jar]) < VehicleConstants.fill_radius
    pts = [start, *path]
    for a, b in itertools.pairwise(pts):
        assert planner.grid.segment_free(a, b)
    # independent check of the clearance: probe each path point with MuJoCo's own distance query
    radius = VehicleConstants.radius
    clearance = _min_distance_to_static(scene.model, pts, radius)
    assert clearance >= 0.0, f"path comes {-clearance:.3f} m into an obstacle"
    assert path_length(start, path) >= np.linalg.norm(end - start) - 1e-9


def _min_distance_to_static(model: mujoco.MjModel, pts, radius: float) -> float:
    """Smallest signed distance between a vertical probe cylinder of ``radius`` moved along the
    polyline and any static collidable geom, from ``mj_geomDistance`` (not the planner's grid)."""
    spec = mujoco.MjSpec.from_file(str(arena_path(Config())))
    for i, site in enumerate(ROOM.jar_sites):
        frame = spec.worldbody.add_frame(pos=list(site))
        spec.attach(
            mujoco.MjSpec.from_file(str(JAR_PROP)),
            prefix=f"j{i}/",
            frame=frame,
        )
    probe = spec.worldbody.add_body(name="probe", mocap=True)
    probe.add_geom(
        name="probe", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[radius, 0.35, 0], pos=[0, 0, 0.4]
    )
    m = spec.compile()
    d = mujoco.MjData(m)
    pid = m.geom("probe").id
    static = [
        g
        for g in range(m.ngeom)
        if m.geom_bodyid[g] != m.body("probe").id
        and (m.geom_contype[g] or m.geom_conaffinity[g])
        and m.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE
    ]
    best = math.inf
    for a, b in itertools.pairwise(pts):
        n = max(1, math.ceil(np.linalg.norm(b - a) / 0.05))
        for k in range(n + 1):
            p = a + (b - a) * k / n
            d.mocap_pos[0] = (p[0], p[1], 0.0)
            mujoco.mj_kinematics(m, d)
            for g in static:
                best = min(best, mujoco.mj_geomDistance(m, d, pid, g, 0.5, None))
    return best


def test_unreachable_goal_and_free_goal(wf_scene) -> None:
    model = wf_scene().model
    planner = GridPlanner.for_model(model, radius=0.36, z_band=GROUND_BAND)
    free_goal = (0.5, 0.5)
    assert np.allclose(planner.plan((0.0, 0.0), free_goal)[-1], free_goal)  # straight line
    boxed = GridPlanner.for_model(model, radius=0.36, z_band=GROUND_BAND, bounds=(-1, 1, -1, 1))
    boxed.grid.blocked[:, 10] = True  # a wall across the small grid
    with pytest.raises(ValueError, match="no collision-free path"):
        boxed.plan((-0.8, 0.0), (0.8, 0.0))


def test_vehicle_follows_a_planned_path_to_a_jar_without_touching_anything(wf_scene) -> None:
    """The physical check: drive the vehicle along the waypoints with its own controller."""
    scene = wf_scene()
    vehicle = scene.robots["vehicle"]
    planner = GridPlanner.for_model(scene.model, radius=VehicleConstants.radius, z_band=GROUND_BAND)
    start = vehicle.position[:2]
    path = planner.plan(start, JARS[0])  # around the north-west partition
    assert len(path) >= 2, "the partition should force a turn"
    body = vehicle.root_body_id
    t = 0.0
    for waypoint in path:
        vehicle.drive_to(waypoint)
        while not vehicle.at(waypoint, 0.03):
            scene.advance(0.5)
            t += 0.5
            for c in scene.data.contact[: scene.data.ncon]:
                bodies = {scene.model.geom_bodyid[c.geom1], scene.model.geom_bodyid[c.geom2]}
                assert body not in bodies, "the vehicle touched an obstacle"
            assert t < path_length(start, path) / 0.5 + 3.0, "took too long"
    assert np.linalg.norm(vehicle.position[:2] - JARS[0]) < VehicleConstants.fill_radius
