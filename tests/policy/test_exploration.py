"""Exploration by ε-mixed sampling: each choosing agent's chain-rule factor
(:class:`maopg.policy.EpsilonMixture`) or the joint option (:class:`maopg.policy.JointMixture`)
mixed with the uniform distribution over the available options, continuing agents untouched,
never an unavailable option, log-probabilities that are the mixture's (checked against
hand-worked cases), and its schedule (``ppo.explore_*``)."""

from __future__ import annotations

import itertools
import math

import pytest
import torch

from maopg.env.contract import AgentSpec, EnvSpec, Strategy
from maopg.learner.mappo import PPOConfig
from maopg.policy import (
    AutoregressivePolicy,
    CentralizedPolicy,
    ConditionalJoint,
    ObsBatch,
    PartiallyCentralizedPolicy,
    explore,
    mix_uniform,
)

SPEC = EnvSpec(
    task="exploration",
    strategy=Strategy.CONTINUE,
    agents=(
        AgentSpec("a", "turtlebot", ("x", "y", "z"), 4),
        AgentSpec("b", "fetch", ("u", "v"), 3),
        AgentSpec("c", "turtlebot", ("p", "q", "r", "s"), 2),
    ),
    image_shape=None,
    tick_seconds=0.1,
    max_ticks=10,
    gamma=0.99,
)
COUNTS = (3, 2, 4)
CHOOSING = torch.tensor([[1, 1, 1], [1, 0, 1], [0, 1, 0], [1, 1, 0], [0, 0, 1]]).bool()
RUNNING = torch.tensor([[0, 0, 0], [2, 1, 3], [1, 0, 1], [0, 0, 2], [2, 1, 0]])
AVAILABLE = torch.ones(5, sum(COUNTS), dtype=torch.bool)
AVAILABLE[0, 1] = False  # agent a may not take y in row 0
AVAILABLE[3, 3 + 1] = False  # agent b may not take v in row 3
AVAILABLE[4, 5:8] = False  # agent c may only take s in row 4


FAMILIES = {
    "centralized": CentralizedPolicy,
    "partial": PartiallyCentralizedPolicy,
    "autoregressive": AutoregressivePolicy,
}


def _distributions(copies: int = 1) -> dict[str, object]:
    """The conditional of each built-in policy family on the same five decision points, each
    repeated ``copies`` times (row ``k`` is point ``k % 5``)."""
    torch.manual_seed(0)
    obs = ObsBatch(torch.randn(5, 9).repeat(copies, 1))
    conditions = (t.repeat(copies, 1) for t in (CHOOSING, RUNNING, AVAILABLE))
    choosing, running, available = conditions
    made = {}
    for name, family in FAMILIES.items():
        policy = family(SPEC, hidden=16)
        made[name] = policy.distribution(obs, choosing, running, available)
    return made


def _mixed(dist, eps: float, form: str, copies: int = 1):
    """``dist`` mixed in ``form`` at ``eps`` (the conditions repeated as ``_distributions``)."""
    conditions = tuple(t.repeat(copies, 1) for t in (CHOOSING, RUNNING, AVAILABLE))
    return explore(dist, eps, form, conditions, COUNTS)  # type: ignore[arg-type]


def _admissible(joint: torch.Tensor) -> torch.Tensor:
    """``bool [..., B]`` of joints ``[..., B, N]``: every choosing agent's option available,
    every continuing agent's its running one."""
    ok = torch.ones(joint.shape[:-1], dtype=torch.bool)
    for i, lanes in enumerate(torch.split(AVAILABLE, list(COUNTS), dim=-1)):
        lanes = lanes.expand(*joint.shape[:-1], lanes.shape[-1])
        picked = lanes.gather(-1, joint[..., i : i + 1]).squeeze(-1)
        ok &= torch.where(CHOOSING[:, i], picked, joint[..., i] == RUNNING[:, i])
    return ok


def test_the_mixture_of_a_product_categorical_is_the_hand_worked_one():
    """Two agents, both choosing, joint probabilities ``[[.4, .1], [.2, .3]]``, ε = 0.5:
    agent 0's factor is ``[.5, .5]`` (mixed: ``[.5, .5]``); agent 1's given o0 = 0 is
    ``[.8, .2]`` → ``.5·.8 + .5/2 = .65``, given o0 = 1 ``[.4, .6]`` → ``.45, .55``. With agent 1's
    second option unavailable, the slice is the first column ``[.4, .2]/.6`` → agent 0 mixes
    ``2/3`` to ``.5·2/3 + .25``."""
    logits = torch.tensor([[[0.4, 0.1], [0.2, 0.3]]]).log()
    both = torch.ones(1, 2, dtype=torch.bool)
    running = torch.zeros(1, 2, dtype=torch.long)
    dist = ConditionalJoint(logits, both, running, torch.ones(1, 4, dtype=torch.bool))
    mixed = explore(dist, 0.5)
    expected = {(0, 0): 0.5 * 0.65, (0, 1): 0.5 * 0.35, (1, 0): 0.5 * 0.45, (1, 1): 0.5 * 0.55}
    for joint, p in expected.items():
        got = mixed.log_prob(torch.tensor([joint])).exp().item()
        assert got == pytest.approx(p, abs=1e-6), joint
    available = torch.tensor([[True, True, True, False]])
    restricted = explore(ConditionalJoint(logits, both, running, available), 0.5)
    assert restricted.log_prob(torch.tensor([[0, 0]])).exp().item() == pytest.approx(
        0.5 * 2 / 3 + 0.25, abs=1e-6
    )
    assert restricted.log_prob(torch.tensor([[0, 1]])).item() == -math.inf


def test_the_joint_mixture_of_a_product_categorical_is_the_hand_worked_one():
    """Three options against two, both choosing, ε = 0.4: ``μ(o) = .6·π(o) + .4/6``; where the
    policy puts no mass on a joint option the mixture puts ``.4/6`` (a joint ruled out by
    availability stays impossible)."""
    p = torch.tensor([[[0.5, 0.0], [0.25, 0.25], [0.0, 0.0]]])
    both = torch.ones(1, 2, dtype=torch.bool)
    running = torch.zeros(1, 2, dtype=torch.long)
    available = torch.ones(1, 5, dtype=torch.bool)
    dist = ConditionalJoint(p.log(), both, running, available)
    mixed = explore(dist, 0.4, "joint", (both, running, available), (3, 2))
    for joint in itertools.product(range(3), range(2)):
        got = mixed.log_prob(torch.tensor([joint])).exp().item()
        assert got == pytest.approx(0.6 * float(p[0][joint]) + 0.4 / 6, abs=1e-6), joint
    available[0, 2] = False  # agent 0's third option
    restricted = ConditionalJoint(p.log(), both, running, available)
    mixed = explore(restricted, 0.4, "joint", (both, running, available), (3, 2))
    assert mixed.log_prob(torch.tensor([[0, 1]])).exp().item() == pytest.approx(0.4 / 4)
    assert mixed.log_prob(torch.tensor([[2, 0]])).item() == -math.inf


@pytest.mark.parametrize("form", ["agent", "joint"])
@pytest.mark.parametrize("family", ["centralized", "partial", "autoregressive"])
def test_the_mixture_is_a_distribution_over_the_admissible_joints(family, form):
    """Its probabilities sum to 1 over the slice in every row; ε = 1 is uniform over each
    choosing agent's available options; ε = 0 is the policy itself."""
    dist = _distributions()[family]
    joints = torch.tensor(list(itertools.product(*(range(k) for k in COUNTS))))
    for eps in (0.0, 0.3, 1.0):
        total = torch.zeros(5)
        for joint in joints:
            joint = joint.expand(5, 3)
            p = _mixed(dist, eps, form).log_prob(joint).exp()
            total += torch.where(_admissible(joint), p, 0.0)
            if eps == 0.0:
                assert torch.allclose(p, dist.log_prob(joint).exp(), atol=1e-6)  # type: ignore[attr-defined]
        assert torch.allclose(total, torch.ones(5), atol=1e-5), (eps, total)
    sizes = torch.stack(
        [lanes.sum(-1) for lanes in torch.split(AVAILABLE, list(COUNTS), dim=-1)], -1
    )
    uniform = -torch.where(CHOOSING, sizes.float().log(), 0.0).sum(-1)
    everywhere = _mixed(dist, 1.0, form)
    joint = everywhere.sample(torch.Generator().manual_seed(0))
    assert torch.allclose(everywhere.log_prob(joint), uniform, atol=1e-6)


@pytest.mark.parametrize("form", ["agent", "joint"])
@pytest.mark.parametrize("family", ["centralized", "partial", "autoregressive"])
def test_sampling_never_takes_an_unavailable_option_and_leaves_continuing_agents_alone(
    family, form
):
    """5,000 draws of each point at ε = 1 (all exploration) and ε = 0.5; their frequencies
    follow the mixture's probabilities."""
    dist = _distributions(copies=5000)[family]
    generator = torch.Generator().manual_seed(3)
    for eps in (1.0, 0.5):
        mixed = _mixed(dist, eps, form, copies=5000)
        draws = mixed.sample(generator).view(5000, 5, 3)
        assert bool(_admissible(draws).all())
        assert bool((draws[:, ~CHOOSING] == RUNNING[~CHOOSING]).all())
    # ε = 0.5 at point 0, where all three agents choose: frequencies against probabilities
    joints, counts = torch.unique(draws[:, 0], dim=0, return_counts=True)
    scored = draws.clone()
    scored[: len(joints), 0] = joints
    p = mixed.log_prob(scored.view(-1, 3)).exp().view(5000, 5)[: len(joints), 0]
    assert torch.allclose(counts / 5000, p, atol=0.02)


@pytest.mark.parametrize("form", ["agent", "joint"])
@pytest.mark.parametrize("family", ["centralized", "partial", "autoregressive"])
def test_the_gradient_of_the_mixed_log_prob_is_finite(family, form):
    """At ε = 0, 0.5 and 1, with unavailable options in the rows."""
    dist = _distributions()[family]
    joint = dist.sample(torch.Generator().manual_seed(1))  # type: ignore[attr-defined]
    for eps in (0.0, 0.5, 1.0):
        torch.manual_seed(0)
        obs = ObsBatch(torch.randn(5, 9))
        policy = FAMILIES[family](SPEC, hidden=16)
        mixed = _mixed(policy.distribution(obs, CHOOSING, RUNNING, AVAILABLE), eps, form)
        mixed.log_prob(joint).sum().backward()
        for name, parameter in policy.named_parameters():
            assert parameter.grad is None or bool(torch.isfinite(parameter.grad).all()), name


@pytest.mark.parametrize("family", ["centralized", "partial", "autoregressive"])
def test_the_entropy_is_the_policys_own_along_the_scored_joint(family):
    """The bonus regularises the policy, not the mixture: scored through the mixture, the
    entropy is what the policy alone gives along the same joint (the autoregressive one's is
    read along the joint last scored)."""
    joint = _distributions()[family].sample(torch.Generator().manual_seed(2))  # type: ignore[attr-defined]
    alone, mixed = _distributions()[family], _mixed(_distributions()[family], 0.5, "agent")
    alone.log_prob(joint)  # type: ignore[attr-defined]
    mixed.log_prob(joint)
    assert torch.allclose(mixed.entropy(), alone.entropy(), atol=1e-6)  # type: ignore[attr-defined]


def test_mix_uniform_keeps_ruled_out_entries_out():
    log_probs = torch.tensor(
        [[0.0, -math.inf, -math.inf], [math.log(0.25), math.log(0.75), -math.inf]]
    )
    mixed = mix_uniform(log_probs, torch.tensor([0.4, 0.2])).exp()
    assert torch.allclose(mixed, torch.tensor([[1.0, 0.0, 0.0], [0.3, 0.7, 0.0]]))


def test_the_schedule_falls_linearly_then_holds():
    off = PPOConfig()
    assert off.exploration(0, 0) == 0.0 and off.exploration(10**9, 10**6) == 0.0
    ticks = PPOConfig(explore_eps=1.0, explore_eps_end=0.01, explore_decay=100_000)
    assert [ticks.exploration(s, 0) for s in (0, 50_000, 100_000, 400_000)] == pytest.approx(
        [1.0, 0.505, 0.01, 0.01]
    )
    acac = PPOConfig(
        explore_eps=1.0, explore_eps_end=0.01, explore_decay=30_000, explore_unit="episodes"
    )
    assert acac.exploration(10**6, 15_000) == pytest.approx(0.505)
    assert PPOConfig(explore_eps=0.2).exploration(10**6, 10**6) == 0.2  # decay 0: constant
    off = PPOConfig(explore_eps=0.0, explore_eps_end=0.01, explore_decay=10)
    assert off.exploration(10**6, 10**6) == 0.0  # 0 is off, whatever the end value


def test_a_policy_without_chain_rule_factors_is_refused_in_one_line():
    class Opaque:
        choosing = CHOOSING

        def sample(self, generator=None): ...

    with pytest.raises(TypeError, match="needs a policy whose conditional factors by agent"):
        explore(Opaque(), 0.1)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="form must be one of"):
        explore(Opaque(), 0.1, "team")  # type: ignore[arg-type]
