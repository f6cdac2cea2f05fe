"""``python -m eval`` from a clone: the command line lives in :mod:`maopg.experiment.cli.eval_cli`
(installed as ``maopg-eval``)."""

import sys

from maopg.experiment.cli.eval_cli import main

sys.exit(main())
