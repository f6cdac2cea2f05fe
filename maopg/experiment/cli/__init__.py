"""The two command lines, ``python -m train`` and ``python -m eval`` (``maopg-train`` and
``maopg-eval`` once installed).

- :mod:`.command_line` — what both share: plugins first, user errors as one line;
- :mod:`.train_cli` — ``train``: a run from flags, ``key=value`` settings and a config file;
- :mod:`.eval_cli` — ``eval``: evaluate, video, timeline, plot, table, check-robot, reproduce.
"""
