"""The learners: MAPPO over option-level trajectories (rollout storage, GAE, value
normalisation, the PPO update), the Mac-DQN baseline (squeezed replay, conditional double-Q)
and ACAC (agent-centric actors and an attention critic over whole episodes), each with its own
collection loop behind :class:`Learner`, and atomic checkpoints."""

from maopg.learner.acac import ACACConfig, ACACLearner
from maopg.learner.adam import Adam
from maopg.learner.base import SHARED_COLUMNS, Actor, Learner, LearnerSetup, NonFiniteError
from maopg.learner.buffer import Rollout, TrainBatch
from maopg.learner.checkpoint import (
    CheckpointError,
    capture_global_rng,
    fitting,
    load_checkpoint,
    remove_stale_temporaries,
    restore_global_rng,
    save_checkpoint,
)
from maopg.learner.gae import DiscountForm, compute_gae
from maopg.learner.macdqn import MacDQN, MacDQNConfig, MacDQNLearner
from maopg.learner.mappo import MAPPO, MAPPOLearner, PPOConfig
from maopg.learner.replay import SqueezedReplay
from maopg.learner.value_norm import ValueNorm

__all__ = [
    "MAPPO",
    "SHARED_COLUMNS",
    "ACACConfig",
    "ACACLearner",
    "Actor",
    "Adam",
    "CheckpointError",
    "DiscountForm",
    "Learner",
    "LearnerSetup",
    "MAPPOLearner",
    "MacDQN",
    "MacDQNConfig",
    "MacDQNLearner",
    "NonFiniteError",
    "PPOConfig",
    "Rollout",
    "SqueezedReplay",
    "TrainBatch",
    "ValueNorm",
    "capture_global_rng",
    "compute_gae",
    "fitting",
    "load_checkpoint",
    "remove_stale_temporaries",
    "restore_global_rng",
    "save_checkpoint",
]
