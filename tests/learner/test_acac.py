"""ACAC's pieces against hand-worked cases, on the real Box Pushing grid task: the event-based
time embedding, the asynchronous (event) GAE, the agent-centric memories that advance only at
their own agent's decisions, the critic's inputs there, PopArt, ε-mixing and the round."""

import dataclasses
import math

import numpy as np
import pytest
import torch

from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.env.vector_base import StepResult
from maopg.learner import ACACConfig, ACACLearner, compute_gae
from maopg.learner.acac import cut_short
from maopg.policy import ObsBatch, stack_conditions
from maopg.policy.agent_centric import (
    AgentCentricCritic,
    AgentCentricPolicy,
    PopArt,
    advance,
    scan,
    time_embedding,
)

CONFIG = EnvConfig(task="box_pushing_grid", strategy="continue")


@pytest.fixture
def envs():
    envs = SeededVectorEnv(CONFIG, num_envs=4, seed=3)
    envs.reset()
    yield envs
    envs.close()


def _learner(setup_for, envs: SeededVectorEnv, **settings) -> ACACLearner:
    torch.manual_seed(0)
    config = ACACConfig(**settings)
    return ACACLearner(AgentCentricPolicy(envs.spec, width=config.width), setup_for(envs, config))


def test_the_time_embedding_reads_the_tick_an_observation_came_at():
    """τ = ticks + 1 in radians, as the published table of width 2 (frequency 1)."""
    got = time_embedding(torch.tensor([0, 4, 99]))
    for row, tau in zip(got, (1, 5, 100), strict=True):
        assert torch.allclose(row, torch.tensor([math.sin(tau), math.cos(tau)]))


def test_the_event_gae_decays_lambda_once_per_decision():
    """Two decision points of 3 and 2 ticks, then a timeout bootstrapped from V = 4, worked
    by hand: δ_t = R_t + γ^k V' − V, A_t = δ_t + γ^k λ A_{t+1}."""
    gamma, lam = 0.9, 0.5
    values = np.array([[1.0], [2.0]])
    next_values = np.array([[2.0], [4.0]])
    rewards = np.array([[1.5], [0.5]])
    durations = np.array([[3], [2]])
    advantages, returns = compute_gae(
        values=values,
        next_values=next_values,
        reward_sum=rewards,
        reward_discounted=rewards,
        durations=durations,
        terminated=np.zeros((2, 1), bool),
        continues=np.array([[True], [False]]),
        gamma=gamma,
        lam=lam,
        form="event",
    )
    delta1 = 0.5 + 0.9**2 * 4.0 - 2.0
    delta0 = 1.5 + 0.9**3 * 2.0 - 1.0
    assert advantages[1, 0] == pytest.approx(delta1)
    assert advantages[0, 0] == pytest.approx(delta0 + 0.9**3 * 0.5 * delta1)
    assert returns[:, 0] == pytest.approx(advantages[:, 0] + values[:, 0])


def test_an_agents_memory_advances_only_at_its_own_decisions(envs):
    """Actor and critic alike: a step where agent 1 continues leaves its state as it was, and
    agent 0's moves; the actor's continuing agent keeps its running option."""
    torch.manual_seed(0)
    policy = AgentCentricPolicy(envs.spec)
    critic = AgentCentricCritic(envs.spec)
    obs = ObsBatch.from_decision_points(envs.points[:1])
    choosing, running, available = stack_conditions(envs.points[:1])
    state = torch.randn(1, 2, 32)
    continuing = torch.tensor([[True, False]])
    running = torch.tensor([[-1, 3]])
    dist, after = policy.step(obs, continuing, running, available, state, torch.tensor([False]))
    assert torch.equal(after[:, 1], state[:, 1]) and not torch.equal(after[:, 0], state[:, 0])
    assert dist.sample(torch.Generator().manual_seed(0))[0, 1] == 3
    _, after = critic.step(obs, continuing, state, torch.tensor([False]))
    assert torch.equal(after[:, 1], state[:, 1]) and not torch.equal(after[:, 0], state[:, 0])
    _, fresh = critic.step(obs, choosing, state, torch.tensor([True]))  # a start zeroes both
    _, zeroed = critic.step(obs, choosing, torch.zeros_like(state), torch.tensor([False]))
    assert torch.equal(fresh, zeroed)


def test_the_critic_reads_each_agents_latest_encoding_along_an_episode(setup_for, envs):
    """``scan`` over a collected round's points gives, at every point, the value that stepping
    the critic point by point gives: each agent's token is its encoder's state after its own
    latest decision."""
    learner = _learner(setup_for, envs, episodes_per_update=2)
    batch, _, _ = learner.collect(envs, 0.5)
    critic = learner.critic
    with torch.no_grad():
        along = learner._values(critic, batch)
        steps, width = batch.choosing.shape[:2], critic.width
        state = torch.zeros(steps[1], 2, width)
        for t in range(steps[0]):
            rows = torch.arange(t * steps[1], (t + 1) * steps[1])
            value, state = critic.step(batch.obs[rows], batch.choosing[t], state, batch.starts[t])
            valid = t <= torch.from_numpy(batch.length)
            assert torch.allclose(along[t][valid], value[valid], atol=1e-6)
        states = scan(
            critic.cells,
            [net(batch.obs) for net in critic.inputs],
            batch.choosing,
            batch.starts,
            critic.initial_state(steps[1]),
        )
    assert states.shape == (*steps, 2, width)


@pytest.mark.parametrize("seed", range(6))
def test_scan_agrees_with_advancing_point_by_point(seed):
    """``scan`` runs each agent's cell over its own events only; it gives the states and the
    gradients of :func:`advance` applied at every point: across several starts in one
    sequence, an agent that never chooses in a segment, and a carried-in state before a
    sequence's first start."""
    gen = torch.Generator().manual_seed(seed)
    steps, batch, agents, width = 30, 4, 3, 8
    torch.manual_seed(seed)
    cells = torch.nn.ModuleList(torch.nn.GRUCell(width, width) for _ in range(agents))
    inputs = [torch.randn(steps * batch, width, generator=gen) for _ in range(agents)]
    for x in inputs:
        x.requires_grad_(True)
    choosing = torch.rand(steps, batch, agents, generator=gen) < 0.4
    starts = torch.rand(steps, batch, generator=gen) < 0.15
    starts[0, ::2] = True  # columns 1 and 3 carry ``state`` in until their first start
    choosing[10:20, 0, 2] = False
    starts[10, 0] = True  # agent 2 has no event in column 0's segment from point 10
    state = torch.randn(batch, agents, width, generator=gen, requires_grad=True)

    expected, current = [], state
    for t in range(steps):
        current = current.masked_fill(starts[t].view(-1, 1, 1), 0.0)
        rows = slice(t * batch, (t + 1) * batch)
        current = advance(cells, [x[rows] for x in inputs], current, choosing[t])
        expected.append(current)
    expected = torch.stack(expected)
    got = scan(cells, inputs, choosing, starts, state)

    assert torch.allclose(got, expected, atol=1e-6)
    assert torch.equal(got[12, 0, 2], torch.zeros(width))  # zeroed at 10, no event since
    wrt = [state, *inputs, *cells.parameters()]
    for a, b in zip(
        torch.autograd.grad(expected.square().sum(), wrt),
        torch.autograd.grad(got.square().sum(), wrt),
        strict=True,
    ):
        assert torch.allclose(a, b, atol=1e-5)


def test_popart_keeps_every_output_while_its_statistics_move():
    torch.manual_seed(0)
    head = PopArt(8, beta=0.9)
    x = torch.randn(5, 8)
    before = head.denormalize(head(x))
    head.update(torch.tensor([100.0, 250.0, -10.0]))
    assert torch.allclose(head.denormalize(head(x)), before, atol=1e-4)
    mean, std = head.stats()
    assert mean == pytest.approx(340.0 / 3, rel=1e-4)  # debiased: the one batch's own mean
    assert std > 1.0


def test_a_round_trains_on_the_last_finished_episodes_and_counts_them(setup_for, envs):
    learner = _learner(setup_for, envs, episodes_per_update=3)
    batch, finished, ticks = learner.collect(envs, 1.0)
    assert len(finished) >= 3 and batch.choosing.shape[1] == 3
    assert ticks >= sum(e["ticks"] for e in finished)  # unfinished episodes' ticks count too
    # the round ran until the tick of the third finish had passed in every environment: the
    # earliest finishes of the round are its first episodes, whose round tick is their length
    third = sorted(e["ticks"] for e in finished)[2]
    assert ticks >= envs.num_envs * third
    lengths = batch.length
    assert (lengths >= 1).all() and batch.choosing.shape[0] == lengths.max() + 1
    # every agent chooses at an episode's first point, and rows after the final point are padding
    assert batch.choosing[0].all() and not batch.steps[lengths, np.arange(3)].any()
    row, _ = learner.iteration(envs, 0)
    assert row["epsilon"] == 1.0 and row["published_steps"] == learner.published_steps > 0
    assert learner.config.exploration(15_000) == pytest.approx(0.505)
    assert learner.config.exploration(10**6) == pytest.approx(0.01)


class _Recorded(SeededVectorEnv):
    """The real vector environment, recording each finish as (round tick, environment, return,
    ticks) and, before each step, the round tick every environment had passed: the ground truth
    a round is checked against."""

    def restart(self) -> None:
        super().restart()
        self.elapsed = np.zeros(self.num_envs, dtype=np.int64)
        self.finishes: list[tuple[int, int, float, int]] = []
        self.passed: list[int] = []

    def step(self, joints: np.ndarray) -> list[StepResult]:
        self.passed.append(int(self.elapsed.min()))
        results = super().step(joints)
        for e, result in enumerate(results):
            self.elapsed[e] += result.outcome.duration
            if result.final is not None:
                info = result.final.info["episode"]
                self.finishes.append((int(self.elapsed[e]), e, info["return"], info["ticks"]))
        return results


def test_a_round_keeps_every_finish_by_the_cutoff_tick_and_trains_on_the_last(setup_for):
    """ACAC's published protocol (32 environments, 16 episodes), tick by tick: the round's
    cutoff is the tick of the 16th earliest finish; every episode finished by then counts (more
    than 16 where several finish at that tick), the batch is the last 16 of them by tick then
    environment, the rest are dropped, and the published counter adds exactly the counted
    episodes' ticks."""
    envs = _Recorded(CONFIG, num_envs=32, seed=5)
    envs.reset()
    learner = _learner(setup_for, envs, episodes_per_update=16)
    batch, finished, ticks = learner.collect(envs, 1.0)
    for e in range(envs.num_envs):  # an environment's round ticks are its episodes' lengths
        mine = [f for f in envs.finishes if f[1] == e]
        assert [f[0] for f in mine] == list(np.cumsum([f[3] for f in mine]))
    cutoff = sorted(f[0] for f in envs.finishes)[15]
    counted = sorted((f for f in envs.finishes if f[0] <= cutoff), key=lambda f: (f[0], f[1]))
    assert len(counted) > 16  # a tie at the cutoff: every one of them counts
    assert [(e["return"], e["ticks"]) for e in finished] == [(f[2], f[3]) for f in counted]
    assert any(f[0] > cutoff for f in envs.finishes)  # finishes after the cutoff are dropped
    # it stops as soon as every environment has passed the cutoff, and not before
    assert envs.passed[-1] < cutoff <= envs.elapsed.min() and ticks == envs.elapsed.sum()
    steps = batch.steps.numpy()
    assert np.allclose(batch.reward_sum.sum(axis=0), [f[2] for f in counted[-16:]])
    assert [int(batch.duration[steps[:, b], b].sum()) for b in range(16)] == [
        f[3] for f in counted[-16:]
    ]
    before = learner.published_steps
    learner.iteration(envs, 0)  # a second round, recorded afresh
    cutoff = sorted(f[0] for f in envs.finishes)[15]
    added = learner.published_steps - before
    assert added == sum(f[3] for f in envs.finishes if f[0] <= cutoff)
    envs.close()


def test_at_full_exploration_the_ratio_is_one_whatever_the_actors_say(setup_for, envs):
    """ε = 1: every choosing agent draws uniformly, old and new probabilities are the
    uniform's whatever the weights, so the surrogate's ratio is exactly 1."""
    learner = _learner(setup_for, envs, episodes_per_update=2)
    batch, _, _ = learner.collect(envs, 1.0)
    old, _ = learner.agent_log_probs(batch, 1.0)
    for parameter in learner.policy.parameters():
        parameter.data.add_(torch.randn_like(parameter))
    new, _ = learner.agent_log_probs(batch, 1.0)
    deciding = batch.choosing & batch.steps.unsqueeze(-1)
    for i in range(2):
        assert torch.allclose(new[i][deciding[..., i]], old[i][deciding[..., i]])
        assert torch.allclose(new[i][deciding[..., i]], torch.tensor(-math.log(8)))


def test_an_update_moves_only_the_actors_of_agents_that_decided(setup_for, envs):
    """Each actor's loss reads its own decisions only: an agent masked out of every decision
    of the batch keeps its weights, the other's change."""
    learner = _learner(setup_for, envs, episodes_per_update=2)
    batch, _, _ = learner.collect(envs, 0.3)
    batch.choosing[..., 1] = False
    batch.running[..., 1] = batch.running[..., 1].clamp(min=0)  # a continuing agent's option
    before = [p.clone() for p in learner.policy.heads[1].parameters()]
    moved = [p.clone() for p in learner.policy.heads[0].parameters()]
    learner.update(batch, 0.3)
    kept, changed = (list(learner.policy.heads[i].parameters()) for i in (1, 0))
    assert all(torch.equal(a, b) for a, b in zip(before, kept, strict=True))
    assert any(not torch.equal(a, b) for a, b in zip(moved, changed, strict=True))


def test_from_cameras_each_agent_reads_its_own_image(setup_for):
    """From RGB (Tool Delivery, three robots of two kinds): each actor and critic encoder has a
    CNN of its own over its agent's camera, and a round and an update run through them."""
    config = EnvConfig(
        task="tool_delivery", strategy="continue", images=True, overrides={"max_ticks": 30}
    )
    envs = SeededVectorEnv(config, num_envs=2, seed=0)
    try:
        envs.reset()
        learner = _learner(setup_for, envs, episodes_per_update=1)
        assert all(net.cnn is not None for net in learner.policy.inputs)
        assert all(net.cnn is not None for net in learner.critic.inputs)
        batch, finished, _ = learner.collect(envs, 0.5)
        assert batch.obs.images is not None and len(finished) >= 1
        before = learner.policy.inputs[0].cnn.convs[0].weight.clone()
        stats = learner.update(batch, 0.5)
        assert math.isfinite(stats["policy_loss"]) and math.isfinite(stats["value_loss"])
        assert not torch.equal(learner.policy.inputs[0].cnn.convs[0].weight, before)
    finally:
        envs.close()


def _interleaved(learner: ACACLearner, envs: SeededVectorEnv, ended: tuple[int, int] = (1, 1)):
    """One collected episode cut to four steps whose decisions interleave as asynchronous
    options make them: both agents choose at the start (tick 0), agent 1 alone at tick 2, agent
    0 alone at tick 3, agent 1 alone at tick 5, and the episode ends at tick 6 in a terminal
    state, with the options ``ended`` marks ending there; the continuing agent keeps the option
    it runs."""
    batch, _, _ = learner.collect(envs, 0.5)
    rows = slice(0, 5)
    choosing = torch.tensor([[1, 1], [0, 1], [1, 0], [0, 1], list(ended)], dtype=torch.bool)
    joint = batch.joint[rows, :1].clone()
    running = torch.full((5, 1, 2), -1, dtype=torch.long)
    for t in range(1, 5):
        for i in range(2):
            if not choosing[t, i]:
                running[t, 0, i] = joint[t, 0, i] = joint[t - 1, 0, i]
    rewards = np.array([[-0.2], [-0.1], [-0.2], [299.9], [0.0]])
    return dataclasses.replace(
        batch,
        obs=batch.obs[torch.arange(5)],
        choosing=choosing.unsqueeze(1),
        running=running,
        available=torch.ones(5, 1, 16, dtype=torch.bool),  # 8 options an agent
        joint=joint,
        reward=rewards,
        reward_sum=rewards,
        duration=np.array([[2], [1], [2], [1], [1]]),  # the final point: filler
        terminated=np.array([True]),
        length=np.array([4]),
    )


def test_interleaved_decisions_share_each_points_advantage_and_each_actor_reads_its_own(
    setup_for, envs, monkeypatch
):
    """The asynchronous GAE on an episode whose agents decide at different ticks, worked by
    hand (γ = 0.98, λ = 0.95, the target critic's values V = 1, 2, 3, 4 at the four steps):
    δ_t = R_t + γ^k_t V_{t+1} − V_t with k_t the ticks to the next decision point (the
    terminal's value 0), A_t = δ_t + γ^k_t λ A_{t+1}: one advantage per decision point, whoever
    chose there. The first update's surrogate (ratio 1: old and new weights alike) is then, for
    each actor, minus the mean advantage over its own decisions only: agent 0's at ticks 0 and
    3, agent 1's at ticks 0, 2 and 5."""
    learner = _learner(setup_for, envs, episodes_per_update=1, train_repeat=1)
    batch = _interleaved(learner, envs)
    losses = _hand_worked(learner, monkeypatch)
    g, lam = 0.98, 0.95
    d3 = 299.9 + 0.0 - 4.0
    d2 = -0.2 + g**2 * 4.0 - 3.0
    d1 = -0.1 + g**1 * 3.0 - 2.0
    d0 = -0.2 + g**2 * 2.0 - 1.0
    a3 = d3
    a2 = d2 + g**2 * lam * a3
    a1 = d1 + g**1 * lam * a2
    a0 = d0 + g**2 * lam * a1
    advantages, returns = learner.advantages(batch)
    assert advantages[:4, 0] == pytest.approx([a0, a1, a2, a3])
    assert returns[:4, 0] == pytest.approx([a0 + 1.0, a1 + 2.0, a2 + 3.0, a3 + 4.0])

    learner.update(batch, 0.5)
    assert losses[0] == pytest.approx(-(a0 + a2) / 2, rel=1e-5)
    assert losses[1] == pytest.approx(-(a0 + a1 + a3) / 3, rel=1e-5)


def _hand_worked(learner: ACACLearner, monkeypatch) -> dict[int, float]:
    """The critic's values of the hand-worked episode (V = 1 … 5 along its points, in return
    units); returns the dict the next update's actor losses land in, critic and actors left
    unstepped."""
    values = torch.tensor([[1.0], [2.0], [3.0], [4.0], [5.0]])
    monkeypatch.setattr(learner, "_values", lambda critic, batch: values)
    monkeypatch.setattr(learner.target.value_head, "denormalize", lambda v: v)
    losses: dict[int, float] = {}
    monkeypatch.setattr(learner, "step_critic", lambda loss: None)
    monkeypatch.setattr(
        learner, "step_actors", lambda got: losses.update({i: v.item() for i, v in got.items()})
    )
    return losses


@pytest.mark.parametrize("form", ["train", "drop"])
def test_a_decision_the_episodes_end_cut_short_is_trained_on_or_dropped(
    setup_for, envs, monkeypatch, form
):
    """The hand-worked episode with agent 1's option of tick 5 still running when the episode
    ends at tick 6 (the final point's ``choosing`` false for it): that decision, and only that
    one, is cut short. ``acac.cut_decisions=train`` (the paper's description) keeps it in agent
    1's loss, ``drop`` (ACAC's code) leaves it out; agent 0's decisions both ended and count
    either way. With both options ending at the final point nothing is cut."""
    learner = _learner(setup_for, envs, episodes_per_update=1, train_repeat=1, cut_decisions=form)
    assert not cut_short(_interleaved(learner, envs)).any()
    batch = _interleaved(learner, envs, ended=(1, 0))
    assert cut_short(batch)[:, 0].nonzero().tolist() == [[3, 1]]
    losses = _hand_worked(learner, monkeypatch)
    advantages, _ = learner.advantages(batch)
    a0, a1, a2, a3 = advantages[:4, 0]
    learner.update(batch, 0.5)
    assert losses[0] == pytest.approx(-(a0 + a2) / 2, rel=1e-5)
    mine = [a0, a1, a3] if form == "train" else [a0, a1]
    assert losses[1] == pytest.approx(-sum(mine) / len(mine), rel=1e-5)


def test_the_last_steps_target_is_the_advantage_alone_in_the_codes_form(
    setup_for, envs, monkeypatch
):
    """``acac.last_target=advantage`` (ACAC's code, whose value at an episode's last step is
    left at 0): the critic's target there is ``A`` instead of ``A + V``, every other step's and
    every advantage as in the description's form."""
    targets = {}
    for form in ("return", "advantage"):
        learner = _learner(setup_for, envs, episodes_per_update=1, last_target=form)
        batch = _interleaved(learner, envs)
        _hand_worked(learner, monkeypatch)
        targets[form] = learner.advantages(batch)
    (adv, ret), (adv_code, ret_code) = targets["return"], targets["advantage"]
    assert adv_code[:4, 0] == pytest.approx(adv[:4, 0])
    assert ret_code[:3, 0] == pytest.approx(ret[:3, 0])
    assert ret[3, 0] == pytest.approx(adv[3, 0] + 4.0) and ret_code[3, 0] == pytest.approx(
        adv[3, 0]
    )
