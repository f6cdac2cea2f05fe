"""MAPPO over option-level trajectories: rollout storage, GAE, value normalisation, the PPO
update, rollout sampling (serial or ``spawn`` workers) and atomic checkpoints."""

from maopg.learner.buffer import Rollout, TrainBatch
from maopg.learner.checkpoint import (
    CheckpointError,
    capture_global_rng,
    load_checkpoint,
    restore_global_rng,
    save_checkpoint,
)
from maopg.learner.gae import DiscountForm, compute_gae
from maopg.learner.mappo import MAPPO, PPOConfig
from maopg.learner.sampler import EnvConfig, Sampler, StepResult, episode_seed
from maopg.learner.value_norm import ValueNorm

__all__ = [
    "MAPPO",
    "CheckpointError",
    "DiscountForm",
    "EnvConfig",
    "PPOConfig",
    "Rollout",
    "Sampler",
    "StepResult",
    "TrainBatch",
    "ValueNorm",
    "capture_global_rng",
    "compute_gae",
    "episode_seed",
    "load_checkpoint",
    "restore_global_rng",
    "save_checkpoint",
]
