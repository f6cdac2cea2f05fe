"""What a training run is, and what it leaves on disk.

- :mod:`.config` — :class:`~.config.TrainConfig`: the task, the method and every setting, validated
  before anything is written;
- :mod:`.config_file` and :mod:`.migration` — reading a ``config.json`` or a YAML settings file,
  and bringing files and checkpoints of earlier releases to the current schema in one step;
- :mod:`.methods` — the method registry (a method's strategy, policy builder and learner);
- :mod:`.directory` — the run directory's files: config, metrics, checkpoints, ``done.json``;
- :mod:`.lock` — one process at a time in a run directory;
- :mod:`.wandb_log`, :mod:`.tb_video` — the optional loggers beside ``metrics.csv``;
- :mod:`.settings_reference` — every setting's kind, default, bounds and meaning, for ``--help``
  and the documentation's reference page;
- :mod:`.sysinfo` — the machine a run or benchmark ran on;
- :mod:`.errors` — what counts as a user's mistake (one line, never a traceback).

The package imports nothing on its own: the command lines import it before they may import
MuJoCo.
"""
