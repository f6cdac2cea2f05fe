"""Camera channels met where a user meets them: a run from colour, depth and segmentation
trains and resumes, its checkpoint's CNN reads them, the PettingZoo view bounds them, and a bad
camera setting is one line before anything is written."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from maopg.env.pettingzoo import parallel_env
from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main
from maopg.learner import load_checkpoint

RUN = [
    "--task",
    "box_pushing",
    "--method",
    "async",
    "--images",
    "image_size=36",
    "env.camera_channels=rgb+depth+seg",
    "env.camera_fovy=60",
    "env.max_ticks=30",
    "batch_ticks=60",
    "backend=local",
    "num_envs=1",
    "ppo.epochs=1",
    "progress=false",
    "video=false",
    "eval_episodes=0",
    "plot=false",
]


def test_a_run_from_every_channel_trains_and_resumes(tmp_path):
    run_dir = tmp_path / "run"
    assert main([*RUN, "--total-samples", "120", "--run-dir", str(run_dir)]) == 0
    assert main(["--resume", "--run-dir", str(run_dir), "--total-samples", "240"]) == 0
    with (run_dir / "metrics.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert int(rows[-1]["samples"]) >= 240
    final = load_checkpoint(run_dir / "final.pt")
    assert final["config"]["env_overrides"]["camera_channels"] == "rgb+depth+seg"
    weights = next(v for k, v in final["policy"].items() if k.endswith("cnn.convs.0.weight"))
    assert weights.shape[1] == 3 + 1 + 9, "colour, depth, one-hot over Box Pushing's 9 classes"


BAD = [
    (
        ["env.camera_channels=rgb+ir"],
        r"env\.camera_channels: unknown channel 'ir'; allowed: any of",
    ),
    (["env.camera_channels=rgb+rgb"], r"env\.camera_channels='rgb\+rgb' names a channel twice"),
    (["env.camera_fovy=arm:70"], r"env\.camera_fovy: the task's robots play no role 'arm'; roles"),
    (["env.camera_fovy=ground:wide"], r"env\.camera_fovy: 'ground:wide' is not a number; allowed"),
    (["env.camera_fovy=ground:190"], r"env\.camera_fovy must be < 180, got 'ground:190'"),
    (["env.camera_fovy=0"], r"env\.camera_fovy must be > 0, got 0"),
    (["env.camera_offset=drone:0 1"], r"env\.camera_offset: 'drone:0 1' is not 3 numbers"),
    (["env.camera_offset=[0,1]"], r"env\.camera_offset expected \[float, float, float\] or str"),
    (["env.camera_rotation=ground:1 2 3,ground:0 0 0"], r"gives role 'ground' twice"),
]


@pytest.mark.parametrize(("args", "message"), BAD, ids=[a[0] for a, _ in BAD])
def test_a_bad_camera_setting_is_one_line_before_anything_is_written(
    tmp_path, user_error, args, message
):
    run_dir = tmp_path / "run"
    argv = ["--task", "water_filling", "--total-samples", "60", "--run-dir", str(run_dir), *args]
    err = user_error(main, argv, message)
    assert len(err.strip().splitlines()) == 1 and not run_dir.exists()


def test_the_pettingzoo_view_bounds_each_channel():
    overrides = {"camera_channels": "rgb+depth"}
    view = parallel_env("water_filling", images=True, image_size=36, overrides=overrides)
    try:
        observations, _ = view.reset(seed=0)
        space = view.observation_space("vehicle")["image"]
        near, far = view.env.spec.image_channels.depth_range
        assert space.shape == (36, 36, 4) and space.dtype == np.float32
        assert (space.low[0, 0].tolist(), space.high[0, 0].tolist()) == (
            [0, 0, 0, np.float32(near)],
            [255, 255, 255, np.float32(far)],
        )
        assert all(space.contains(observations[a]["image"]) for a in view.agents)
    finally:
        view.close()


def test_a_checkpoint_refuses_other_channels_of_the_same_shape(tmp_path, capsys):
    """``rgb+depth`` and ``rgb+seg`` both stack four planes, but not for the same encoder: a
    checkpoint evaluated under the other channels is one line, exit 2, nothing written."""
    run_dir = tmp_path / "run"
    settings = [s for s in RUN if not s.startswith("env.camera_channels")]
    argv = [*settings, "env.camera_channels=rgb+depth", "--total-samples", "60"]
    assert main([*argv, "--run-dir", str(run_dir)]) == 0
    capsys.readouterr()
    out = tmp_path / "eval.json"
    argv = ["evaluate", "--checkpoint", str(run_dir), "--json", str(out)]
    assert eval_main([*argv, "env.camera_channels=rgb+seg"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the checkpoint's policy cannot act" in err, err
    assert not out.exists()
