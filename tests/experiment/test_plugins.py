"""A user's own task, from the command line to the video: ``--import``, ``MAOPG_PLUGINS`` and the
entry-point groups, through training, spawned workers, ``--resume`` and evaluation, each in a
fresh process as a user would run it. The task is ``examples/berries.py`` (no MuJoCo scene)."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import pytest

from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.plugins import ENV_VAR

REPO = Path(__file__).resolve().parents[2]
QUICK = ["progress=false", "plot=false", "batch_ticks=200", "num_envs=2", "ppo.epochs=2"]


def _run(
    *args: str, env: dict[str, str] | None = None, cwd: Path = REPO
) -> subprocess.CompletedProcess:
    """``python -m ARGS`` in a fresh interpreter (without the parent's plugins)."""
    base = {k: v for k, v in os.environ.items() if k != ENV_VAR}
    return subprocess.run(
        [sys.executable, "-m", *args],
        cwd=cwd,
        env={**base, **(env or {})},
        capture_output=True,
        text=True,
        check=False,
    )


@pytest.fixture(autouse=True)
def _no_leaking_plugins(monkeypatch):
    """Plugins imported in this process register into the registries, are remembered as loaded
    and record themselves in the environment: each test gets private copies of all of it."""
    from maopg import plugins
    from maopg.sim import robots
    from maopg.tasks import registry

    monkeypatch.setenv(ENV_VAR, "")
    monkeypatch.setattr(plugins, "_LOADED", set())
    monkeypatch.setattr(registry, "_TASKS", dict(registry._TASKS))
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    for name in [m for m in sys.modules if m.startswith("examples.robots")]:
        monkeypatch.delitem(sys.modules, name)


def test_a_users_task_trains_in_workers_resumes_evaluates_and_films(tmp_path):
    run = tmp_path / "run"
    common = ["--task", "berries", "--run-dir", str(run), *QUICK]
    unknown = _run("train", *common, "--total-samples", "400")
    assert unknown.returncode == 2 and "invalid choice: 'berries'" in unknown.stderr

    # spawned workers import the plugin too (they would fail with "unknown task" otherwise)
    args = ["--import", "examples.berries", *common, "backend=processes", "num_workers=2"]
    trained = _run("train", *args, "--total-samples", "400")
    assert trained.returncode == 0, trained.stderr
    assert json.loads((run / "config.json").read_text())["plugins"] == ["examples.berries"]
    assert (run / "done.json").exists()  # the video (default video=true) did not crash
    reader = imageio.get_reader(run / "rollout.mp4")
    try:
        frames = list(reader.iter_data())
    finally:
        reader.close()
    assert len(frames) == 241 and frames[0].std() > 0  # the reset frame, 4 for each of 60 ticks

    # the saved plugins are imported before the parser checks --task's choices
    resume = ["--resume", "--run-dir", str(run), "--task", "berries", "--total-samples", "800"]
    resumed = _run("train", *resume)
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((run / "done.json").read_text())["samples"] >= 800

    evaluated = _run("eval", "evaluate", "--checkpoint", str(run), "--episodes", "2")
    assert evaluated.returncode == 0, evaluated.stderr
    assert "| async seed0 @" in evaluated.stdout and "| berries |" in evaluated.stdout
    video = tmp_path / "v.mp4"
    filmed = _run("eval", "video", "--checkpoint", str(run), "--out", str(video), "--sample")
    assert filmed.returncode == 0 and video.stat().st_size > 0, filmed.stderr


def test_the_environment_variable_and_a_file_path_work_like_import(tmp_path):
    scripted = ["eval", "evaluate", "--reference", "scripted", "--task", "berries"]
    by_env = _run(*scripted, "--episodes", "2", env={ENV_VAR: "examples.berries"})
    assert by_env.returncode == 0 and "| scripted | berries |" in by_env.stdout, by_env.stderr
    # from elsewhere (no clone on the path): the installed command line and a file, which
    # spawned workers import too (by its absolute path) before they unpickle its classes
    installed = ["maopg.experiment.cli.eval_cli", *scripted[1:]]
    plugin = ["--import", "../examples/berries.py"]
    elsewhere = tmp_path / "elsewhere"
    (tmp_path / "examples").mkdir()
    (tmp_path / "examples" / "berries.py").write_text(
        (REPO / "examples" / "berries.py").read_text()
    )
    elsewhere.mkdir()
    by_file = _run(*installed, *plugin, cwd=elsewhere)
    assert by_file.returncode == 0, by_file.stderr
    run = tmp_path / "run"
    train = [
        "maopg.experiment.cli.train_cli",
        *plugin,
        "--task",
        "berries",
        *QUICK,
        "video=false",
        "eval_episodes=0",
    ]
    train += ["backend=processes", "num_workers=2", "--total-samples", "400", "--run-dir", str(run)]
    trained = _run(*train, cwd=elsewhere)
    assert trained.returncode == 0, trained.stderr
    resume = ["maopg.experiment.cli.train_cli", "--resume", "--run-dir", str(run)]
    assert _run(*resume, "--total-samples", "800", cwd=REPO).returncode == 0  # another cwd


def test_a_plugin_file_imports_the_modules_beside_it_in_every_process(tmp_path, monkeypatch):
    """``--import plug/task.py`` whose task is in a module beside it: the training (here), then
    its ``--resume`` and the evaluation of its checkpoint (each a fresh process, in another
    folder than the plugin's) import that module; the evaluation's JSON says what produced the
    result: the task and its settings, the method and checkpoint, the plugin's file and hash."""
    from maopg.experiment.cli.train_cli import main as train_main

    plug = tmp_path / "plug"
    plug.mkdir()
    (plug / "field.py").write_text("from examples.berries import BerryConfig, BerryField\n")
    plugin = plug / "task.py"
    plugin.write_text(
        "from field import BerryConfig, BerryField\n"
        "from maopg.tasks import register_task\n"
        "register_task('field', BerryField, config=BerryConfig)\n"
    )
    monkeypatch.setattr(sys, "path", list(sys.path))  # the plugin's folder goes on it
    monkeypatch.chdir(tmp_path)
    run = tmp_path / "run"
    args = ["--import", "plug/task.py", "--task", "field", "--run-dir", str(run), *QUICK]
    args += ["env.ripen_prob=0.05", "video=false", "eval_episodes=0", "--total-samples", "200"]
    assert train_main(args) == 0
    resume = ["--resume", "--run-dir", str(run), "--total-samples", "400"]
    resumed = _run("train", *resume)
    assert resumed.returncode == 0, resumed.stderr
    out = tmp_path / "result.json"
    evaluate = ["--checkpoint", str(run), "--episodes", "1", "--json", str(out)]
    evaluated = _run("eval", "evaluate", *evaluate)
    assert evaluated.returncode == 0, evaluated.stderr

    source = json.loads(out.read_text())["source"]
    assert (source["task"], source["strategy"]) == ("field", "continue")
    assert source["env"]["ripen_prob"] == 0.05 and source["env"]["images"] is False
    samples = json.loads((run / "done.json").read_text())["samples"]
    assert source["policy"] == {
        "method": "async",
        "seed": 0,
        "checkpoint": str((run / "final.pt").resolve()),
        "samples": samples,
        "greedy": True,
    }
    digest = hashlib.sha256(plugin.read_bytes()).hexdigest()
    path = str(plugin.resolve())
    record = {"plugin": path, "path": path, "sha256": digest}
    assert record in source["plugins"]


def test_an_installed_packages_entry_point_registers_its_task(tmp_path):
    """A distribution on the path whose ``entry_points.txt`` names a module in ``maopg.tasks``."""
    site = tmp_path / "site"
    (site / "mypicker").mkdir(parents=True)
    (site / "mypicker" / "__init__.py").write_text(
        "from examples.berries import BerryConfig, BerryField\n"
        "from maopg.tasks import register_task\n"
        "register_task('my_berries', BerryField, config=BerryConfig)\n"
    )
    info = site / "mypicker-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: mypicker\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[maopg.tasks]\nmy_berries = mypicker\n")
    helped = _run("train", "--help", env={"PYTHONPATH": f"{site}{os.pathsep}{REPO}"})
    assert helped.returncode == 0 and "my_berries" in helped.stdout, helped.stderr


def test_user_errors_are_one_line(user_error, monkeypatch):
    """An unknown robot in a task setting, a task with no scripted policy, a plugin that does not
    import: one line each, no traceback."""
    from examples.berries import BerryConfig, BerryField
    from maopg.tasks import registry

    registry.register_task("plain_berries", BerryField, config=BerryConfig)
    reference = ["evaluate", "--episodes", "1", "--reference"]
    bad_robot = [*reference, "random", "--task", "water_filling", "env.drone_robot=nope"]
    user_error(eval_main, bad_robot, "unknown robot 'nope'")
    user_error(eval_main, ["--import", "no_such_module", "plot", "runs"], "no_such_module")
    no_script = [*reference, "scripted", "--task", "plain_berries"]
    user_error(eval_main, no_script, "task 'plain_berries' has no scripted policy")


def test_check_robot_runs_a_users_robot_through_the_eval_command_line(capsys):
    """``examples/robots``: a holonomic base with position actuators, imported as a plugin."""
    argv = ["--import", "examples.robots.user_robots", "check-robot", "--robot", "holonomic_base"]
    assert eval_main([*argv, "--role", "ground"]) == 0
    assert "all checks passed" in capsys.readouterr().out
    assert eval_main([*argv, "--role", "drone"]) == 1  # a base cannot fly
    assert "FAIL" in capsys.readouterr().out
    swap = ["--import", "examples.robots.user_robots", "evaluate", "--reference", "random"]
    swap += ["--task", "water_filling", "env.drone_robot=quadrotor", "env.max_ticks=20"]
    assert eval_main([*swap, "--episodes", "1"]) == 0
    assert "| random | water_filling |" in capsys.readouterr().out


def test_a_registration_made_in_the_parent_reaches_spawned_workers(monkeypatch, tmp_path):
    """No plugin module: ``register_task`` called here, then ``backend=processes``."""
    from examples.berries import BerryConfig, BerryField
    from maopg.experiment.cli.train_cli import main as train_main
    from maopg.tasks import registry

    registry.register_task("inline_berries", BerryField, config=BerryConfig)
    args = ["--task", "inline_berries", *QUICK, "backend=processes", "num_workers=2"]
    run = tmp_path / "run"
    assert (
        train_main(
            [
                *args,
                "video=false",
                "eval_episodes=0",
                "--total-samples",
                "400",
                "--run-dir",
                str(run),
            ]
        )
        == 0
    )
    assert (run / "done.json").exists()
