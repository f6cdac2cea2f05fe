"""Using a trained policy: loading it, acting with it, evaluating it.

- :mod:`.loading` — a run directory or checkpoint back to its config, environment and actor;
- :mod:`.inference` — :func:`~.inference.load_policy`, acting from Python or PettingZoo;
- :mod:`.evaluate` — episodes of a trained or reference policy, and the evaluation during
  training (its schedule and seeds);
- :mod:`.timeline` — an episode's options per agent as a figure (``python -m eval timeline``).
"""
