"""Experiments: the training config, the method registry, the run directory, the training loop,
loading a trained policy, and the evaluation and reproduction tools behind ``python -m train``
and ``python -m eval`` (``maopg-train`` / ``maopg-eval`` once installed)."""
