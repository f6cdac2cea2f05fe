"""An existing PettingZoo environment trained with this project: MPE's Simple Spread (three
agents cover three landmarks; ``pip install mpe2``), registered as the task ``spread``::

    python -m train --import examples.pettingzoo_spread --task spread --method async

Its five discrete moves become one-tick options (:mod:`maopg.tasks.pettingzoo_task`); the team's
reward is the agents' mean.
"""

from maopg.tasks.pettingzoo_task import register_pettingzoo

register_pettingzoo(
    "spread",
    "mpe2.simple_spread_v3:parallel_env",
    env_kwargs={"N": 3, "max_cycles": 25, "continuous_actions": False},
    max_ticks=25,
    train_defaults={"batch_ticks": 1000, "total_samples": 50_000, "images": False},
)
