"""Bad inputs and config files (issue #17), met where a user meets them: the ``train`` and
``eval`` command lines (in process, where the process's state allows it), the PettingZoo view
and the robot adapters. A user error ends a command with status 2 and one ``error:`` line naming
the setting, no traceback, and leaves nothing behind."""

from __future__ import annotations

import ctypes.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from maopg.env import make_env
from maopg.env.pettingzoo import OptionParallelEnv
from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.cli.train_cli import parse_args
from maopg.experiment.run.migration import CONFIG_SCHEMA
from maopg.experiment.studies import get_study
from maopg.experiment.studies.grid import Cell, cell_config

REPO = Path(__file__).resolve().parents[2]
TINY = ["num_envs=1", "backend=local", "batch_ticks=60", "progress=false", "video=false"]
TINY += ["plot=false", "--total-samples", "60"]
WF = ["--task", "water_filling", "--no-images"]


def _one_line(err: str, pattern: str) -> None:
    import re

    lines = err.strip().splitlines()
    assert len(lines) == 1 and re.search(pattern, lines[0]), err
    assert "Traceback" not in err


BAD_TRAIN = [
    (["env.max_ticks=0"], r"env\.max_ticks must be >= 1, got 0"),
    (["env.max_ticks=-5"], r"env\.max_ticks must be >= 1, got -5"),
    (["env.max_ticks=1.5"], r"env\.max_ticks expected int, got 1\.5"),
    (["env.max_ticks=abc"], r"env\.max_ticks expected int, got 'abc'"),
    (["image_size=-1"], r"image_size must be >= 1, got -1"),
    (["image_size=2.5"], r"image_size expected int, got '2\.5'"),
    (["image_size=100000"], r"image_size must be <= 4096, got 100000"),
    ([*WF, "env.timestep=0"], r"env\.timestep must be > 0, got 0"),
    (["env.tick_seconds=-1"], r"env\.tick_seconds must be > 0, got -1"),
    (["env.tick_seconds=0.03"], r"env\.tick_seconds=0\.03 is not a whole number of env\.timestep"),
    ([*WF, "env.drop_std=-0.1"], r"env\.drop_std must be >= 0, got -0\.1"),
    ([*WF, "env.interval_scale=[15,5]"], r"env\.interval_scale must increase"),
    ([*WF, "env.vehicle_start=[1,2,3]"], r"env\.vehicle_start expected \[float, float\] or null"),
    ([*WF, "env.drone_start=[100,0]"], r"env\.drone_start=\(100, 0\) lies outside the arena"),
    (["env.fetch_base=[9,1]"], r"env\.fetch_base=\(9, 1\) lies outside the arena"),
    (["env.max_staged=3"], r"env\.max_staged must be <= 2, got 3"),
    (
        ["env.appearance=foggy"],
        r"env\.appearance must be one of \['off', 'light', 'full', 'heldout', 'mounts', 'dusk', "
        r"'neon', 'glare'\], got 'foggy'",
    ),
    (
        ["env.appearance=heldout"],
        r"env\.appearance=heldout is held out from training: a run trains under off, light, full",
    ),
    (["env.appearance=dusk"], r"env\.appearance=dusk is held out from training"),
    (["env.camera_offset=0 0 5"], r"env\.camera_offset must be <= 1, got '0 0 5'"),
    (["env.camera_rotation=ground:400 0 0"], r"env\.camera_rotation must be <= 180"),
    (["hidden=0"], r"hidden must be >= 1, got 0"),
    (["layers=0"], r"layers must be >= 1, got 0"),
    (["ppo.num_minibatches=0"], r"ppo\.num_minibatches must be >= 1, got 0"),
    (["ppo.gae_lambda=1.5"], r"ppo\.gae_lambda must be <= 1, got 1\.5"),
    (["ppo.gae_lambda=-0.1"], r"ppo\.gae_lambda must be >= 0, got -0\.1"),
    (["ppo.clip=-1"], r"ppo\.clip must be >= 0, got -1"),
    (["ppo.discount=yearly"], r"ppo\.discount must be one of \['smdp', 'event', 'option'\]"),
    (["num_workers=-1"], r"num_workers must be >= 0, got -1"),
    (["--seed", "-1"], r"seed must be >= 0, got -1"),
    (["gamma=nan"], r"gamma must be a finite number, got nan"),
    (["device=tpu"], r"device must be one of \['auto', 'cpu', 'cuda'\]"),
    (["precision=fp16"], r"precision must be one of \['fp32', 'bf16'\]"),
    (["--no-images", "env.images=true"], r"env\.images=True is not a task override: .*images=true"),
    (["env.image_size=48"], r"env\.image_size=48 is not a task override: .*image_size=84"),
    (["env.primitive=true"], r"env\.primitive=True is not a task override: .*end2end"),
    (["eval_episodes=-1"], r"eval_episodes must be >= 0, got -1"),
    ([*WF, "env.cruise_altitude=50"], r"env\.cruise_altitude=50: no wall or obstacle reaches"),
    (["env.tick_seconds=inf"], r"env\.tick_seconds must be a finite number, got inf"),
    (["env.step_reward=nan"], r"env\.step_reward must be a finite number, got nan"),
    (["logger=mlflow"], r"logger must be one of \['tensorboard', 'wandb'\]"),
    (["wandb.mode=cloud"], r"wandb\.mode must be one of \['online', 'offline'\]"),
    (["wandb.projekt=x"], r"unknown setting 'wandb\.projekt': did you mean 'wandb\.project'"),
    (["--method", "mac-dqn", "dqn.eps_end=2"], r"dqn\.eps_end must be <= 1, got 2"),
    (["--seed", "1", "seed=2"], r"--seed 1 contradicts seed=2"),
    (["--method", "async", "method=partial"], r"--method async contradicts method=partial"),
    (["--no-images", "images=true"], r"--no-images contradicts images=true"),
    (["--seed", "x"], r"argument --seed: invalid int value: 'x'"),
]


@pytest.mark.parametrize(("args", "message"), BAD_TRAIN, ids=[" ".join(a) for a, _ in BAD_TRAIN])
def test_a_bad_training_setting_is_one_line_naming_it(tmp_path, capsys, args, message):
    run_dir = tmp_path / "run"
    assert train_main([*TINY, "--run-dir", str(run_dir), *args]) == 2
    _one_line(capsys.readouterr().err, message)
    assert not run_dir.exists()


def test_the_debug_flag_shows_the_traceback(tmp_path):
    with pytest.raises(ValueError, match=r"hidden must be >= 1"):
        train_main([*TINY, "--run-dir", str(tmp_path / "run"), "hidden=0", "--debug"])


BAD_EVAL = [
    (["evaluate", "--reference", "scripted", "--seed", "-1"], r"argument --seed: must be >= 0"),
    (["evaluate", "--reference", "scripted", "--episodes", "0"], r"--episodes: must be >= 1"),
    (
        ["video", "--reference", "scripted", "--out", "x.txt"],
        r"video path x\.txt: must end in \.mp4",
    ),
    (["reproduce", "--eval-episodes", "-3", "--dry-run"], r"--eval-episodes: must be >= 0"),
    (
        ["reproduce", "--reference-episodes", "0", "--dry-run"],
        r"--reference-episodes: must be >= 1",
    ),
    (["table", "results/runs", "--window", "0"], r"--window: must be >= 1"),
    (["evaluate", "--reference", "random", "env.max_ticks=0"], r"env\.max_ticks must be >= 1"),
    (["evaluate", "--reference", "random", "max_ticks=5"], r"takes task settings only, .*env\."),
    (
        ["video", "--reference", "random", "env.appearance=sunny", "--out", "x.mp4"],
        r"env\.appearance must be one of \[.*\], got 'sunny'",
    ),
    (
        ["evaluate", "--reference", "scripted", "--set", "turtlebot_robot=diffbot"],
        r"--set is retired: .*env\.turtlebot_robot=diffbot",
    ),
    (["evaluate", "--reference", "random", "--strategy", "eventually"], r"--strategy: invalid"),
    (["video", "--reference", "random", "--fps", "0", "--out", "x.mp4"], r"--fps: must be >= 1"),
    (["reproduce", "--dry-run", "--set", "ppo.epochs=2"], r"--set is retired: .* ppo\.epochs=2"),
    (["reproduce", "--dry-run", "ppo.epochz=2"], r"unknown setting 'ppo\.epochz': did you mean"),
    (
        ["reproduce", "--dry-run", "seed=3"],
        r"tool_delivery/async: seed=3 contradicts the grid's cell \(seed \d+\)",
    ),
    (["reproduce", "--dry-run", "--config", "missing.yaml"], r"config file .*missing\.yaml"),
    (
        ["reproduce", "--study", "leaderboard", "--dry-run", "--seeds", "1"],
        r"--runs does not apply to --study leaderboard .*allowed: --results, --methods",
    ),
    (
        ["reproduce", "--study", "vision", "--dry-run", "--methods", "async"],
        r"--methods does not apply to --study vision .*allowed: --results, --runs, --tasks",
    ),
    (
        ["reproduce", "--study", "vision", "--dry-run", "env.appearance=full"],
        r"key=value does not apply to --study vision \(its variants fix",
    ),
    (
        ["reproduce", "--study", "vision", "--dry-run", "--tasks", "box_pushing"],
        r"task\(s\) \['box_pushing'\] not in study 'vision'; choose from \['tool_delivery'",
    ),
]


@pytest.mark.parametrize(("args", "message"), BAD_EVAL, ids=[" ".join(a) for a, _ in BAD_EVAL])
def test_a_bad_evaluation_setting_is_one_line_naming_it(tmp_path, capsys, args, message):
    runs = ["--runs", str(tmp_path / "runs"), "--results", str(tmp_path / "results")]
    argv = [*args, *runs] if args[0] == "reproduce" else args
    assert eval_main(argv) == 2
    _one_line(capsys.readouterr().err, message)
    assert not any(tmp_path.iterdir()) and not Path("x.mp4").exists() and not Path("x.txt").exists()


def test_a_corrupt_saved_config_is_named(tmp_path, capsys):
    run_dir = tmp_path / "runs" / "tool_delivery" / "async" / "seed0"
    run_dir.mkdir(parents=True)
    (run_dir / "metrics.csv").write_text("iteration,samples\n")
    (run_dir / "done.json").write_text("{}\n")
    for text, message in (('{"task": "tool_del', "is not valid JSON"), ("[1]", "a mapping")):
        (run_dir / "config.json").write_text(text)
        assert train_main(["--resume", "--run-dir", str(run_dir)]) == 2
        _one_line(capsys.readouterr().err, rf"{run_dir / 'config.json'}.*{message}")
        assert eval_main(["table", str(tmp_path / "runs")]) == 2
        _one_line(capsys.readouterr().err, rf"{run_dir / 'config.json'}.*{message}")


def _subprocess(args: list[str], **env: str) -> subprocess.CompletedProcess:
    """``python ARGS`` from the repository, headless (no display), ``env`` over this process's
    environment (whose PyOpenGL platform follows its own ``MUJOCO_GL``)."""
    unset = ("DISPLAY", "WAYLAND_DISPLAY", "PYOPENGL_PLATFORM")
    environ = {k: v for k, v in os.environ.items() if k not in unset}
    environ.update(env, PYTHONPATH=str(REPO))
    return subprocess.run(
        [sys.executable, *args], cwd=REPO, env=environ, capture_output=True, text=True, timeout=300
    )


@pytest.mark.skipif(ctypes.util.find_library("OSMesa") is not None, reason="OSMesa installed")
def test_osmesa_without_its_library_is_one_line(tmp_path):
    """``import mujoco`` itself fails here (inside PyOpenGL): the command line says why first."""
    proc = _subprocess(["-m", "train", "--run-dir", str(tmp_path / "run")], MUJOCO_GL="osmesa")
    assert proc.returncode == 2
    _one_line(proc.stderr, r"MUJOCO_GL=osmesa, but libOSMesa is not installed")
    assert not (tmp_path / "run").exists()


def test_glfw_without_a_display_is_one_line_before_anything_is_written(tmp_path):
    run_dir = tmp_path / "run"
    train = ["-m", "train", *TINY, "--run-dir", str(run_dir), "--images", "image_size=36"]
    proc = _subprocess(train, MUJOCO_GL="glfw")
    assert proc.returncode == 2
    _one_line(proc.stderr, r"MUJOCO_GL=glfw needs a display.*\(this run renders: images=true\)")
    assert not run_dir.exists()
    video = ["-m", "eval", "video", "--reference", "scripted", "--out", str(tmp_path / "v.mp4")]
    proc = _subprocess(video, MUJOCO_GL="glfw")
    assert proc.returncode == 2
    _one_line(proc.stderr, r"cannot render 640x480 frames with MUJOCO_GL=glfw: .*needs a display")


def test_an_error_exit_with_a_renderer_open_prints_only_the_error(tmp_path):
    """The video's renderers are open when writing the file fails: no ``EGLError`` follows."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    out = blocker / "sub" / "v.mp4"
    proc = _subprocess(["-m", "eval", "video", "--reference", "scripted", "--out", str(out)])
    assert proc.returncode == 2, proc.stderr
    assert "EGLError" not in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_a_frame_beyond_what_the_gl_context_holds_is_a_render_error(robots):
    """Configs cap ``image_size`` at 4096 (every GL renders that); a bigger frame asked of the
    renderer directly fails by its size, not deep in MuJoCo."""
    from maopg.sim.render import CameraRenderer, RenderError

    model = robots["fetch"].model
    with pytest.raises(RenderError, match=r"cannot render 100000x100000 frames with MUJOCO_GL=egl"):
        CameraRenderer(model, 100_000, 100_000)


# ---------------------------------------------------------------------------- config files
SETTINGS = ["--method", "sync-wait", "--seed", "3", "num_envs=2", "ppo.epochs=4"]
SETTINGS += ["ppo.lr=1e-3", "env.max_ticks=90", "env.desk_spots=[[0.8,3.0],[1.3,3.0]]"]
YAML = """\
method: sync-wait
seed: 3
num_envs: 2
ppo:
  epochs: 4
ppo.lr: 1e-3          # dotted keys work too; 1e-3 is a number, as in JSON
env:
  max_ticks: 90
  desk_spots: [[0.8, 3.0], [1.3, 3.0]]
"""
JSON = {
    "method": "sync-wait",
    "seed": 3,
    "num_envs": 2,
    "ppo": {"epochs": 4, "lr": 1e-3},
    "env.max_ticks": 90,
    "env": {"desk_spots": [[0.8, 3.0], [1.3, 3.0]]},
}


def _resolved(argv: list[str]) -> dict:
    config, _ = parse_args(argv)
    return config.resolved().to_dict()


def test_yaml_and_json_files_resolve_as_key_value_does(tmp_path):
    (tmp_path / "run.yaml").write_text(YAML)
    (tmp_path / "run.json").write_text(json.dumps(JSON))
    expected = _resolved(SETTINGS)
    assert _resolved(["--config", str(tmp_path / "run.yaml")]) == expected
    assert _resolved(["--config", str(tmp_path / "run.json")]) == expected
    # the file first, then key=value, then the flags
    over = _resolved(["--config", str(tmp_path / "run.yaml"), "ppo.epochs=6", "--seed", "5"])
    assert over["ppo"]["epochs"] == 6 and over["seed"] == 5 and over["ppo"]["lr"] == 1e-3


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("seed: [1\n", r"run\.yaml is not valid YAML"),
        ("- 1\n", r"run\.yaml: expected a mapping of settings, got list"),
        ("ppo.epochz: 2\n", r"unknown setting 'ppo\.epochz': did you mean 'ppo\.epochs'\?"),
        ("dqn:\n  lr: 1.0\n", r"do not belong to method 'async'"),
        ("env:\n  max_ticks: -1\n", r"env\.max_ticks must be >= 1, got -1"),
        ("seed: 2\n", None),  # a file's value may be repeated by a flag ...
    ],
)
def test_a_bad_config_file_is_one_line(tmp_path, capsys, text, message):
    (tmp_path / "run.yaml").write_text(text)
    run_dir = tmp_path / "run"
    argv = [*TINY, "--run-dir", str(run_dir), "--config", str(tmp_path / "run.yaml")]
    if message is None:  # ... and overridden by one: a flag contradicts only key=value
        argv += ["--seed", "4", "hidden=0"]
        message = r"hidden must be >= 1"
    assert train_main(argv) == 2
    _one_line(capsys.readouterr().err, message)
    assert not run_dir.exists()


def test_the_resolved_config_is_written_and_reads_back_as_a_config_file(tmp_path):
    (tmp_path / "run.yaml").write_text("hidden: 16\nenv:\n  max_ticks: 40\n")
    run_dir = tmp_path / "run"
    argv = [
        "--config",
        str(tmp_path / "run.yaml"),
        *TINY,
        "--run-dir",
        str(run_dir),
        "ppo.epochs=1",
    ]
    assert train_main(argv) == 0
    saved = json.loads((run_dir / "config.json").read_text())
    assert saved.pop("schema") == CONFIG_SCHEMA  # the layout it is written in
    assert saved["hidden"] == 16 and saved["env_overrides"] == {"max_ticks": 40}
    assert saved == _resolved(argv)
    assert _resolved(["--config", str(run_dir / "config.json")]) == saved


def test_the_grid_gives_its_settings_to_every_cell_as_train_does(tmp_path, capsys):
    """``eval reproduce`` takes train's ``key=value`` (anywhere: a list option does not swallow
    them) and ``--config``, checks them before any cell runs and hands them to every cell."""
    grid_file = tmp_path / "grid.yaml"
    grid_file.write_text("hidden: 16\n")
    runs = tmp_path / "runs"
    grid = ["reproduce", "--runs", str(runs), "--results", str(tmp_path / "res"), "--dry-run"]
    grid += ["--config", str(grid_file), "--tasks", "tool_delivery", "--methods", "async"]
    assert eval_main([*grid, "ppo.epochs=2"]) == 0
    assert "tool_delivery/async/seed0: would start" in capsys.readouterr().out
    assert eval_main([*grid, "ppo.epochs=0"]) == 2
    _one_line(capsys.readouterr().err, r"ppo\.epochs must be >= 1, got 0")
    paper = get_study("paper")
    cell, _ = cell_config(
        Cell("tool_delivery", "async", 0), runs, paper, ["ppo.epochs=2"], grid_file
    )
    cell = cell.resolved()
    assert (cell.seed, cell.hidden, cell.learner.epochs) == (0, 16, 2) and not runs.exists()


def test_evaluate_takes_task_settings_as_env_key_value(tmp_path):
    out = tmp_path / "eval.json"
    argv = ["evaluate", "--reference", "random", "--episodes", "1", "--json", str(out)]
    assert eval_main([*argv, "env.max_ticks=7"]) == 0
    assert json.loads(out.read_text())["length_mean"] == 7


# ---------------------------------------------------------------------------- PettingZoo
GO_TO_TR, WAIT = 1, 5
"""A Turtlebot's option to drive to the tool room, the Fetch's one-tick wait."""


@pytest.fixture(scope="module")
def parallel_env():
    """The PettingZoo view where only the Fetch chooses: the Turtlebots drive to the tool room
    (several ticks) while the Fetch waits (one); returns the view and its last infos."""
    env = OptionParallelEnv(make_env("tool_delivery", seed=0))
    env.reset(seed=0)
    *_, infos = env.step({"turtlebot0": GO_TO_TR, "turtlebot1": GO_TO_TR, "fetch": WAIT})
    assert infos["fetch"]["choosing"] and infos["turtlebot0"]["running"] == GO_TO_TR
    assert not infos["turtlebot0"]["choosing"]
    yield env, infos
    env.close()


@pytest.mark.parametrize(
    ("actions", "message"),
    [
        ({"fetch": 1.0}, r"agent 'fetch': action 1\.0 is not an integer option"),
        ({"fetch": "1"}, r"agent 'fetch': action '1' is not an integer option"),
        ({"fetch": math.nan}, r"agent 'fetch': action nan is not an integer option"),
        ({"fetch": None}, r"agent 'fetch': action None is not an integer option"),
        ({"fetch": True}, r"agent 'fetch': action True is not an integer option"),
        ({"fetch": 0, "fetch2": 0}, r"unknown agent\(s\) \['fetch2'\]"),
        ({"fetch": 0, "turtlebot0": 2}, r"agent 'turtlebot0': action 2, but it is still running"),
        ({"fetch": 99}, r"fetch"),
        ({"turtlebot0": 1}, r"\['fetch'\] are choosing"),
    ],
)
def test_bad_pettingzoo_actions_raise_naming_the_agent(parallel_env, actions, message):
    env, _ = parallel_env
    with pytest.raises(ValueError, match=message):
        env.step(actions)


def test_a_running_agent_may_repeat_its_option_or_send_nothing(parallel_env):
    env, infos = parallel_env
    *_, after = env.step({"fetch": np.int64(WAIT), "turtlebot0": infos["turtlebot0"]["running"]})
    assert after["fetch"]["ticks"] > infos["fetch"]["ticks"]


# ---------------------------------------------------------------------------- robot adapters
@pytest.fixture(scope="module")
def robots():
    envs = [make_env("water_filling", seed=0), make_env("tool_delivery", seed=0)]
    wf, td = (env.task for env in envs)
    yield {
        "drone": wf.drone,
        "vehicle": wf.vehicle,
        "turtlebot0": td.turtlebots[0],
        "fetch": td.fetch,
    }
    for env in envs:
        env.close()


@pytest.mark.parametrize(
    ("robot", "command", "args", "kwargs"),
    [
        ("drone", "fly_to", ((math.nan, 0.0, 1.5),), {}),
        ("drone", "fly_to", ((0.0, 0.0, 1.5),), {"yaw": math.inf}),
        ("drone", "fly_to", ((0.0, 0.0, 1.5),), {"speed": math.nan}),
        ("vehicle", "drive_to", ((0.0, math.inf),), {}),
        ("vehicle", "set_velocity", (0.1, math.nan), {}),
        ("turtlebot0", "drive_to", (np.array([math.nan, 1.0]),), {}),
        ("fetch", "set_arm_targets", (np.array([0.0, math.nan, 0.0, 0.0, 0.0]),), {}),
        ("fetch", "ik", ((1.0, math.nan, 0.8),), {}),
    ],
)
def test_non_finite_set_points_raise_naming_robot_and_command(robots, robot, command, args, kwargs):
    adapter = robots[robot]
    with pytest.raises(ValueError, match=rf"robot '{robot}' .*{command}\(.*(nan|inf)"):
        getattr(adapter, command)(*args, **kwargs)


def test_the_drone_keeps_its_target_after_a_refused_nan(robots):
    drone = robots["drone"]
    before = drone._target
    with pytest.raises(ValueError):
        drone.fly_to((math.nan, math.nan, math.nan))
    assert drone._target == before
