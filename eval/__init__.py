"""Evaluation of trained option policies: seeded evaluation, rollout videos, learning curves,
result tables and the resumable reproduction grid (``python -m eval --help``)."""
