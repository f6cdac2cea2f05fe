"""One grid cell's training in a process of its own (``python -m maopg.experiment.studies.cell``).

The grid (:mod:`maopg.experiment.studies.grid`) writes the cell's config (as a run directory's
``config.json`` holds it) and whether it resumes to this process's standard input, as JSON:
``{"config": {...}, "resume": false}``. The process imports the config's plugins, rebuilds the
config and calls the training function; a user error ends it with one line and exit status 2,
as the train command line does. The cell's lock comes from the grid
(:func:`maopg.experiment.run.lock.child_environment`).
"""

from __future__ import annotations

import json
import sys

from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.errors import reporting_user_errors
from maopg.plugins import load_plugins

PROG = "maopg.experiment.studies.cell"


def _train_cell() -> int:
    from maopg.experiment.training.trainer import train

    request = json.loads(sys.stdin.read())
    load_plugins(request["config"].get("plugins", []))
    train(TrainConfig.from_dict(request["config"]), resume=bool(request["resume"]))
    return 0


if __name__ == "__main__":
    sys.exit(reporting_user_errors(PROG, _train_cell))
