"""Option policies (feed-forward or recurrent), the centralized critic, Mac-DQN's joint Q-network,
and their actors."""

from maopg.policy.actors import DistributionActor, QActor, episode_starts
from maopg.policy.autoregressive import (
    AutoregressiveConditional,
    AutoregressivePolicy,
    PartialFactoredPolicy,
)
from maopg.policy.batch import ObsBatch, stack_conditions, vector_slices
from maopg.policy.conditional import (
    ConditionalJoint,
    FactoredConditional,
    JointOptionDistribution,
    conditional_argmax,
    conditional_log_probs,
    draw_multinomial,
    epsilon_greedy,
    joint_slice_mask,
    partial_conditional_log_probs,
    ravel_joint,
    unravel_joint,
)
from maopg.policy.encoders import (
    PRECISIONS,
    JointEncoder,
    LocalEncoder,
    NatureCNN,
    init_orthogonal,
    set_precision,
)
from maopg.policy.memory import FEED_FORWARD, MemoryDesign, OptionMemory
from maopg.policy.networks import (
    CentralCritic,
    CentralizedPolicy,
    EncodedPolicy,
    JointQNetwork,
    OptionPolicy,
    PartiallyCentralizedPolicy,
)

__all__ = [
    "FEED_FORWARD",
    "PRECISIONS",
    "AutoregressiveConditional",
    "AutoregressivePolicy",
    "CentralCritic",
    "CentralizedPolicy",
    "ConditionalJoint",
    "DistributionActor",
    "EncodedPolicy",
    "FactoredConditional",
    "JointEncoder",
    "JointOptionDistribution",
    "JointQNetwork",
    "LocalEncoder",
    "MemoryDesign",
    "NatureCNN",
    "ObsBatch",
    "OptionMemory",
    "OptionPolicy",
    "PartialFactoredPolicy",
    "PartiallyCentralizedPolicy",
    "QActor",
    "conditional_argmax",
    "conditional_log_probs",
    "draw_multinomial",
    "episode_starts",
    "epsilon_greedy",
    "init_orthogonal",
    "joint_slice_mask",
    "partial_conditional_log_probs",
    "ravel_joint",
    "set_precision",
    "stack_conditions",
    "unravel_joint",
    "vector_slices",
]
