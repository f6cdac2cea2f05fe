"""What a policy's cameras show under each ``env.appearance``: one figure per task, a row per
look, a column per robot camera, each image exactly as the policy receives it.

Run: ``.venv/bin/python bench/analysis/looks_gallery.py [--tasks tool_delivery,water_filling]
[--episodes 3] [--size 64] [--out results/vision]`` (writes ``looks_<task>.png``).

The rows: the scene as its task builds it (``off``); ``full``, the training looks of the vision
study, and ``heldout`` and ``mounts``, the held-out looks it is evaluated in, each on the first
``--episodes`` reset seeds (0, 1, ...: the vision study's evaluation episodes, so these are the
looks its policies are scored in); then the fixed held-out presets ``dusk``, ``neon`` and
``glare``. Each image is the observation the environment hands the policy at the episode's first
decision point (``images=true`` at ``--size`` pixels), drawn with nearest-neighbour scaling so
no pixel is invented. The figure's pixels depend on the GL rasteriser (printed with the conditions).
"""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import argparse
from pathlib import Path

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import matplotlib.pyplot as plt
import numpy as np

from maopg.env import make_env
from maopg.sim.egl_check import gl_strings
from maopg.sim.looks import OFF, PRESETS

TASKS = ("tool_delivery", "water_filling")
"""The vision study's tasks."""


def rows(episodes: int) -> list[tuple[str, int]]:
    """The figure's rows: ``(look, reset seed)``."""
    drawn = [(look, seed) for look in ("full", "heldout", "mounts") for seed in range(episodes)]
    return [(OFF, 0), *drawn, *((preset, 0) for preset in PRESETS)]


def first_images(task: str, look: str, seed: int, size: int) -> np.ndarray:
    """``[N, H, W, 3]``: every robot camera's image at the first decision point of the
    episode with reset ``seed`` under ``env.appearance=look``."""
    env = make_env(task, seed=0, images=True, image_size=size, overrides={"appearance": look})
    try:
        images = env.reset(seed=seed).images
        if images is None:
            raise RuntimeError(f"{task} gave no images with images=true")
        return images.copy()
    finally:
        env.close()


def gallery(task: str, episodes: int, size: int, out: Path) -> Path:
    """Draw ``task``'s figure into ``out/looks_<task>.png``."""
    looks = rows(episodes)
    images = [first_images(task, look, seed, size) for look, seed in looks]
    agents = images[0].shape[0]
    fig, axes = plt.subplots(
        len(looks),
        agents,
        figsize=(max(1.6 * agents + 1.4, 4.6), 1.6 * len(looks)),
        squeeze=False,
    )
    for r, ((look, seed), frame) in enumerate(zip(looks, images, strict=True)):
        for a in range(agents):
            ax = axes[r][a]
            ax.imshow(frame[a], interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(f"agent {a}", fontsize=9)
        drawn = look if look == OFF or look in PRESETS else f"{look}, seed {seed}"
        axes[r][0].set_ylabel(drawn, fontsize=9, rotation=0, ha="right", va="center")
    fig.suptitle(f"{task}\nrobot cameras at the first decision point ({size} px)", fontsize=10)
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.6 / fig.get_figheight()))  # room for the title
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"looks_{task}.png"
    fig.savefig(path, dpi=100, metadata={"Software": None})
    plt.close(fig)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tasks", default=",".join(TASKS))
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--out", type=Path, default=Path("results/vision"))
    args = parser.parse_args()
    vendor, renderer = gl_strings()
    print(f"GL: {vendor} / {renderer}; {args.size} px; reset seeds 0-{args.episodes - 1}")
    for task in args.tasks.split(","):
        print(f"{task}: {gallery(task, args.episodes, args.size, args.out)}")


if __name__ == "__main__":
    main()
