"""``logger=wandb``: the run's TensorBoard record mirrored to Weights & Biases.

W&B is an optional extra (``maopg[wandb]``; :func:`maopg.extras.install_hint` says how to
install it): nothing imports it unless a run asks for it, and TensorBoard and ``metrics.csv``
are written as always, so a W&B run is a view of the run, never its only record.

A run directory keeps one W&B run: its id and the last step sent are in ``wandb.json``, and a
resumed run continues the same W&B run (``resume="allow"``). W&B cannot delete rows, so
``RunLog``'s rule of cutting a resumed record back to its checkpoint does not carry over;
instead a resumed run sends no step at or below the last one sent. That loses nothing: training
is deterministic, so the rows recomputed between the checkpoint and the kill equal the rows W&B
already holds. Offline (``wandb.mode=offline``, or ``WANDB_MODE=offline``) each start writes a
directory of its own under ``RUN_DIR/wandb/``, and ``wandb sync`` uploads them in order into the
one run.

Steps are sample counts, as in TensorBoard. A row's ``train/*`` columns, its evaluation's
``eval/*`` (``eval_every``) and the ``options/*`` shares of the same iteration go out as one
W&B step.
"""

from __future__ import annotations

import importlib.util
import json
import os
import secrets
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

from maopg.extras import install_hint
from maopg.settings import Settings, setting

STATE = "wandb.json"
"""The run directory's record of its W&B run: ``{"id", "logged", "final"}``."""


def missing_wandb() -> str:
    """The error of ``logger=wandb`` without wandb: how to install it (:func:`install_hint`)."""
    return f"logger=wandb needs the wandb package: {install_hint('wandb')}"


def wandb_available() -> bool:
    return importlib.util.find_spec("wandb") is not None


@dataclass(frozen=True)
class WandbOptions(Settings):
    """The ``wandb.*`` settings of a run: where its record goes, not what it computes (a
    resumed run may change them). Read only with ``logger=wandb``."""

    PREFIX: ClassVar[str] = "wandb."

    project: str = "maopg"
    """The W&B project the run is logged to."""
    entity: str | None = None
    """The W&B team or user (``None``: the logged-in user's default)."""
    group: str | None = None
    """Groups runs in the W&B interface (e.g. the seeds of one setting)."""
    mode: str | None = setting(None, choices=("online", "offline"))
    """``None``: W&B's own choice (``WANDB_MODE``, else ``online``); ``offline`` writes the run
    under ``RUN_DIR/wandb/`` for a later ``wandb sync``."""


class WandbMirror:
    """Sends a run's scalars, settings, final evaluation and video to one W&B run."""

    def __init__(
        self, run_dir: Path, options: WandbOptions, *, name: str, config: dict[str, Any]
    ) -> None:
        import wandb

        self._path = run_dir / STATE
        record = json.loads(self._path.read_text()) if self._path.exists() else {}
        self._id = record.get("id") or secrets.token_hex(4)
        self._logged = int(record.get("logged", -1))
        self._final = bool(record.get("final", False))
        self._pending: dict[str, float] = {}
        self._step = -1
        try:
            self._run = wandb.init(
                id=self._id,
                resume="allow",
                project=options.project,
                entity=options.entity,
                group=options.group,
                name=name,
                mode=options.mode,
                dir=str(run_dir),
                config=config,
                settings=wandb.Settings(console="off", silent=True),
            )
        except wandb.errors.Error as err:  # no login, no network, a project it may not write
            raise ValueError(
                f"logger=wandb: {err} (wandb.mode=offline logs without an account)"
            ) from None
        self._save()

    def log(self, step: int, values: dict[str, float]) -> None:
        """Add ``values`` at ``step`` (sent when a later step arrives, or at :meth:`flush`);
        a step this W&B run already holds is skipped (module docstring)."""
        if step <= self._logged:
            return
        if step != self._step:
            self._send()
            self._step = step
        self._pending.update(values)

    def flush(self) -> None:
        self._send()

    def final(self, summary: dict[str, float], video: Path | None) -> None:
        """The final evaluation (the run's W&B summary) and the rollout video, once per run: a
        resumed run that repeats its after-training steps does not send them twice. The video
        goes with the last row's step, or W&B's current one if later: a resumed online run
        refuses older steps."""
        if self._final or not (summary or video):
            return
        import wandb

        self.flush()
        self._run.summary.update(summary)
        if video is not None:
            step = max(self._logged, self._run.step)
            self._run.log({"rollout": wandb.Video(str(video), format="mp4")}, step=step)
        self._final = True
        self._save()

    def close(self, failed: bool = False) -> None:
        if not failed:
            self.flush()
        self._run.finish(exit_code=1 if failed else 0)

    def _send(self) -> None:
        if not self._pending:
            return
        self._run.log(self._pending, step=self._step)
        self._pending = {}
        self._logged = self._step
        self._save()

    def _save(self) -> None:
        record = {"id": self._id, "logged": self._logged, "final": self._final}
        tmp = self._path.with_name(f".{STATE}.tmp")
        tmp.write_text(json.dumps(record) + "\n")
        os.replace(tmp, self._path)
