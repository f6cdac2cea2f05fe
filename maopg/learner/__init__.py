"""The learners: MAPPO over option-level trajectories (rollout storage, GAE, value
normalisation, the PPO update) and the Mac-DQN baseline, on one rollout sampler (serial or
``spawn`` workers), with atomic checkpoints."""

from maopg.learner.buffer import Rollout, TrainBatch
from maopg.learner.checkpoint import (
    CheckpointError,
    capture_global_rng,
    load_checkpoint,
    restore_global_rng,
    save_checkpoint,
)
from maopg.learner.gae import DiscountForm, compute_gae
from maopg.learner.macdqn import JointQNetwork, MacDQN, MacDQNConfig, SqueezedReplay
from maopg.learner.mappo import MAPPO, PPOConfig
from maopg.learner.sampler import EnvConfig, Sampler, StepResult, episode_seed
from maopg.learner.value_norm import ValueNorm

__all__ = [
    "MAPPO",
    "CheckpointError",
    "DiscountForm",
    "EnvConfig",
    "JointQNetwork",
    "MacDQN",
    "MacDQNConfig",
    "PPOConfig",
    "Rollout",
    "Sampler",
    "SqueezedReplay",
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
