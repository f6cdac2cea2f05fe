"""Rollout videos, the old path (one frame a tick) beside the new one (four), in one run.

Run: ``.venv/bin/python bench/perf/video_speed.py [--ref 1754aaf] [--rounds 2] [--tasks
water_filling tool_delivery]``. Prints a Markdown block for BENCHMARKS.md (progress goes to
stderr).

- *old*: ``git archive REF`` (default: the last commit before the frames between ticks), its
  ``record_episode`` at its defaults: a frame a tick at 4 fps, the overview with shadows and 4x
  multisampling, x264 at its default preset, the whole frame drawn anew every frame.
- *new*: a snapshot of the working tree, its ``record_episode`` at its defaults: four frames a
  tick (physics states inside the tick) at 16 fps, the overview framed to the scene and
  rendered as the observations are, the robots' cameras once a tick, the panel, captions and
  timeline drawn once a tick, x264 ``veryfast``.

A second table times the overview alone, the larger part of a frame's work, at each step
from the old setting to the new, interleaved in this process (this tree): MuJoCo's defaults,
the observations' setting (no shadows, reflections nor multisampling, only the geoms in view),
and that with coarser built-in meshes (``maopg.sim.render.VIDEO_DETAIL``).

Both film the scripted policy's episode at seed 0 (Water Filling: 300 ticks, the episode the
45-second target is about; Tool Delivery: 41). Each recording runs in a fresh subprocess with
``maopg`` imported from its own checkout (``compare_checkouts.run_script`` checks it), old and
new back to back in every round, the first of the pair swapping from round to round. The
machine is shared, so besides the wall time each recording reports the CPU time it used: its
own process's (``time.process_time``: Python, MuJoCo and llvmpipe's rendering threads) and its
encoder's (the ``ffmpeg`` child, ``RUSAGE_CHILDREN``). Their sum is the work a recording is:
on a quiet machine, where one of its threads is always running, its wall time is at most that
(less where the encoder and the rendering overlap on two cores). Contention inflates CPU time
too, so on a busy machine the sum overstates it.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve()
DEFAULT_REF = "1754aaf"
MARK = "@@video_speed@@"
TARGET_S = 45.0
"""A full Water Filling episode's video, at most, on a quiet 2-core machine."""
OLD_QUIET_S = 42.0
"""What the old path took for it there (the figure issue #46 reports); this shared machine is
never quiet, so the new path's time there is this scaled by the ratios measured here."""


def child(task: str, out: str) -> None:
    """Record the scripted episode of ``task`` (seed 0) with the ``maopg`` on the path; print
    one line of figures."""
    import resource
    import time

    from maopg.env import make_env
    from maopg.env.rollout import reference_policy
    from maopg.env.video import record_episode

    env = make_env(task, "continue", seed=0)
    policy = reference_policy("scripted", env, 0)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall, cpu = time.perf_counter(), time.process_time()
    video = record_episode(env, policy, out, seed=0)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    env.close()
    encoder = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    figures = {
        "ticks": video.ticks,
        "frames": video.frames,
        "shape": list(video.shape),
        "wall": wall,
        "cpu": cpu,
        "encoder": encoder,
        "mb": Path(out).stat().st_size / 1e6,
    }
    print(MARK, json.dumps(figures))


def overview_costs(task: str, frames: int) -> dict[str, float]:
    """CPU ms per 640x480 overview frame of ``task`` (after reset, framed as a video frames
    it) at each setting, the settings taking turns frame by frame."""
    import time

    import numpy as np

    from maopg.env import make_env
    from maopg.sim.culling import cull_outside_view
    from maopg.sim.framing import overview_view
    from maopg.sim.render import VIDEO_DETAIL, make_renderer

    env = make_env(task, "continue", seed=0)
    env.reset(seed=0)
    model, data = env.task.scene.model, env.task.scene.data
    camera = overview_view(model, data, 640 / 480).free_camera(model)
    offsamples = int(model.vis.quality.offsamples)
    settings = {
        "MuJoCo defaults (shadows, multisampling)": (True, offsamples, None),
        "observation setting": (False, 0, None),
        f"observation setting, meshes {VIDEO_DETAIL}": (False, 0, VIDEO_DETAIL),
    }
    renderers = {
        name: make_renderer(model, 480, 640, shadows=shadows, offsamples=n, detail=detail)
        for name, (shadows, n, detail) in settings.items()
    }
    out = np.empty((480, 640, 3), np.uint8)
    spent = dict.fromkeys(renderers, 0.0)
    try:
        for k in range(frames + 1):
            for name, renderer in renderers.items():
                start = time.process_time()
                renderer.update_scene(data, camera=camera)
                if not settings[name][0]:
                    cull_outside_view(renderer.scene, 640 / 480)
                renderer.render(out=out)
                if k:  # the first frame of each warms it up
                    spent[name] += time.process_time() - start
    finally:
        for renderer in renderers.values():
            renderer.close()
        env.close()
    return {name: 1e3 * t / frames for name, t in spent.items()}


def load_average() -> float:
    return float(Path("/proc/loadavg").read_text().split()[0])


def spread(values: list[float], digits: int) -> str:
    """Median (min–max)."""
    if len(values) == 1:
        return f"{values[0]:.{digits}f}"
    low, mid, high = min(values), statistics.median(values), max(values)
    return f"{mid:.{digits}f} ({low:.{digits}f}–{high:.{digits}f})"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ref", default=DEFAULT_REF, help="the old checkout (a git ref)")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--tasks", nargs="+", default=["water_filling", "tool_delivery"])
    parser.add_argument("--frames", type=int, default=40, help="overview frames per setting")
    parser.add_argument(
        "--old-quiet",
        type=float,
        default=OLD_QUIET_S,
        help="the old path's Water Filling video on a quiet 2-core machine, seconds",
    )
    parser.add_argument("--child", nargs=2, metavar=("TASK", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:  # imports maopg from PYTHONPATH, the checkout measured
        child(*args.child)
        return 0
    sys.path.insert(0, str(HERE.parent))  # compare_checkouts, beside this script
    from compare_checkouts import checkouts, run_script  # (it imports this tree's maopg)

    from maopg.experiment.run.sysinfo import markdown

    start_load = load_average()
    loads: list[float] = []
    runs: dict[tuple[str, str], list[dict]] = {}
    with tempfile.TemporaryDirectory(prefix="maopg-video-speed-") as tmp:
        work = Path(tmp)
        old, new, cwd = checkouts(args.ref, work)
        for r in range(args.rounds):
            pair = (old, new) if r % 2 == 0 else (new, old)
            for task in args.tasks:
                for side in pair:
                    other = new if side is old else old
                    out = work / f"{side.side}_{task}_{r}.mp4"
                    loads.append(load_average())
                    text = run_script(side, HERE, ("--child", task, str(out)), [other.root], cwd)
                    line = next(x for x in text.splitlines() if x.startswith(MARK))
                    figures = json.loads(line.removeprefix(MARK))
                    runs.setdefault((task, side.side), []).append(figures)
                    print(
                        f"[round {r + 1}] {task} {side.side}: {figures['wall']:.1f} s wall, "
                        f"{figures['cpu']:.1f} s CPU, {figures['encoder']:.1f} s encoder",
                        file=sys.stderr,
                    )
        descriptions = {c.side: f"{c.description}; maopg from `{c.maopg_file}`" for c in (old, new)}
    print("### Rollout video speed, old path beside new (`bench/perf/video_speed.py`)\n")
    print(markdown())
    print(f"- load average (1 min) before each recording: {min(loads):.2f}–{max(loads):.2f}")
    print(f"- load average (1 min) at end: {load_average():.2f} (at start {start_load:.2f})")
    print(f"- old: {descriptions['old']}")
    print(f"- new: {descriptions['new']}")
    print(
        f"- scripted policy, seed 0, `record_episode` at each side's defaults; {args.rounds} "
        "rounds, old and new back to back in each (the first swapping), each in a fresh "
        "subprocess; median (min–max) over the rounds"
    )
    print(
        "- CPU: the recording process's `time.process_time` (Python, MuJoCo, llvmpipe's "
        "threads); encoder: its ffmpeg child's; work = their sum, the most a recording's wall "
        "time is on a quiet machine\n"
    )
    print(
        "| task | path | ticks | frames | frame | wall (s) | CPU (s) | encoder CPU (s) | "
        "work (s) | work per frame (ms) | file (MB) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    work_of: dict[tuple[str, str], float] = {}
    for task in args.tasks:
        for side in ("old", "new"):
            done = runs[(task, side)]
            first = done[0]
            work = [f["cpu"] + f["encoder"] for f in done]
            work_of[(task, side)] = statistics.median(work)
            per_frame = [1e3 * w / f["frames"] for w, f in zip(work, done, strict=True)]
            height, width, _ = first["shape"]
            print(
                f"| {task} | {side} | {first['ticks']} | {first['frames']} | {width}x{height} | "
                f"{spread([f['wall'] for f in done], 1)} | {spread([f['cpu'] for f in done], 1)} "
                f"| {spread([f['encoder'] for f in done], 1)} | {spread(work, 1)} | "
                f"{spread(per_frame, 1)} | {spread([f['mb'] for f in done], 2)} |"
            )
    print()
    for task in args.tasks:
        old_work, new_work = work_of[(task, "old")], work_of[(task, "new")]
        old_frames = runs[(task, "old")][0]["frames"]
        new_frames = runs[(task, "new")][0]["frames"]
        ratio = (old_work / old_frames) / (new_work / new_frames)
        verdict = ""
        if task == "water_filling":  # scaled to the quiet machine the target is about
            walls = [statistics.median(f["wall"] for f in runs[(task, s)]) for s in ("old", "new")]
            by_wall, by_work = walls[1] / walls[0], new_work / old_work
            quiet = args.old_quiet
            verdict = (
                f"; new/old wall {by_wall:.2f}, work {by_work:.2f}: from the old path's "
                f"{quiet:.0f} s on a quiet 2-core machine, {by_wall * quiet:.0f} s and "
                f"{by_work * quiet:.0f} s there (target: {TARGET_S:.0f} s)"
            )
        print(
            f"- {task}: a frame costs {ratio:.1f}x less work on the new path; the whole video "
            f"{new_work / old_work:.2f}x the old one's work for {new_frames / old_frames:.1f}x "
            f"the frames{verdict}"
        )
    print(
        f"\nCPU ms per 640x480 overview frame ({args.frames} per setting, the settings taking "
        "turns; the whole process's CPU time, llvmpipe's threads included):\n"
    )
    costs = {task: overview_costs(task, args.frames) for task in args.tasks}
    names = list(next(iter(costs.values())))
    print("| setting | " + " | ".join(args.tasks) + " |")
    print("|---|" + "---|" * len(args.tasks))
    for name in names:
        print(f"| {name} | " + " | ".join(f"{costs[t][name]:.1f}" for t in args.tasks) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
