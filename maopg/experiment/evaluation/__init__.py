"""Using a trained policy: loading it, acting with it, evaluating it.

- :mod:`.loading` — a run directory or checkpoint back to its config, environment and actor;
- :mod:`.inference` — :func:`~.inference.load_policy`, acting from Python or PettingZoo;
- :mod:`.evaluate` — episodes of a trained or reference policy, and the evaluation during
  training (its schedule and seeds);
- :mod:`.timeline` — an episode's options per agent as a figure (``python -m eval timeline``).
"""

GREEDY_BY_DEFAULT = True
"""How a trained policy acts unless told otherwise — in :func:`~.inference.load_policy`,
:meth:`~.loading.Trained.actor`, ``python -m eval evaluate`` and ``python -m eval video``
(``--greedy`` / ``--sample`` choose): greedily, each agent taking its most probable option
(Mac-DQN: ε 0). That is what "the policy" means where users come from: Stable-Baselines3's
``evaluate_policy`` and BenchMARL (``evaluation_deterministic_actions: True``) evaluate the
deterministic policy by default; it is also reproducible, one greedy episode of a deterministic
task being every episode. ``scripts/run.sh`` trains long enough that its Tool Delivery policy
succeeds greedy as well as sampled. Sampling (``--sample``, ``greedy=False``) acts as training
did; it is what to use where the greedy policy loops: on Water Filling without memory
(results/README.md, Water Filling finding 6). What a run records while and after it trains has
settings of its own: its video samples (``video_sample``), its evaluation during training
samples (``eval_during_sample``), and its final evaluation does both."""
