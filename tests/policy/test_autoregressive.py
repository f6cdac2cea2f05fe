"""The autoregressive conditional policy against brute-force enumeration of the joint, and its
expressivity: it fits a correlated conditional no product of independent marginals can."""

from __future__ import annotations

import itertools
import math

import pytest
import torch

from maopg.env.contract import AgentSpec, EnvSpec, Strategy
from maopg.policy import ObsBatch, joint_slice_mask
from maopg.policy.autoregressive import AutoregressivePolicy, PartialFactoredPolicy

TEAMS = {
    "two": (3, 6),
    "three": (3, 3, 6),
    "four": (2, 4, 3, 5),
}
"""Option counts of small heterogeneous teams (N ≤ 4: the joint can be enumerated)."""


def make_spec(counts: tuple[int, ...]) -> EnvSpec:
    agents = tuple(
        AgentSpec(f"agent{i}", "robot", tuple(f"o{j}" for j in range(k)), 4)
        for i, k in enumerate(counts)
    )
    return EnvSpec("team", Strategy.CONTINUE, agents, None, 1.0, 100, 0.99)


def random_conditions(counts: tuple[int, ...], batch: int, seed: int):
    """Random ``U`` (at least one chooser per row), running options, availability masks with at
    least one available option per agent, and observations."""
    gen = torch.Generator().manual_seed(seed)
    n = len(counts)
    choosing = torch.rand(batch, n, generator=gen) < 0.6
    choosing[torch.arange(batch), torch.randint(0, n, (batch,), generator=gen)] = True
    running = torch.stack([torch.randint(0, k, (batch,), generator=gen) for k in counts], -1)
    masks = []
    for k in counts:
        mask = torch.rand(batch, k, generator=gen) < 0.7
        mask[torch.arange(batch), torch.randint(0, k, (batch,), generator=gen)] = True
        masks.append(mask)
    obs = ObsBatch(torch.randn(batch, 4 * n, generator=gen))
    return obs, choosing, running, torch.cat(masks, dim=-1)


POLICIES = {"chain": AutoregressivePolicy, "partial": PartialFactoredPolicy}
"""The chain rule over the joint and each agent's own observation, and per-agent factors on
local observations only."""


def build(counts: tuple[int, ...], seed: int = 0, kind: str = "chain") -> AutoregressivePolicy:
    torch.manual_seed(seed)
    policy = POLICIES[kind](make_spec(counts), hidden=32, layers=1)
    with torch.no_grad():  # a far-from-uniform policy, so the checks below are not trivial
        policy.head.weight.mul_(300.0)
    return policy


def enumerate_joint(counts: tuple[int, ...], batch: int) -> torch.Tensor:
    """Every joint option, ``int64 [ΠK, N]``."""
    return torch.tensor(list(itertools.product(*(range(k) for k in counts))))


def brute_force(policy, obs, choosing, running, available) -> tuple[torch.Tensor, torch.Tensor]:
    """(log π of every joint ``[B, ΠK]`` — −inf outside the slice —, the slice mask)."""
    counts = policy.option_counts
    joints = enumerate_joint(counts, len(obs))
    mask = joint_slice_mask(choosing, running, available, counts).reshape(len(obs), -1)
    log_p = torch.full(mask.shape, -math.inf)
    for row in range(len(obs)):
        r = slice(row, row + 1)
        m = len(joints)
        dist = policy.distribution(
            ObsBatch(obs.vectors[r].expand(m, -1)),
            choosing[r].expand(m, -1),
            running[r].expand(m, -1),
            available[r].expand(m, -1),
        )
        inside = mask[row]
        log_p[row, inside] = dist.log_prob(joints)[inside]
    return log_p, mask


@pytest.mark.parametrize("kind", POLICIES)
@pytest.mark.parametrize("team", TEAMS)
def test_probabilities_over_the_slice_sum_to_one_and_match_the_factors(team, kind):
    counts = TEAMS[team]
    policy = build(counts, kind=kind)
    obs, choosing, running, available = random_conditions(counts, 12, seed=1)
    with torch.no_grad():
        log_p, _ = brute_force(policy, obs, choosing, running, available)
        torch.testing.assert_close(log_p.exp().sum(-1), torch.ones(12))
        # log_prob is the product of the factors, each computed on its own, step by step
        dist = policy.distribution(obs, choosing, running, available)
        joint = dist.sample(torch.Generator().manual_seed(0))
        total = torch.zeros(12)
        for i in range(len(counts)):
            agent = torch.tensor([i])
            logits = policy.factor_logits(
                dist.features, dist.choosing, dist._known(joint, agent), agent
            )
            factor = dist._log_softmax(logits, agent)[:, 0]
            picked = factor.gather(-1, joint[:, i : i + 1]).squeeze(-1)
            total += torch.where(choosing[:, i], picked, 0.0)
        torch.testing.assert_close(dist.log_prob(joint), total)


@pytest.mark.parametrize("kind", POLICIES)
@pytest.mark.parametrize("team", TEAMS)
def test_sampling_frequencies_match_and_respect_the_condition(team, kind):
    counts = TEAMS[team]
    policy = build(counts, seed=2, kind=kind)
    obs, choosing, running, available = random_conditions(counts, 3, seed=3)
    with torch.no_grad():
        log_p, mask = brute_force(policy, obs, choosing, running, available)
        draws = 20_000
        rows = torch.arange(3).repeat_interleave(draws)
        dist = policy.distribution(obs[rows], choosing[rows], running[rows], available[rows])
        joint = dist.sample(torch.Generator().manual_seed(4))
    # continuing agents keep their running option; masked options are never drawn
    assert torch.equal(joint[~choosing[rows]], running[rows][~choosing[rows]])
    flat = torch.zeros(len(rows), dtype=torch.long)
    for i, k in enumerate(counts):
        flat = flat * k + joint[:, i]
    assert bool(mask[rows, flat].all()), "a joint outside the slice was drawn"
    for row in range(3):
        freq = torch.bincount(flat[rows == row], minlength=mask.shape[1]).double() / draws
        p = log_p[row].exp().double()
        # 5 standard errors of a binomial proportion, plus a floor for rare joints
        tolerance = 5 * torch.sqrt(p * (1 - p) / draws) + 2e-3
        assert bool(((freq - p).abs() <= tolerance).all()), (freq, p)


@pytest.mark.parametrize("kind", POLICIES)
def test_gradients_reach_only_the_factors_of_choosing_agents(kind):
    """Row by row, in rows where some agents choose and others continue: the log-probability
    and entropy of a sampled joint send no gradient to a continuing agent's factor — its own
    encoder's features in that row, which feed its factor alone, get none — and some to every
    choosing agent's that has a choice (more than one option available)."""
    counts = TEAMS["three"]
    policy = build(counts, kind=kind)
    obs, choosing, running, available = random_conditions(counts, 32, seed=5)
    assert int((~choosing.all(1)).sum()) >= 8, "too few rows with a continuing agent"
    outputs: dict[int, list[torch.Tensor]] = {i: [] for i in range(len(counts))}

    def keep(agent: int):
        def hook(_module, _inputs, output: torch.Tensor) -> None:
            output.retain_grad()
            outputs[agent].append(output)

        return hook

    handles = [e.register_forward_hook(keep(i)) for i, e in enumerate(policy.encoders)]
    dist = policy.distribution(obs, choosing, running, available)
    joint = dist.sample(torch.Generator().manual_seed(6))
    (dist.log_prob(joint).sum() + dist.entropy().sum()).backward()
    for handle in handles:
        handle.remove()
    options = available.split(list(counts), dim=1)
    for agent, kept in outputs.items():
        assert kept, f"agent {agent}'s encoder never ran"
        per_row = sum(out.grad.abs().sum(-1) for out in kept)
        assert bool((per_row[~choosing[:, agent]] == 0).all()), f"agent {agent} continued"
        chose = choosing[:, agent] & (options[agent].sum(1) > 1)
        assert int(chose.sum()) >= 8 and bool((per_row[chose] > 0).all()), f"agent {agent} chose"


@pytest.mark.parametrize("kind", POLICIES)
def test_an_agent_that_continues_everywhere_trains_none_of_its_own_encoder(kind):
    """Agent i's own encoder feeds agent i's factor only: where agent 1 continues in every row,
    the log-probability and entropy of the joint send it no gradient, while the choosing agents'
    encoders (and the joint one, which every factor reads) get one."""
    counts = TEAMS["three"]
    policy = build(counts, kind=kind)
    obs, choosing, running, available = random_conditions(counts, 16, seed=11)
    choosing[:, 1] = False
    choosing[:, 0] = True
    dist = policy.distribution(obs, choosing, running, available)
    joint = dist.sample(torch.Generator().manual_seed(12))
    (dist.log_prob(joint).sum() + dist.entropy().sum()).backward()

    def grad_norm(module: torch.nn.Module) -> float:
        return sum(float(p.grad.abs().sum()) for p in module.parameters() if p.grad is not None)

    assert grad_norm(policy.encoders[1]) == 0.0
    assert grad_norm(policy.encoders[0]) > 0.0
    if policy.encoder is not None:
        assert grad_norm(policy.encoder) > 0.0


def test_sync_rows_and_the_mode_and_entropy():
    """Every agent choosing (the sync strategies): the mode is the greedy decode, and the
    entropy along a joint equals the chain rule's sum of factor entropies."""
    counts = TEAMS["three"]
    policy = build(counts)
    obs, _, running, available = random_conditions(counts, 8, seed=7)
    choosing = torch.ones(8, 3, dtype=torch.bool)
    with torch.no_grad():
        dist = policy.distribution(obs, choosing, running, available)
        mode = dist.mode()
        factors = dist.factor_log_probs(mode)
        assert torch.equal(mode, factors.argmax(-1))
        expected = -(factors.exp() * factors.nan_to_num(neginf=0.0)).sum(-1).sum(-1)
        torch.testing.assert_close(dist.entropy(), expected)
        # exact joint entropy, averaged over the policy's own joints, is what the estimate hits
        log_p, _ = brute_force(policy, obs, choosing, running, available)
        exact = -(log_p.exp() * log_p.nan_to_num(neginf=0.0)).sum(-1)
        joints = enumerate_joint(counts, 8)
        estimate = torch.zeros(8)
        for j, joint in enumerate(joints):
            dist.log_prob(joint.expand(8, -1))
            estimate += log_p[:, j].exp() * dist.entropy()
        torch.testing.assert_close(estimate, exact, atol=1e-5, rtol=1e-5)


def test_fits_a_correlated_conditional_no_product_of_marginals_can():
    """Expressivity: gradient descent on KL(target ‖ π) over 3 choosing agents reaches < 0.01,
    where the best product of independent marginals stays far above it."""
    counts = (3, 3, 4)
    policy = build(counts, seed=8)
    with torch.no_grad():
        policy.head.weight.div_(300.0)
    gen = torch.Generator().manual_seed(9)
    target = torch.softmax(3.0 * torch.randn(math.prod(counts), generator=gen), 0)
    grid = target.view(counts)
    marginals = [grid.sum(dim=tuple(d for d in range(3) if d != i)) for i in range(3)]
    product = torch.einsum("a,b,c->abc", *marginals).reshape(-1)
    product_kl = float((target * (target / product).log()).sum())
    assert product_kl > 0.1, "the target must be correlated for the test to mean anything"

    joints = enumerate_joint(counts, 1)
    m = len(joints)
    obs = ObsBatch(torch.zeros(m, 12))
    choosing = torch.ones(m, 3, dtype=torch.bool)
    running = torch.zeros(m, 3, dtype=torch.long)
    available = torch.ones(m, sum(counts), dtype=torch.bool)
    optimizer = torch.optim.Adam(policy.parameters(), lr=3e-2)
    for _ in range(300):
        log_p = policy.distribution(obs, choosing, running, available).log_prob(joints)
        kl = (target * (target.log() - log_p)).sum()
        optimizer.zero_grad()
        kl.backward()
        optimizer.step()
    assert kl.item() < 0.01, (kl.item(), product_kl)


def test_partial_factors_are_independent_local_marginals_with_the_exact_entropy():
    """partial-ar: agent i's factor sees its own observation, not the others' (nor their
    draws), so the joint is the product of the marginals and the entropy is exact."""
    counts = TEAMS["three"]
    policy = build(counts, seed=5, kind="partial")
    obs, choosing, running, available = random_conditions(counts, 8, seed=6)
    with torch.no_grad():
        log_p, mask = brute_force(policy, obs, choosing, running, available)
        exact = -(log_p.exp() * log_p.masked_fill(~mask, 0.0)).sum(-1)
        dist = policy.distribution(obs, choosing, running, available)
        dist.log_prob(dist.sample(torch.Generator().manual_seed(7)))
        torch.testing.assert_close(dist.entropy(), exact)
        # another agent's observation (agent 2's slice of the vectors) leaves agent 0's factor be
        other = ObsBatch(obs.vectors.clone())
        other.vectors[:, 8:] += 5.0
        joint = dist.mode()
        before = dist.factor_log_probs(joint)[:, 0]
        after = policy.distribution(other, choosing, running, available).factor_log_probs(joint)
        torch.testing.assert_close(after[:, 0], before)
        assert not torch.allclose(after[:, 2], dist.factor_log_probs(joint)[:, 2])
