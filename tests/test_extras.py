"""How to install an optional extra, said as it works from here: this clone's own extra. (An
installed wheel's hint, ``pip install 'maopg[wandb]'``, is checked by tests/test_wheel.py.)"""

from __future__ import annotations

from pathlib import Path

from maopg.experiment.cli.train_cli import main
from maopg.extras import clone_root, install_hint

REPO = Path(__file__).resolve().parents[1]


def test_from_a_clone_the_hint_installs_the_clones_own_extra() -> None:
    assert clone_root() == REPO
    assert install_hint("ray") == f"pip install -e '.[ray]' (in {REPO}, the clone maopg runs from)"


def test_logger_wandb_without_wandb_says_how_to_install_it(tmp_path, user_error, monkeypatch):
    monkeypatch.setattr("maopg.experiment.run.config.wandb_available", lambda: False)
    run = tmp_path / "run"
    args = ["--total-samples", "100", "--run-dir", str(run), "logger=wandb"]
    user_error(
        main, args, r"logger=wandb needs the wandb package: pip install -e '\.\[wandb\]' \(in /"
    )
    assert not run.exists()
