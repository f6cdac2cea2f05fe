"""Option policies, encoders and the centralized critic for the option-level learners."""

from maopg.policy.batch import ObsBatch, stack_conditions, vector_slices
from maopg.policy.conditional import (
    ConditionalJoint,
    FactoredConditional,
    JointOptionDistribution,
    conditional_log_probs,
    joint_slice_mask,
    partial_conditional_log_probs,
    ravel_joint,
    unravel_joint,
)
from maopg.policy.encoders import JointEncoder, LocalEncoder, NatureCNN, init_orthogonal
from maopg.policy.networks import (
    CentralCritic,
    CentralizedPolicy,
    OptionPolicy,
    PartiallyCentralizedPolicy,
    build_policy,
)

__all__ = [
    "CentralCritic",
    "CentralizedPolicy",
    "ConditionalJoint",
    "FactoredConditional",
    "JointEncoder",
    "JointOptionDistribution",
    "LocalEncoder",
    "NatureCNN",
    "ObsBatch",
    "OptionPolicy",
    "PartiallyCentralizedPolicy",
    "build_policy",
    "conditional_log_probs",
    "init_orthogonal",
    "joint_slice_mask",
    "partial_conditional_log_probs",
    "ravel_joint",
    "stack_conditions",
    "unravel_joint",
    "vector_slices",
]
