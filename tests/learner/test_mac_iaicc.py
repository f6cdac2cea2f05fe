"""Mac-IAICC and its siblings against hand-worked cases: each agent's macro-actions and their
targets over interleaved decisions, which points each critic reads, the naive advantage, and a
round and update of each on the real Box Pushing grid task."""

import dataclasses

import numpy as np
import pytest
import torch

from maopg.env import make_env
from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.learner.mac_iaicc import (
    HistoryCritics,
    MacIAICCConfig,
    MacIAICCLearner,
    StateCritics,
    macro_steps,
    n_step_targets,
)
from maopg.learner.rounds import Episodes, collect_round
from maopg.policy import ObsBatch
from maopg.policy.agent_centric import AgentCentricPolicy

GAMMA = 0.9


def _episode() -> Episodes:
    """One episode of two agents: points at ticks 0, 2, 5 and the final point at 6 (terminal);
    agent 0 chooses at the first two, agent 1 at the first and third; the steps from them
    carry discounted rewards 1, 2 and 4."""
    choosing = torch.tensor([[[True, True]], [[True, False]], [[False, True]], [[True, True]]])
    return Episodes(
        obs=ObsBatch(torch.zeros(4, 10), ticks=torch.tensor([0, 2, 5, 6])),
        choosing=choosing,
        running=torch.zeros(4, 1, 2, dtype=torch.int64),
        available=torch.ones(4, 1, 16, dtype=torch.bool),
        joint=torch.zeros(4, 1, 2, dtype=torch.int64),
        reward=np.array([[1.0], [2.0], [4.0], [0.0]]),
        reward_sum=np.array([[1.0], [2.0], [4.0], [0.0]]),
        duration=np.array([[2], [3], [1], [1]]),
        terminated=np.array([True]),
        length=np.array([3]),
    )


def test_each_agents_macro_actions_span_its_own_decisions():
    g = GAMMA
    first = macro_steps(_episode(), 0, g)
    assert list(first.rows) == [0, 1] and list(first.next_rows) == [1, 3]
    assert first.reward == pytest.approx([1.0, 2.0 + g**3 * 4.0])
    assert first.discount == pytest.approx([g**2, g**4])
    assert list(first.terminal) == [False, True]
    assert first.weight == pytest.approx([g**1, g**5])  # γ to the index of its last tick
    assert list(first.team_rows) == [0, 2]
    second = macro_steps(_episode(), 1, g)
    assert list(second.rows) == [0, 2] and list(second.next_rows) == [2, 3]
    assert second.reward == pytest.approx([1.0 + g**2 * 2.0, 4.0])
    assert second.discount == pytest.approx([g**5, g**1])
    assert list(second.team_rows) == [1, 2]


def test_n_step_targets_sum_n_macro_actions_then_bootstrap_within_each_episode(setup_for):
    """Three steps of episode 0 (the last one terminal: bootstrap 0) and two of episode 1 (a
    timeout: its last step bootstraps), worked by hand for n = 1, 2 and 5."""
    reward = np.array([1.0, 2.0, 4.0, 8.0, 16.0])
    discount = np.array([0.5, 0.25, 0.5, 0.5, 0.5])
    bootstrap = np.array([10.0, 20.0, 0.0, 40.0, 80.0])
    episode = np.array([0, 0, 0, 1, 1])
    one = n_step_targets(reward, discount, bootstrap, episode, 1)
    assert one == pytest.approx(reward + discount * bootstrap)
    two = n_step_targets(reward, discount, bootstrap, episode, 2)
    assert two == pytest.approx(
        [
            1.0 + 0.5 * 2.0 + 0.5 * 0.25 * 20.0,
            2.0 + 0.25 * 4.0 + 0.25 * 0.5 * 0.0,
            4.0 + 0.5 * 0.0,  # the episode's last step: it stops and bootstraps there
            8.0 + 0.5 * 16.0 + 0.25 * 80.0,
            16.0 + 0.5 * 80.0,
        ]
    )
    five = n_step_targets(reward, discount, bootstrap, episode, 5)
    assert five[0] == pytest.approx(1.0 + 0.5 * 2.0 + 0.125 * 4.0)  # Monte Carlo to the end
    assert five[3] == pytest.approx(two[3])


@pytest.fixture
def envs():
    envs = SeededVectorEnv(
        EnvConfig(task="box_pushing_grid", strategy="continue"), num_envs=4, seed=2
    )
    envs.reset()
    yield envs
    envs.close()


def _learner(setup_for, envs: SeededVectorEnv, critic: str) -> MacIAICCLearner:
    torch.manual_seed(0)
    config = MacIAICCConfig(critic=critic, episodes_per_update=2)
    policy = AgentCentricPolicy(envs.spec, embed_time=False, head_norm=False)
    return MacIAICCLearner(policy, setup_for(envs, config))


def test_a_centralized_critic_reads_every_team_point_and_an_own_critic_only_its_agents(
    setup_for, envs
):
    """Changing agent 1's observation at a point where only agent 0 chose moves the team
    history critics there, and leaves agent 1's own-history critic where it was."""
    learner = _learner(setup_for, envs, "history")
    batch, _, _ = collect_round(
        envs, learner.policy, 1.0, 2, torch.Generator().manual_seed(0), torch.device("cpu")
    )
    steps, episodes = batch.choosing.shape[:2]
    rows = [
        (t, b)
        for t in range(1, steps)
        for b in range(episodes)
        if batch.choosing[t, b, 0] and not batch.choosing[t, b, 1] and t < batch.length[b]
    ]
    assert rows, "no point where agent 0 chose alone"
    t, b = rows[0]
    torch.manual_seed(0)
    history = HistoryCritics(envs.spec, "history", 32)
    own = HistoryCritics(envs.spec, "own", 32)
    before = history.values(batch, torch.device("cpu")), own.values(batch, torch.device("cpu"))
    changed = batch.obs.vectors.clone().view(steps, episodes, -1)
    changed[t, b, 5:] += 1.0  # agent 1's vector (each agent's is 5 entries)
    batch.obs = ObsBatch(changed.view(steps * episodes, -1), ticks=batch.obs.ticks)
    after = history.values(batch, torch.device("cpu")), own.values(batch, torch.device("cpu"))
    assert not torch.equal(after[0][t, b], before[0][t, b])
    assert torch.equal(after[1][t, b, 1], before[1][t, b, 1])


def test_state_critics_read_the_grids_state_at_each_point_and_nothing_else(setup_for, envs):
    """MacroMARL's Box Pushing critics (``critic=state``): the batch carries the grid's 18-float
    state at every point, each agent's critic reads it there and only there, and not the
    agents' observations."""
    assert envs.spec.state_size == 18
    learner = _learner(setup_for, envs, "state")
    assert isinstance(learner.critic, StateCritics)
    batch, _, _ = collect_round(
        envs, learner.policy, 1.0, 2, torch.Generator().manual_seed(0), torch.device("cpu")
    )
    steps, episodes = batch.choosing.shape[:2]
    states = batch.obs.states
    assert states is not None and states.shape == (steps * episodes, 18)
    # the first point's: the canonical layout's, as a fresh environment reports it at reset
    reset = make_env("box_pushing_grid", "continue").reset().state
    assert torch.equal(states.view(steps, episodes, 18)[0, 0], torch.from_numpy(reset))
    before = learner.critic.values(batch, torch.device("cpu"))
    assert before.shape == (steps, episodes, 2)
    t, b = 1, 0
    changed = states.clone().view(steps, episodes, 18)
    changed[t, b] += 0.5
    vectors = batch.obs.vectors + 1.0  # the observations: not read
    batch.obs = dataclasses.replace(
        batch.obs, vectors=vectors, states=changed.view(steps * episodes, 18)
    )
    after = learner.critic.values(batch, torch.device("cpu"))
    moved = (after != before).any(-1)
    assert moved[t, b] and moved.sum() == 1


@pytest.mark.parametrize("critic", ["history", "own", "joint", "state"])
def test_a_round_and_an_update_of_each_sibling(setup_for, envs, critic):
    learner = _learner(setup_for, envs, critic)
    before = [p.clone() for p in learner.policy.parameters()]
    row, ticks = learner.iteration(envs, 0)
    assert ticks > 0 and row["published_steps"] > 0 and row["epsilon"] == 1.0
    assert np.isfinite(row["value_loss"]) and np.isfinite(row["policy_loss"])
    # at ε = 1 the mixed policy is uniform whatever the actors say: no actor gradient
    assert all(torch.equal(a, b) for a, b in zip(before, learner.policy.parameters(), strict=True))
    learner.episodes = 2_000  # ε about one half
    row, _ = learner.iteration(envs, ticks)
    assert any(
        not torch.equal(a, b) for a, b in zip(before, learner.policy.parameters(), strict=True)
    )


@pytest.mark.parametrize("critic", ["history", "own"])
def test_from_cameras_the_critics_read_the_images_they_should(setup_for, critic):
    """Tool Delivery from RGB: a centralized critic's CNN reads every robot's camera, an own
    critic's its robot's; a round and an update run through them."""
    config = EnvConfig(
        task="tool_delivery", strategy="continue", images=True, overrides={"max_ticks": 30}
    )
    envs = SeededVectorEnv(config, num_envs=2, seed=0)
    try:
        envs.reset()
        learner = _learner(setup_for, envs, critic)
        assert all(net.cnn is not None for net in learner.critic.inputs)
        before = learner.critic.inputs[0].cnn.convs[0].weight.clone()
        row, _ = learner.iteration(envs, 0)
        assert np.isfinite(row["value_loss"])
        assert not torch.equal(learner.critic.inputs[0].cnn.convs[0].weight, before)
    finally:
        envs.close()


@pytest.mark.parametrize("critic", ["history", "own", "joint"])
def test_a_target_over_more_macro_actions_than_the_episode_has_is_its_discounted_return(
    setup_for, envs, critic
):
    """With ``n_step`` beyond every episode's length, each episode's first target is its
    discounted return (plus the discounted bootstrap where a timeout cut it) on every critic,
    the Naive one's team steps included; with 1 it is the one-step target."""
    learner = _learner(setup_for, envs, critic)
    batch, _, _ = collect_round(
        envs, learner.policy, 1.0, 2, torch.Generator().manual_seed(0), torch.device("cpu")
    )
    agents = 1 if critic == "joint" else 2
    steps = [macro_steps(batch, i, 0.98) for i in range(2)]
    with torch.no_grad():
        target_values = learner.target.values(batch, torch.device("cpu")).numpy()
    ticks = batch.obs.ticks.view(batch.choosing.shape[:2]).numpy()
    learner.config = dataclasses.replace(learner.config, n_step=10_000)
    long = learner._targets(batch, steps)
    learner.config = dataclasses.replace(learner.config, n_step=1)
    one = learner._targets(batch, steps)
    for b, length in enumerate(batch.length):
        discounted = sum(0.98 ** ticks[t, b] * batch.reward[t, b] for t in range(length))
        for i in range(agents):
            tail = 0.0 if batch.terminated[b] else 0.98 ** ticks[length, b]
            expected = discounted + tail * target_values[length, b, i]
            assert float(
                long[i][0, b] if critic == "joint" else long[i][steps[i].episodes == b][0]
            ) == pytest.approx(expected, rel=1e-5)
    s = steps[0]
    if critic != "joint":
        boot = np.where(s.terminal, 0.0, target_values[s.next_rows, s.episodes, 0])
        assert one[0].numpy() == pytest.approx(s.reward + s.discount * boot, rel=1e-5)
