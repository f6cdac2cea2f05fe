"""Simulation-core benchmark: physics rate, option-layer overhead and camera cost per scene.

Run: ``.venv/bin/python bench/perf/sim_bench.py``. Prints a Markdown block for BENCHMARKS.md.
Scenes: Tool Delivery (Fetch + 2 Turtlebots) and, when its arena and robots exist, Water
Filling (vehicle + drone + 3 jars). Renders use one reused renderer over every robot camera.
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import math
import sys
import time
from collections.abc import Callable

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np

from maopg.sim.render import CameraRenderer
from maopg.sim.robots import ASSETS_DIR, get_robot, robot_names
from maopg.sim.scene import Scene, SceneBuilder, load_spec
from maopg.experiment.run.sysinfo import markdown

TD_TIMESTEP, TD_TICK = 0.02, 1.0
WF_TICK = 0.5
SIZES = (64, 84, 128)


def tool_delivery() -> tuple[Scene, float, Callable[[Scene, int], None]]:
    builder = SceneBuilder("arenas/tool_delivery.xml", timestep=TD_TIMESTEP, render_size=128)
    builder.add_robot("fetch", "fetch", (0.9, 1.8, 0.0))
    builder.add_robot("tb0", "turtlebot", (3.0, 1.5, 0.0))
    builder.add_robot("tb1", "turtlebot", (3.0, 2.5, 0.0))
    for i in range(3):
        builder.add_attachable(f"tool{i}/tool", (None, "fetch/gripper", "tb0/basket", "tb1/basket"))
    scene = builder.build()
    scene.attach("tool0/tool", "tb0/basket")
    shelf = scene.site_position("shelf/slot1")
    desk = scene.site_position("desk/slot0")

    def command(s: Scene, tick: int) -> None:
        """Both Turtlebots shuttle between the tool room and WA0; the arm swings."""
        s.robots["tb0"].drive_to((6.0, 3.0) if tick % 12 < 6 else (2.5, 3.5))
        s.robots["tb1"].drive_to((1.2, 3.0) if tick % 12 < 6 else (6.0, 3.0))
        fetch = s.robots["fetch"]
        fetch.set_arm_targets(fetch.ik(shelf if tick % 4 < 2 else desk))

    return scene, TD_TICK, command


def water_filling() -> tuple[Scene, float, Callable[[Scene, int], None]] | None:
    arena = ASSETS_DIR / "arenas" / "water_filling.xml"
    needed = ("vehicle", "drone")
    if not arena.exists() or not all(n in robot_names() for n in needed):
        print(f"> note: Water Filling skipped ({arena} or robots {needed} missing)")
        return None
    for name in needed:
        module = get_robot(name).adapter
        if not get_robot(name).mjcf.exists():
            print(f"> note: Water Filling skipped ({name} MJCF missing, adapter {module})")
            return None
    spec = load_spec(arena)
    sites = {s.name: np.array(s.pos) for s in spec.sites}
    builder = SceneBuilder(arena, timestep=float(spec.option.timestep), render_size=128)
    for i in range(3):
        builder.add_prop(f"jar{i}", "props/jar.xml", sites[f"jar_{i}"])
    builder.add_robot("vehicle", "vehicle", sites["spawn_vehicle"])
    builder.add_robot("drone", "drone", sites["spawn_drone"])
    scene = builder.build()

    def command(s: Scene, tick: int) -> None:
        """The vehicle and the drone shuttle 1 m back and forth (drone at 1.5 m)."""
        v, d = sites["spawn_vehicle"], sites["spawn_drone"]
        dx = 1.0 if tick % 8 < 4 else 0.0
        s.robots["vehicle"].drive_to((v[0] + dx, v[1]))
        s.robots["drone"].fly_to((d[0] - dx, d[1], 1.5))

    return scene, WF_TICK, command


def physics(scene: Scene, tick: float, command, ticks: int) -> tuple[float, float, float]:
    """(us per bare mj_step, ms per tick via Scene.advance, ms per bare-physics tick).

    The bare run replays the controls the option layer produced, from the same start, so both
    simulate the same motion; each is the best of 3 runs.
    """
    model, data = scene.model, scene.data
    nstep = round(tick / scene.timestep)
    full = bare = math.inf
    for _ in range(3):
        scene.reset()
        ctrls = []
        start = time.perf_counter()
        for t in range(ticks):
            command(scene, t)
            scene.advance(tick)
            ctrls.append(data.ctrl.copy())
        full = min(full, (time.perf_counter() - start) / ticks)
        if any(r.control_hz is not None for r in scene.robots.values()):
            ctrls = None  # a controller runs inside the tick: replay can't reproduce it
        scene.reset()
        start = time.perf_counter()
        for t in range(ticks):
            if ctrls is not None:
                data.ctrl[:] = ctrls[t]
            mujoco.mj_step(model, data, nstep=nstep)
        bare = min(bare, (time.perf_counter() - start) / ticks)
    return bare / nstep * 1e6, full * 1e3, bare * 1e3


def camera_ms(scene: Scene, size: int, fast: bool, reps: int) -> float:
    cameras = [r.camera_name for r in scene.robots.values()]
    with CameraRenderer(scene.model, size, size, fast=fast) as renderer:
        out = renderer.render(scene.data, cameras)
        start = time.perf_counter()
        for _ in range(reps):
            renderer.render(scene.data, cameras, out=out)
        elapsed = time.perf_counter() - start
    return elapsed / (reps * len(cameras)) * 1e3


def main() -> int:
    scenes = {"Tool Delivery": tool_delivery()}
    wf = water_filling()
    if wf is not None:
        scenes["Water Filling"] = wf
    print("### Simulation core (`bench/perf/sim_bench.py`)\n")
    print(markdown() + "\n")
    print(
        "| scene | bodies/geoms/actuators | timestep | tick | mj_step (µs) | steps/s "
        "| bare tick (ms) | Scene.advance tick (ms) | option-layer overhead |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, (scene, tick, command) in scenes.items():
        m = scene.model
        step_us, full_ms, bare_ms = physics(scene, tick, command, ticks=60)
        rated = [p for p, r in scene.robots.items() if r.control_hz is not None]
        note = f" (includes {', '.join(rated)}: Python control at control_hz)" if rated else ""
        print(
            f"| {name} | {m.nbody}/{m.ngeom}/{m.nu} | {scene.timestep * 1e3:g} ms | {tick:g} s "
            f"| {step_us:.1f} | {1e6 / step_us:,.0f} | {bare_ms:.2f} | {full_ms:.2f} "
            f"| {100 * (full_ms - bare_ms) / bare_ms:+.0f}%{note} |"
        )
    print(
        "\nms per camera frame (mean over every robot camera of the scene, one reused renderer; "
        "observation = shadows/reflections off, offsamples 0; defaults = shadows on, "
        "offsamples 4, shadowsize 2048 from the arenas):\n"
    )
    print("| scene | cameras | setting | " + " | ".join(f"{s} px" for s in SIZES) + " |")
    print("|---|---|---|" + "---|" * len(SIZES))
    for name, (scene, _, _) in scenes.items():
        for fast, label in ((True, "observation"), (False, "MuJoCo defaults")):
            reps = 30 if fast else 5
            cells = " | ".join(f"{camera_ms(scene, s, fast, reps):.1f}" for s in SIZES)
            print(f"| {name} | {len(scene.robots)} | {label} | {cells} |")
    cams = math.fsum(len(s.robots) for s, _, _ in scenes.values())
    print(f"\n({int(cams)} robot cameras benchmarked in total.)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
