"""The training loop and what watches it.

- :mod:`.trainer` — :func:`~.trainer.train`: collect, update, log, checkpoint, evaluate, resume;
- :mod:`.watch` — the progress bar and stall watch fed by the environments' steps;
- :mod:`.eta` — how long a run (and the steps after it) will take, from measured rates.
"""
