"""Generalised advantage estimation over decision points (option steps).

A rollout is a ``[S, E]`` grid: ``S`` option steps of ``E`` environments stepped in lockstep.
Option step ``t`` of an environment starts at decision point ``z_t``; it lasts ``k_t`` ticks and
collects the rewards ``r_{t,0..k_t-1}`` reported at the next decision point.

Two discount forms are supported (docs/DESIGN.md §5):

``smdp`` (default)
    The semi-Markov form: discount by the time that actually passed,
    ``δ_t = R^γ_t + γ^{k_t} V(z_{t+1}) − V(z_t)`` and ``A_t = δ_t + (γλ)^{k_t} A_{t+1}`` with
    ``R^γ_t = Σ_j γ^j r_{t,j}``. It estimates the same tick-level return whatever the options'
    durations are, so the methods (and ``end2end``, whose options last one tick) optimise one
    objective and their values are comparable.
``event``
    ACAC's asynchronous form (Jung et al. 2025): the semi-Markov ``δ_t``, with the trace decayed
    by ``γ^{k_t} λ`` — λ once per decision event, however many ticks it lasted.
``option``
    The paper's form: treat an option step as one step, ``δ_t = R_t + γ V(z_{t+1}) − V(z_t)`` and
    ``A_t = δ_t + γλ A_{t+1}`` with the summed reward ``R_t = Σ_j r_{t,j}``. With unequal
    durations it weighs a long option's future like a short one's, which biases the policy
    towards long options; it exists to reproduce the paper.

Episode ends and batch cuts (``next_values`` is always ``V(z_{t+1})``, the value of the point the
step ended at):

- terminated: bootstrap with 0 (``terminated[t]``), and stop the recursion;
- truncated: bootstrap from ``V`` of the truncated point, and stop the recursion;
- cut by the end of the batch mid-episode: bootstrap from ``V`` of the next point; the
  recursion stops because there is no ``A_{t+1}`` in this batch.

So the recursion continues only where ``continues[t]`` (the next row of the grid is the next
option step of the same episode); the caller sets it to ``False`` on the last row.
"""

from __future__ import annotations

import numpy as np

from maopg.learner.sections import DiscountForm


def compute_gae(
    *,
    values: np.ndarray,
    next_values: np.ndarray,
    reward_sum: np.ndarray,
    reward_discounted: np.ndarray,
    durations: np.ndarray,
    terminated: np.ndarray,
    continues: np.ndarray,
    gamma: float,
    lam: float,
    form: DiscountForm | str = DiscountForm.SMDP,
) -> tuple[np.ndarray, np.ndarray]:
    """Advantages and value targets (``A_t + V(z_t)``) of a ``[S, E]`` rollout grid.

    All arrays are ``[S, E]`` (or ``[S]``); values are in return units (denormalised).
    Returns float64 arrays of the same shape.
    """
    form = DiscountForm(form)
    values = np.asarray(values, dtype=np.float64)
    next_values = np.asarray(next_values, dtype=np.float64)
    durations = np.asarray(durations, dtype=np.float64)
    if np.any(durations < 1):
        raise ValueError("every option step must last at least one tick")
    if form is DiscountForm.SMDP:
        rewards = np.asarray(reward_discounted, dtype=np.float64)
        discount = gamma**durations
        trace = (gamma * lam) ** durations
    elif form is DiscountForm.EVENT:
        rewards = np.asarray(reward_discounted, dtype=np.float64)
        discount = gamma**durations
        trace = discount * lam
    else:
        rewards = np.asarray(reward_sum, dtype=np.float64)
        discount = np.full_like(values, gamma)
        trace = np.full_like(values, gamma * lam)
    bootstrap = np.where(np.asarray(terminated, dtype=bool), 0.0, next_values)
    deltas = rewards + discount * bootstrap - values
    keep = np.asarray(continues, dtype=np.float64)

    advantages = np.zeros_like(values)
    following = np.zeros_like(values[0])
    for t in range(values.shape[0] - 1, -1, -1):
        following = deltas[t] + trace[t] * keep[t] * following
        advantages[t] = following
    return advantages, advantages + values
