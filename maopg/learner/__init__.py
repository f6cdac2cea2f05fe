"""The learners: MAPPO over option-level trajectories (rollout storage, GAE, value
normalisation, the PPO update), the Mac-DQN baseline (squeezed replay, conditional double-Q)
and ACAC (agent-centric actors and an attention critic over whole episodes), each with its own
collection loop behind :class:`Learner`, and atomic checkpoints.

The names below are imported on first use (:mod:`maopg.exports`): the config sections
(:mod:`.sections`) and the errors (:mod:`.errors`) load without torch."""

from maopg.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(
    __name__,
    (
        "maopg.learner.acac:ACACLearner",
        "maopg.learner.adam:Adam",
        "maopg.learner.base:SHARED_COLUMNS",
        "maopg.learner.base:Actor",
        "maopg.learner.base:Learner",
        "maopg.learner.base:LearnerSetup",
        "maopg.learner.buffer:Rollout",
        "maopg.learner.buffer:TrainBatch",
        "maopg.learner.checkpoint:capture_global_rng",
        "maopg.learner.checkpoint:fitting",
        "maopg.learner.checkpoint:load_checkpoint",
        "maopg.learner.checkpoint:remove_stale_temporaries",
        "maopg.learner.checkpoint:restore_global_rng",
        "maopg.learner.checkpoint:save_checkpoint",
        "maopg.learner.errors:CheckpointError",
        "maopg.learner.errors:NonFiniteError",
        "maopg.learner.sections:DiscountForm",
        "maopg.learner.gae:compute_gae",
        "maopg.learner.macdqn:MacDQN",
        "maopg.learner.macdqn:MacDQNLearner",
        "maopg.learner.mappo:MAPPO",
        "maopg.learner.mappo:MAPPOLearner",
        "maopg.learner.replay:SqueezedReplay",
        "maopg.learner.sections:ACACConfig",
        "maopg.learner.sections:MacDQNConfig",
        "maopg.learner.sections:PPOConfig",
        "maopg.learner.value_norm:ValueNorm",
    ),
)
