"""The conditional joint-option distributions against brute-force enumeration of the joint."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import torch

from maopg.policy.conditional import (
    ConditionalJoint,
    FactoredConditional,
    conditional_log_probs,
    joint_slice_mask,
    partial_conditional_log_probs,
    ravel_joint,
    unravel_joint,
)

# Tool Delivery (two Turtlebots, Fetch) in both agent orders, Water Filling, one agent, four.
OPTION_COUNTS = [(3, 3, 6), (6, 3, 3), (7, 13), (5,), (2, 3, 2, 4)]


def random_case(counts, batch, seed, available_p=0.7):
    """Random logits and conditions covering sync rows, single choosers and masked options.

    Continuing agents get availability masks that may exclude their running option (the
    conditional must ignore them); choosing agents sometimes have running = -1 (reset).
    """
    gen = torch.Generator().manual_seed(seed)
    n = len(counts)
    logits = 2.0 * torch.randn(batch, *counts, generator=gen, dtype=torch.float64)
    choosing = torch.rand(batch, n, generator=gen) < 0.5
    choosing[0] = True  # sync row
    if batch > 1 and n > 1:
        choosing[1] = False
        choosing[1, n - 1] = True  # single chooser
    choosing[~choosing.any(dim=1), 0] = True  # a decision point has at least one chooser
    running = torch.stack([torch.randint(0, k, (batch,), generator=gen) for k in counts], dim=1)
    running[choosing & (torch.rand(batch, n, generator=gen) < 0.3)] = -1
    masks = []
    for k in counts:
        m = torch.rand(batch, k, generator=gen) < available_p
        m[torch.arange(batch), torch.randint(0, k, (batch,), generator=gen)] = True
        masks.append(m)
    return logits, choosing, running, torch.cat(masks, dim=1)


def brute_force_conditional(logits_row, choosing_row, running_row, available_row, counts):
    """``π̂`` over the flattened joint from the joint softmax, by enumerating every joint option."""
    joint = torch.softmax(logits_row.reshape(-1), dim=0).numpy()
    avail = np.split(available_row.numpy(), np.cumsum(counts)[:-1])
    weights = np.zeros(math.prod(counts))
    for flat, option in enumerate(itertools.product(*(range(k) for k in counts))):
        admissible = all(
            avail[i][o] if choosing_row[i] else o == running_row[i] for i, o in enumerate(option)
        )
        weights[flat] = joint[flat] if admissible else 0.0
    return weights / weights.sum()


def brute_force_partial(agent_logits_rows, choosing_row, running_row, available_row, counts):
    """Per-agent marginals of each agent's own conditional joint (paper Eq. 5), enumerated."""
    marginals = []
    for i, logits_row in enumerate(agent_logits_rows):
        cond = brute_force_conditional(logits_row, choosing_row, running_row, available_row, counts)
        marginals.append(
            cond.reshape(counts).sum(axis=tuple(d for d in range(len(counts)) if d != i))
        )
    return marginals


@pytest.mark.parametrize("counts", OPTION_COUNTS)
def test_conditional_matches_brute_force(counts):
    logits, choosing, running, available = random_case(counts, batch=24, seed=1)
    probs = conditional_log_probs(logits, choosing, running, available).exp()
    assert probs.shape == (24, math.prod(counts))
    torch.testing.assert_close(probs.sum(dim=1), torch.ones(24, dtype=torch.float64))
    for b in range(24):
        expected = brute_force_conditional(logits[b], choosing[b], running[b], available[b], counts)
        np.testing.assert_allclose(probs[b].numpy(), expected, atol=1e-12)


def test_sync_without_masks_is_the_joint_softmax():
    counts = (3, 3, 6)
    logits = torch.randn(8, *counts, generator=torch.Generator().manual_seed(2))
    log_probs = conditional_log_probs(
        logits, torch.ones(8, 3, dtype=torch.bool), torch.full((8, 3), -1), torch.ones(8, 12)
    )
    torch.testing.assert_close(log_probs, torch.log_softmax(logits.reshape(8, -1), dim=1))


def test_single_chooser_is_a_softmax_along_its_axis():
    counts = (3, 3, 6)
    logits = torch.randn(4, *counts, generator=torch.Generator().manual_seed(3))
    choosing = torch.tensor([[False, True, False]] * 4)
    running = torch.tensor([[2, -1, 4], [0, 1, 5], [1, 0, 0], [2, 2, 2]])
    probs = conditional_log_probs(logits, choosing, running, torch.ones(4, 12)).exp()
    for b in range(4):
        axis = torch.softmax(logits[b, running[b, 0], :, running[b, 2]], dim=0)
        joint = probs[b].view(counts)
        torch.testing.assert_close(joint[running[b, 0], :, running[b, 2]], axis)
        assert joint.sum().item() == pytest.approx(1.0)


@pytest.mark.parametrize("counts", [(3, 3, 6), (7, 13)])
def test_log_prob_entropy_and_mode_match_brute_force(counts):
    logits, choosing, running, available = random_case(counts, batch=16, seed=4)
    dist = ConditionalJoint(logits, choosing, running, available)
    joint = dist.sample(torch.Generator().manual_seed(0))
    flat = ravel_joint(joint, counts)
    for b in range(16):
        p = brute_force_conditional(logits[b], choosing[b], running[b], available[b], counts)
        assert dist.log_prob(joint)[b].item() == pytest.approx(math.log(p[flat[b]]), abs=1e-10)
        nonzero = p[p > 0]
        assert dist.entropy()[b].item() == pytest.approx(-(nonzero * np.log(nonzero)).sum())
        assert ravel_joint(dist.mode()[b : b + 1], counts).item() == int(np.argmax(p))
    # Entries of continuing agents are ignored by log_prob (the env accepts -1 there).
    with_placeholders = torch.where(choosing, joint, torch.full_like(joint, -1))
    torch.testing.assert_close(dist.log_prob(with_placeholders), dist.log_prob(joint))


def test_sample_frequencies_agree_with_probabilities():
    counts = (3, 3, 6)
    logits, choosing, running, available = random_case(counts, batch=4, seed=5)
    repeats = 30_000
    dist = ConditionalJoint(
        logits.repeat_interleave(repeats, 0),
        choosing.repeat_interleave(repeats, 0),
        running.repeat_interleave(repeats, 0),
        available.repeat_interleave(repeats, 0),
    )
    joint = dist.sample(torch.Generator().manual_seed(6))
    # Continuing agents keep their running option; choosing agents take available options only.
    assert torch.equal(joint[~dist.choosing], dist.running[~dist.choosing])
    avail = torch.split(available.repeat_interleave(repeats, 0), counts, dim=1)
    for i in range(len(counts)):
        taken = avail[i].gather(1, joint[:, i : i + 1].clamp(min=0)).squeeze(1)
        assert bool(taken[dist.choosing[:, i]].all())
    flat = ravel_joint(joint, counts).view(4, repeats)
    for b in range(4):
        p = brute_force_conditional(logits[b], choosing[b], running[b], available[b], counts)
        freq = np.bincount(flat[b].numpy(), minlength=p.size) / repeats
        assert np.all(freq[p == 0] == 0)
        sigma = np.sqrt(p * (1 - p) / repeats)
        assert np.all(np.abs(freq - p) <= 5 * sigma + 1e-4), (b, np.abs(freq - p).max())


@pytest.mark.filterwarnings("ignore:Anomaly Detection has been enabled")
@pytest.mark.parametrize("counts", OPTION_COUNTS)
def test_gradients_reach_only_the_slice(counts):
    logits, choosing, running, available = random_case(counts, batch=12, seed=7)
    logits.requires_grad_(True)
    dist = ConditionalJoint(logits, choosing, running, available)
    joint = dist.sample(torch.Generator().manual_seed(1))
    with torch.autograd.detect_anomaly():
        (dist.log_prob(joint).sum() + dist.entropy().sum()).backward()
    grad = logits.grad.reshape(12, -1)
    inside = joint_slice_mask(choosing, running, available, counts).reshape(12, -1)
    assert torch.isfinite(grad).all()
    assert torch.all(grad[~inside] == 0)
    # Rows whose slice holds more than one joint option do learn inside the slice.
    wide = inside.sum(dim=1) > 1
    assert torch.all(grad[wide].abs().sum(dim=1) > 0)


def test_fully_determined_slice_is_nan_free():
    counts = (3, 3, 6)
    logits = torch.randn(2, *counts, requires_grad=True)
    available = torch.zeros(2, 12, dtype=torch.bool)
    available[:, 1] = available[:, 3] = available[:, 6 + 5] = True
    choosing = torch.tensor([[True, True, True], [True, False, True]])
    running = torch.tensor([[-1, -1, -1], [0, 2, 0]])
    dist = ConditionalJoint(logits, choosing, running, available)
    assert torch.equal(dist.sample(), torch.tensor([[1, 0, 5], [1, 2, 5]]))
    assert torch.equal(dist.mode(), torch.tensor([[1, 0, 5], [1, 2, 5]]))
    assert torch.equal(dist.entropy(), torch.zeros(2))
    (dist.entropy().sum() + dist.log_prob(dist.mode()).sum()).backward()
    assert torch.equal(logits.grad, torch.zeros_like(logits))


def test_undefined_conditions_are_rejected():
    logits = torch.randn(1, 3, 6)
    no_option = torch.tensor([[True, True, True, False, False, False, False, False, False]])
    with pytest.raises(ValueError, match="agent 1"):
        conditional_log_probs(
            logits, torch.tensor([[True, True]]), torch.tensor([[0, 0]]), no_option
        )
    with pytest.raises(ValueError, match="agent 0"):
        conditional_log_probs(
            logits, torch.tensor([[False, True]]), torch.tensor([[-1, 0]]), torch.ones(1, 9)
        )


def test_ravel_unravel_round_trip():
    counts = (2, 3, 2, 4)
    flat = torch.arange(math.prod(counts))
    joint = unravel_joint(flat, counts)
    assert joint.shape == (48, 4)
    assert torch.equal(ravel_joint(joint, counts), flat)
    assert joint[-1].tolist() == [1, 2, 1, 3]
    assert torch.equal(joint, torch.tensor(list(itertools.product(*(range(k) for k in counts)))))


@pytest.mark.parametrize("counts", OPTION_COUNTS)
def test_partial_marginals_match_brute_force(counts):
    logits, choosing, running, available = random_case(counts, batch=16, seed=8)
    gen = torch.Generator().manual_seed(9)
    agent_logits = [logits] + [
        2.0 * torch.randn(logits.shape, generator=gen, dtype=torch.float64) for _ in counts[1:]
    ]
    log_probs = partial_conditional_log_probs(agent_logits, choosing, running, available)
    for i, k in enumerate(counts):
        assert log_probs[i].shape == (16, k)
        torch.testing.assert_close(
            log_probs[i].exp().sum(dim=1), torch.ones(16, dtype=torch.float64)
        )
    for b in range(16):
        expected = brute_force_partial(
            [al[b] for al in agent_logits], choosing[b], running[b], available[b], counts
        )
        for i in range(len(counts)):
            np.testing.assert_allclose(log_probs[i][b].exp().numpy(), expected[i], atol=1e-12)
            if not choosing[b, i]:  # continuing agents keep their option with probability 1
                assert log_probs[i][b, running[b, i]].item() == 0.0


def test_partial_distribution_samples_and_scores_independent_agents():
    counts = (3, 3, 6)
    logits, choosing, running, available = random_case(counts, batch=3, seed=10)
    gen = torch.Generator().manual_seed(11)
    agent_logits = [torch.randn(logits.shape, generator=gen, dtype=torch.float64) for _ in counts]
    repeats = 30_000
    rep = [t.repeat_interleave(repeats, 0) for t in (choosing, running, available)]
    dist = FactoredConditional(
        partial_conditional_log_probs(
            [a.repeat_interleave(repeats, 0) for a in agent_logits], *rep
        ),
        rep[0],
        rep[1],
    )
    joint = dist.sample(torch.Generator().manual_seed(12))
    assert torch.equal(joint[~rep[0]], rep[1][~rep[0]])
    log_prob, entropy = dist.log_prob(joint), dist.entropy()
    flat = ravel_joint(joint, counts).view(3, repeats)
    for b in range(3):
        marginals = brute_force_partial(
            [a[b] for a in agent_logits], choosing[b], running[b], available[b], counts
        )
        # Agents choose independently: the joint is the product of the per-agent conditionals.
        p = np.einsum("i,j,k->ijk", *marginals).reshape(-1)
        freq = np.bincount(flat[b].numpy(), minlength=p.size) / repeats
        assert np.all(freq[p == 0] == 0)
        assert np.all(np.abs(freq - p) <= 5 * np.sqrt(p * (1 - p) / repeats) + 1e-4)
        row = b * repeats
        chosen = [i for i in range(3) if choosing[b, i]]
        expected_lp = sum(math.log(marginals[i][joint[row, i]]) for i in chosen)
        assert log_prob[row].item() == pytest.approx(expected_lp)
        expected_h = sum(
            -(m[m > 0] * np.log(m[m > 0])).sum() for m in (marginals[i] for i in chosen)
        )
        assert entropy[row].item() == pytest.approx(expected_h)


@pytest.mark.filterwarnings("ignore:Anomaly Detection has been enabled")
@pytest.mark.parametrize("counts", OPTION_COUNTS)
def test_partial_gradients_reach_only_the_slice(counts):
    logits, choosing, running, available = random_case(counts, batch=12, seed=13)
    agent_logits = [logits.clone().requires_grad_(True) for _ in counts]
    dist = FactoredConditional(
        partial_conditional_log_probs(agent_logits, choosing, running, available), choosing, running
    )
    joint = dist.sample(torch.Generator().manual_seed(2))
    # Anomaly mode fails on a NaN produced anywhere in the backward pass, even one that a later
    # masked_fill would zero: the -inf handling must be NaN-free throughout.
    with torch.autograd.detect_anomaly():
        (dist.log_prob(joint).sum() + dist.entropy().sum()).backward()
    inside = joint_slice_mask(choosing, running, available, counts)
    for i, al in enumerate(agent_logits):
        assert torch.isfinite(al.grad).all()
        assert torch.all(al.grad[~inside] == 0)
        # A continuing agent's policy gets no gradient at that decision point.
        assert torch.all(al.grad[~choosing[:, i]] == 0)
