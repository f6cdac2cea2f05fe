"""``python -m train`` from a clone: the command line lives in :mod:`maopg.experiment.cli.train_cli`
(installed as ``maopg-train``)."""

import sys

from maopg.experiment.cli.train_cli import main

sys.exit(main())
