"""The TorchRL recipe of ``docs/torchrl.md`` runs as written: its code blocks, executed in order,
wrap the PettingZoo view with TorchRL's ``PettingZooWrapper`` and pass ``check_env_specs``; the
masks keep continuing agents on their options, the state is the view's joint observation, and
the SMDP advantages it computes with TorchRL equal maopg's own (``compute_gae``)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import torch

from maopg.learner.gae import compute_gae

RECIPE = Path(__file__).resolve().parents[2] / "docs" / "torchrl.md"
CODE = re.compile(r"```python\n(.*?)```", re.DOTALL)


@pytest.fixture(scope="module")
def recipe():
    """The namespace the recipe's blocks leave behind (its ``env``, ``view``, rollout, ...)."""
    blocks = CODE.findall(RECIPE.read_text())
    assert len(blocks) == 2, "the recipe's code blocks changed: update this test"
    namespace: dict = {}
    exec(compile("\n".join(blocks), str(RECIPE), "exec"), namespace)
    yield namespace
    namespace["env"].close()


def test_the_wrapped_view_passes_torchrls_spec_check(recipe):
    env = recipe["env"]
    from torchrl.envs.utils import check_env_specs

    check_env_specs(env, seed=1)  # again, after the recipe's rollout
    assert set(env.group_map) == {"turtlebots", "fetch"}
    assert env.observation_spec["turtlebots", "observation", "observation"].shape == (2, 14)
    assert env.observation_spec["state"].shape == (33,)


def test_masks_keep_continuing_agents_on_their_options(recipe):
    rollout = recipe["rollout"]
    assert rollout.batch_size[0] > 1 and bool(rollout["next", "done"][-1])
    for group in ("turtlebots", "fetch"):
        info = rollout[group, "info"]
        continuing = info["choosing"] == 0
        assert continuing.any() or group == "fetch"
        mask = rollout[group, "action_mask"]
        action = rollout[group, "action"]
        assert mask.gather(-1, action.unsqueeze(-1)).all()  # random actions obey the masks
        running = info["running"].long()
        assert (action[continuing] == running[continuing]).all()
        assert (mask[continuing].sum(-1) == 1).all()


def test_the_state_is_the_views_joint_observation(recipe):
    rollout = recipe["rollout"]
    last = rollout["next"][-1]
    vectors = [last["turtlebots", "observation", "observation"][i] for i in range(2)]
    vectors.append(last["fetch", "observation", "observation"][0])
    assert torch.equal(last["state"], torch.cat(vectors))


def test_the_recipes_advantages_are_maopgs_smdp_advantages(recipe):
    """With non-zero values: TorchRL's GAE with ``γ^k``, ``λ^k`` equals ``compute_gae``."""
    from torchrl.objectives.value.functional import generalized_advantage_estimate

    step = recipe["rollout"]["next"]
    ticks, reward = recipe["ticks"], recipe["reward"]
    gamma, lmbda = recipe["gamma"], recipe["lmbda"]
    assert (ticks > 1).any() and not torch.equal(reward, step["fetch", "reward"][:, 0])
    generator = torch.Generator().manual_seed(0)
    values = torch.randn(reward.shape, generator=generator)
    next_values = torch.cat([values[1:], torch.randn((1, 1), generator=generator)])
    advantage, target = generalized_advantage_estimate(
        gamma**ticks, lmbda**ticks, values, next_values, reward, step["done"], step["terminated"]
    )
    done = step["done"][:, 0].numpy()
    expected, expected_target = compute_gae(
        values=values[:, 0].numpy(),
        next_values=next_values[:, 0].numpy(),
        reward_sum=step["fetch", "reward"][:, 0, 0].numpy(),
        reward_discounted=reward[:, 0].numpy(),
        durations=ticks[:, 0].numpy(),
        terminated=step["terminated"][:, 0].numpy(),
        continues=~done,
        gamma=gamma,
        lam=lmbda,
    )
    np.testing.assert_allclose(advantage[:, 0].numpy(), expected, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(target[:, 0].numpy(), expected_target, rtol=1e-5, atol=1e-5)
