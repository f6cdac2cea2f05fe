"""The TorchRL and BenchMARL recipes of ``docs/torchrl.md`` run as written: the TorchRL code
blocks, executed in order, wrap the PettingZoo view with TorchRL's ``PettingZooWrapper`` and pass
``check_env_specs``; the masks keep continuing agents on their options, the state is the view's
joint observation, and the SMDP advantages it computes with TorchRL equal maopg's own
(``compute_gae``). The BenchMARL block trains BenchMARL's MAPPO on the wrapped view."""

from __future__ import annotations

import re
import sys
import types
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
    assert len(blocks) == 3, "the recipe's code blocks changed: update this test"
    namespace: dict = {}
    exec(compile("\n".join(blocks[:2]), str(RECIPE), "exec"), namespace)
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


def test_benchmarls_mappo_trains_on_the_wrapped_view(recipe, tmp_path, monkeypatch):
    """The BenchMARL block (after the wrapper block, whose names it uses) runs two iterations;
    the batch BenchMARL collected obeys the masks, so continuing agents kept their options."""
    pytest.importorskip("benchmarl")
    monkeypatch.chdir(tmp_path)  # BenchMARL writes its experiment folder into the working dir
    # BenchMARL pickles the task, so its class must live in an importable module.
    module = types.ModuleType("maopg_benchmarl_recipe")
    module.__dict__.update({k: v for k, v in recipe.items() if not k.startswith("__")})
    monkeypatch.setitem(sys.modules, module.__name__, module)
    exec(compile(CODE.findall(RECIPE.read_text())[2], str(RECIPE), "exec"), module.__dict__)

    experiment = module.experiment
    assert experiment.n_iters_performed == 2 and experiment.total_frames == 400
    for group in ("turtlebots", "fetch"):
        buffer = experiment.replay_buffers[group]
        batch = buffer.storage[: len(buffer)]
        mask, action = batch[group, "action_mask"], batch[group, "action"]
        assert mask.gather(-1, action.unsqueeze(-1)).all()
        continuing = mask.sum(-1) == 1
        assert continuing.any() and torch.isfinite(batch[group, "logits"]).all()
    assert batch["state"].shape == (200, 33)
