"""What can stop a learner, as a user's error rather than a bug: a run whose numbers went
non-finite, a checkpoint that cannot be read. In a module without torch, so that the command
lines that report them (:mod:`maopg.experiment.run.errors`) load none before they need it."""

from __future__ import annotations


class NonFiniteError(FloatingPointError):
    """A loss, gradient or parameter became NaN or infinite: training from there would only
    spread it through every weight (and be checkpointed), so the learner stops at once."""


class CheckpointError(RuntimeError):
    """A checkpoint file is missing, truncated, corrupt, or not one of ours."""
