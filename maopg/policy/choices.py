"""The names the policies' settings choose between, without torch: the config sections that
offer them (``ppo.explore_form``, the run's ``precision``) are read by the command line's
``--help`` and validated before anything loads torch."""

from __future__ import annotations

EXPLORE_FORMS = ("agent", "joint")
"""How exploration mixes the uniform in: per choosing agent's factor, or over the joint."""

PRECISION_NAMES = ("fp32", "bf16")
"""The ``precision`` setting's values: what the CNNs compute in
(:data:`maopg.policy.encoders.PRECISIONS` maps them to dtypes)."""
