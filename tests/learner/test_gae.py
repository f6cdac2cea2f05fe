"""GAE over option steps, both discount forms, against numbers worked out by hand.

γ = λ = 0.5 keep the arithmetic exact in binary floating point. Two environments, three rows:

env 0 (one episode that terminates):
  row 0: k=2, rewards [1, 2]    R=3   R^γ = 1 + .5·2        = 2    V=1, V(next)=2
  row 1: k=1, rewards [4]       R=4   R^γ = 4                      V=2, V(next)=4
  row 2: k=3, rewards [8, 0, 4] R=12  R^γ = 8 + 0 + .25·4   = 9    V=4, terminated
env 1 (a truncated episode, then a new one cut by the end of the batch):
  row 0: k=1, rewards [-1]      R=-1  R^γ = -1                     V=0, truncated, V(final)=10
  row 1: k=2, rewards [-1, -1]  R=-2  R^γ = -1 + .5·(-1)    = -1.5 V=3, V(next)=6
  row 2: k=1, rewards [4]       R=4   R^γ = 4                      V=6, batch cut, V(next)=8

SMDP, δ = R^γ + γ^k V' − V, A = δ + (γλ)^k A':
  env 0: δ2 = 9 − 4 = 5;            A2 = 5
         δ1 = 4 + .5·4 − 2 = 4;     A1 = 4 + .25·5 = 5.25
         δ0 = 2 + .25·2 − 1 = 1.5;  A0 = 1.5 + .0625·5.25 = 1.828125
  env 1: δ2 = 4 + .5·8 − 6 = 2;     A2 = 2
         δ1 = −1.5 + .25·6 − 3 = −3; A1 = −3 + .0625·2 = −2.875
         δ0 = −1 + .5·10 − 0 = 4;   A0 = 4 (new episode follows: no recursion)
Paper's per-option-step form, δ = R + γ V' − V, A = δ + γλ A':
  env 0: δ2 = 12 − 4 = 8;  A2 = 8;  δ1 = 4 + 2 − 2 = 4;  A1 = 4 + .25·8 = 6
         δ0 = 3 + 1 − 1 = 3;  A0 = 3 + .25·6 = 4.5
  env 1: δ2 = 4 + 4 − 6 = 2;  A2 = 2;  δ1 = −2 + 3 − 3 = −2;  A1 = −2 + .25·2 = −1.5
         δ0 = −1 + 5 − 0 = 4;  A0 = 4
"""

import numpy as np
import pytest
import torch

from maopg.learner import DiscountForm, Rollout, ValueNorm, compute_gae
from maopg.policy import ObsBatch

VALUES = np.array([[1.0, 0.0], [2.0, 3.0], [4.0, 6.0]])
NEXT_VALUES = np.array([[2.0, 10.0], [4.0, 6.0], [100.0, 8.0]])  # 100: ignored (terminated)
REWARD_SUM = np.array([[3.0, -1.0], [4.0, -2.0], [12.0, 4.0]])
REWARD_DISCOUNTED = np.array([[2.0, -1.0], [4.0, -1.5], [9.0, 4.0]])
DURATIONS = np.array([[2, 1], [1, 2], [3, 1]])
TERMINATED = np.array([[False, False], [False, False], [True, False]])
TRUNCATED = np.array([[False, True], [False, False], [False, False]])
CONTINUES = np.array([[True, False], [True, True], [False, False]])

SMDP_ADVANTAGES = np.array([[1.828125, 4.0], [5.25, -2.875], [5.0, 2.0]])
OPTION_ADVANTAGES = np.array([[4.5, 4.0], [6.0, -1.5], [8.0, 2.0]])


@pytest.mark.parametrize(
    ("form", "expected"),
    [(DiscountForm.SMDP, SMDP_ADVANTAGES), (DiscountForm.OPTION, OPTION_ADVANTAGES)],
)
def test_gae_matches_hand_computation(form, expected):
    advantages, returns = compute_gae(
        values=VALUES,
        next_values=NEXT_VALUES,
        reward_sum=REWARD_SUM,
        reward_discounted=REWARD_DISCOUNTED,
        durations=DURATIONS,
        terminated=TERMINATED,
        continues=CONTINUES,
        gamma=0.5,
        lam=0.5,
        form=form,
    )
    np.testing.assert_array_equal(advantages, expected)
    np.testing.assert_array_equal(returns, expected + VALUES)


def test_smdp_equals_option_form_when_every_option_lasts_one_tick():
    rng = np.random.default_rng(0)
    shape = (7, 3)
    rewards = rng.normal(size=shape)
    kwargs = dict(
        values=rng.normal(size=shape),
        next_values=rng.normal(size=shape),
        reward_sum=rewards,
        reward_discounted=rewards,
        durations=np.ones(shape, dtype=int),
        terminated=rng.random(shape) < 0.2,
        continues=rng.random(shape) < 0.7,
        gamma=0.97,
        lam=0.9,
    )
    smdp, _ = compute_gae(form="smdp", **kwargs)
    option, _ = compute_gae(form="option", **kwargs)
    np.testing.assert_allclose(smdp, option, rtol=0, atol=1e-12)


def test_zero_duration_is_rejected():
    with pytest.raises(ValueError, match="at least one tick"):
        compute_gae(
            values=np.zeros(1),
            next_values=np.zeros(1),
            reward_sum=np.zeros(1),
            reward_discounted=np.zeros(1),
            durations=np.zeros(1),
            terminated=np.zeros(1, bool),
            continues=np.zeros(1, bool),
            gamma=0.9,
            lam=0.9,
        )


def _grid_rollout(values: np.ndarray, next_values: np.ndarray) -> Rollout:
    """The hand example stored row by row the way the sampler stores it."""
    rollout = Rollout(num_envs=2)
    for s in range(3):
        rollout.add(
            obs=ObsBatch(torch.zeros(2, 1)),
            choosing=torch.ones(2, 1, dtype=torch.bool),
            running=torch.zeros(2, 1, dtype=torch.int64),
            available=torch.ones(2, 1, dtype=torch.bool),
            joint=torch.zeros(2, 1, dtype=torch.int64),
            log_prob=torch.zeros(2),
            value=torch.from_numpy(values[s]).float(),
            reward_sum=REWARD_SUM[s],
            reward_discounted=REWARD_DISCOUNTED[s],
            duration=DURATIONS[s],
            terminated=TERMINATED[s],
            truncated=TRUNCATED[s],
            next_value=torch.from_numpy(next_values[s]).float(),
        )
    return rollout


def test_rollout_derives_episode_boundaries_and_batch_cut():
    rollout = _grid_rollout(VALUES, NEXT_VALUES)
    assert rollout.ticks == int(DURATIONS.sum()) == 10
    advantages, returns, _ = rollout.advantages(None, gamma=0.5, lam=0.5, form="smdp")
    np.testing.assert_array_equal(advantages, SMDP_ADVANTAGES)
    batch = rollout.training_batch(advantages, returns)
    # Row-major flattening: index s * E + e.
    np.testing.assert_array_equal(batch.advantages.numpy(), SMDP_ADVANTAGES.reshape(-1))
    np.testing.assert_array_equal(batch.returns.numpy(), (SMDP_ADVANTAGES + VALUES).reshape(-1))


def test_rollout_denormalises_values_before_gae():
    norm = ValueNorm()
    norm.update(torch.tensor([10.0, 30.0, 50.0, 70.0]))
    to_critic_space = lambda x: norm.normalize(torch.from_numpy(x)).numpy()  # noqa: E731
    rollout = _grid_rollout(to_critic_space(VALUES), to_critic_space(NEXT_VALUES))
    advantages, _, values = rollout.advantages(norm, gamma=0.5, lam=0.5, form="option")
    np.testing.assert_allclose(values, VALUES, atol=1e-5)
    np.testing.assert_allclose(advantages, OPTION_ADVANTAGES, atol=1e-4)
