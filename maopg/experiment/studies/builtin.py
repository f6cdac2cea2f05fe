"""The committed studies: the paper's comparison and the questions asked of it since.

Each is registered by name (:func:`~maopg.experiment.studies.registry.register_study`) and
reproduced by ``python -m eval reproduce --study NAME``; its runs and results live in
``results/<name>/`` (the paper's in ``results/runs`` and ``results/``).
"""

from __future__ import annotations

from dataclasses import replace
from functools import partial
from typing import Any

from maopg.experiment.studies.registry import (
    PAPER,
    Settings,
    Study,
    StudyTask,
    frozen,
    register_study,
)

TOOL_DELIVERY_THRESHOLD = 200.0
"""77% of the scripted policy's 259 (docs/DESIGN.md §7): a policy that delivers all three tools
with little waste."""
WATER_FILLING_THRESHOLD = -300_000.0
"""Near the scripted heuristic (about −2.9e5; random options about −4.5e5:
``results/evaluation.md``). Eq. 6 charges about −1000 per tick per dry jar, so the paper's −304
(another simulator and metric) is not comparable."""

PAPER_METHODS = ("async", "sync-cut", "sync-wait", "end2end", "mac-dqn", "partial")
"""The paper's method and its baselines, in the order of its tables (docs/DESIGN.md §6)."""


def _paper() -> Study:
    """The paper's comparison on its two tasks at their default settings.

    Tool Delivery: 5 seeds. Water Filling: a run (RGB, 200K samples) takes 15–55 min on 2
    cores, hence 3 seeds. Mac-DQN's replay rows hold each robot's 64 px image before and after
    the option step (2 × 2 × 12 KB) and the replay is saved in every checkpoint: 10K rows ≈
    0.5 GB, where the default 50K would be ≈ 2.5 GB per run.
    """
    return Study(
        PAPER,
        "the paper's comparison: its method and baselines on its two tasks",
        (
            StudyTask("tool_delivery", (0, 1, 2, 3, 4), threshold=TOOL_DELIVERY_THRESHOLD),
            StudyTask(
                "water_filling",
                (0, 1, 2),
                method_overrides=frozen({"mac-dqn": frozen({"dqn.buffer_size": 10_000})}),
                threshold=WATER_FILLING_THRESHOLD,
            ),
        ),
        PAPER_METHODS,
    )


TEAM_OF_EIGHT = {
    "tool_delivery": {"turtlebots": 6, "fetches": 2, "humans": 3},
    "water_filling": {"vehicles": 4, "drones": 4, "jars": 8},
}
"""Teams of eight robots: 15.3M joint options on Tool Delivery, 9.8·10⁹ on Water Filling,
where only the factored policies fit (``bench/perf/policy_scaling.py``)."""


def _teams() -> Study:
    """Teams of eight: the at-scale methods against the scripted and random references at the
    same size. Tool Delivery trains for 1M samples. Water Filling trains from state: the
    question is the team size, and its eight cameras would triple the cost of every sample.

    Tool Delivery's team plays with ``mask_options``: each option keeps to its initiation set
    (no pass with nothing staged, no search that cannot find a tool); under the canonical rules
    ``async-ar`` never delivers a tool at this size (study ``teams-canonical``). The references
    are measured at the same settings, masks included, so the normalised score compares like
    with like."""
    td = {**TEAM_OF_EIGHT["tool_delivery"], "mask_options": True}
    wf = TEAM_OF_EIGHT["water_filling"]
    return Study(
        "teams",
        "teams of eight robots: async-ar, partial-ar, sync-cut-ar, normalised scores",
        (
            StudyTask(
                "tool_delivery",
                (0, 1, 2),
                frozen(td),
                frozen({"total_samples": 1_000_000}),
                threshold=TOOL_DELIVERY_THRESHOLD,
            ),
            StudyTask(
                "water_filling",
                (0, 1, 2),
                frozen(wf),
                frozen({"images": False}),
                threshold=WATER_FILLING_THRESHOLD,
            ),
        ),
        ("async-ar", "partial-ar", "sync-cut-ar"),
        normalised=True,
    )


def _teams_canonical() -> Study:
    """The control of ``teams`` on Tool Delivery: its team of eight and budget under the
    canonical rules, where every option can be chosen at any time (no ``mask_options``): does
    ``async-ar`` still reach 0.8 of the scripted heuristic in 1M samples without the initiation
    sets?"""
    return Study(
        "teams-canonical",
        "async-ar on the Tool Delivery team of eight under the canonical rules (no masks)",
        (
            StudyTask(
                "tool_delivery",
                (0, 1, 2),
                frozen(TEAM_OF_EIGHT["tool_delivery"]),
                frozen({"total_samples": 1_000_000}),
                threshold=TOOL_DELIVERY_THRESHOLD,
            ),
        ),
        ("async-ar",),
        normalised=True,
    )


def _memory() -> Study:
    """Recurrent policies and critics on Water Filling from RGB (its defaults: 200K samples),
    beside the committed feed-forward runs of the same methods. Their GRUs read the option
    history and are layer-normalised (``ppo.option_history``, ``ppo.memory_norm``): without
    the norm the encoders' large features saturate the gates and the greedy policies loop."""
    return Study(
        "memory",
        "recurrent async, sync-wait and partial on Water Filling from RGB, beside the grid's",
        (StudyTask("water_filling", (0, 1, 2), threshold=WATER_FILLING_THRESHOLD),),
        ("async-rnn", "sync-wait-rnn", "partial-rnn"),
        overrides=frozen({"ppo.option_history": True, "ppo.memory_norm": True}),
        normalised=True,
        baselines=("async", "sync-wait", "partial"),
    )


def _chain_rule() -> Study:
    """The autoregressive conditional against the product categorical at the paper's size."""
    return Study(
        "chain-rule",
        "async-ar against the paper's async on Tool Delivery (state, 5 seeds, 100K samples)",
        (StudyTask("tool_delivery", (0, 1, 2, 3, 4), threshold=TOOL_DELIVERY_THRESHOLD),),
        ("async-ar",),
        baselines=("async",),
    )


BOX_PUSHING_METHODS = ("async", "partial", "async-rnn", "mac-dqn")
"""The methods compared on Box Pushing: the paper's method, its partially centralized policy,
the same with a GRU over each agent's history (an agent sees 5 bits about the cell in front of
it; the published methods all keep a history) and the value-based macro-action baseline."""
BOX_PUSHING_THRESHOLD = 200.0
"""The big box in most episodes: no episode without it pays more than 40, and it pays 300
(:data:`maopg.experiment.studies.published.BIG_BOX`, the same cut, says why)."""
LITERATURE_EVALUATION = frozen(
    {"eval_every": 2_000, "eval_during_episodes": 10, "eval_during_sample": True}
)
"""Evaluation during training as the published curves' (box-pushing reference §8): 10 episodes
sampled from the policy, every 2,000 samples. The published runs evaluate every 96 training
episodes, which is 1.1-1.3K steps on 6x6, 1.5-1.7K on 8x8 and 2.0-2.3K on 10x10 once converged
(about 3K early on, when episodes are long); one cadence keeps the studies alike, and at 2,000
a value at T (the last 5 evaluations) spans 10K samples, the published 10x10 window — twice
the 6x6 one, a little smoother there. On the published counter, which ACAC's and MacroMARL's
rounds advance by a fraction of the samples while ε is high, the same 5 span less training
than the authors' (``bench/analysis/seed_values.py --every-rounds 6`` reads ACAC's runs at the
authors' cadence instead). 250 evaluations per 500K run: at most 10 × 100 ticks
each (their cost: :func:`_box_pushing_grid`, :func:`_box_pushing_mujoco`)."""
RECURRENT_HISTORY = frozen(
    {"async-rnn": frozen({"ppo.option_history": True, "ppo.memory_norm": True})}
)
"""``async-rnn``'s GRUs read each agent's options beside its observations (the
macro-action-observation histories of the literature's methods) and are layer-normalised, as
the ``memory`` study found they must be."""
BOX_PUSHING_SIZES = (6, 8, 10)
"""The grid sizes of the published curves (``bp6``, ``bp8``, ``bp10``)."""
ACAC_COLLECTION = frozen({"num_envs": 32, "gamma": 0.98})
"""ACAC's published collection on Box Pushing (box-pushing reference §10): 32 environments in
lockstep, γ = 0.98."""
ACAC_PUBLISHED = frozen({"acac": frozen({**ACAC_COLLECTION, "total_samples": 2_500_000})})
"""ACAC as its published runs (:data:`ACAC_COLLECTION`). Its rounds throw away every unfinished
episode, and its published curves count only finished training episodes' ticks
(``published_steps``): a 6x6 pilot (seed 0) had 102K of those at 489K of maopg's samples, about
one in five while ε is still high (0.67 there), so its runs go on to 2.5M samples for the
published 500K and are read on either counter."""


FEW_EPISODES = frozen(
    {
        "acac": frozen(
            {
                "acac.episodes_per_update": 4,
                "acac.explore_decay": 50,
                "acac.clip": 0.2,
                "acac.train_repeat": 10,
                "acac.lr": 5e-4,
                "acac.critic_lr": 5e-4,
            }
        ),
        "mac-iaicc": frozen(
            {
                "maciaicc.n_step": 5,
                "maciaicc.lr": 5e-4,
                "maciaicc.critic_lr": 5e-4,
                "maciaicc.episodes_per_update": 4,
                "maciaicc.target_every": 32,
                "maciaicc.explore_decay": 50,
            }
        ),
    }
)
"""ACAC and Mac-IAICC where a budget holds hundreds of episodes rather than the tens of
thousands their Box Pushing settings are made for: Tool Delivery's 100K samples are about 670
episodes of up to 150 ticks, where ACAC's published ε (falling over 30,000 episodes) would still
be 0.98 at the end and its 16-episode rounds of two clipped epochs would make about 40 small
updates. ACAC: rounds of 4 episodes updated as maopg's PPO (clip 0.2, 10 epochs, learning
rates 5e-4), ε over 50 episodes. Mac-IAICC: MacroMARL's Warehouse (tool delivery) scripts —
5-step targets, learning rates 5e-4 and 5e-4, 4 episodes a round, targets every 32 episodes —
with ε over 50 episodes (theirs falls over 10,000 of 40,000). Chosen by pilots on Tool
Delivery at 30K samples, 3 seeds each (docs/results/leaderboard.md, the pilots' table)."""


def macromarl(size: int, critic: str = "state") -> Settings:
    """Mac-IAICC as MacroMARL's Box Pushing scripts run it at ``size``: critics of the grid's
    global state (their ``MacIAISC``), 32 environments and 32 episodes a round, γ = 0.98, the
    target critics copied every 128 episodes on 6x6 and 64 on the larger grids, ε over 4,000
    episodes (6,000 on 10x10); 1.5M samples, its rounds discarding unfinished episodes as
    ACAC's do (a 6x6 pilot had 652K published steps at 966K samples, its ε decaying much
    sooner than ACAC's). ``critic="history"``: the same with the paper's critics of the joint
    observation history (:func:`_mac_iaicc_history`)."""
    return frozen(
        {
            "mac-iaicc": frozen(
                {
                    "num_envs": 32,
                    "gamma": 0.98,
                    "total_samples": 1_500_000,
                    "maciaicc.critic": critic,
                    "maciaicc.target_every": 128 if size == 6 else 64,
                    "maciaicc.explore_decay": 6_000 if size == 10 else 4_000,
                }
            )
        }
    )


def _box_pushing_grid(size: int) -> Study:
    """The Box Pushing grid study at one size: its methods from the grid's 5-bit observations, 5
    seeds, 500K samples (maopg's counter; box-pushing reference §8), evaluating during training
    as the published runs do, and set beside the published curves of the same size.

    One study per size, as the published table is one per size: a task appears once in a study
    (its runs are grouped ``<runs>/<task>/<method>/seed<seed>``, and so are its curves and
    tables), and each size has a folder, a figure and published rows of its own. Each is
    reproduced, and resumed, on its own (``eval reproduce --study box-pushing-8``).

    Cost, measured on this machine with 20K-sample runs on 6x6 (CPU time per 500K samples,
    start-up left out): async 200 s, partial 235, async-rnn 415, mac-dqn 460 (10x10 is cheaper:
    its longer macro-actions choose less often; async 130 s, mac-dqn 400), so at most 1.8
    CPU-hours a size, 5.5 for the three. ACAC's 2.5M samples (:data:`ACAC_PUBLISHED`) take
    about 22 minutes a run (a 6x6 pilot ran 1,860 samples/s, its evaluations included) and
    Mac-IAICC's 1.5M about 10 (2,470 samples/s): 2.7 CPU-hours a size more. An evaluation is a
    small share of that: 10 episodes of at most 100 ticks on one environment, cheaper per tick
    than training (20K samples took as long with evaluation as without, within the noise of a
    shared machine). What the finished runs took on the shared machine, and what the cells
    left would take at that rate, ``bench/analysis/study_cost.py`` prints."""
    return Study(
        f"box-pushing-{size}",
        f"async, partial, async-rnn, mac-dqn, acac and mac-iaicc on the {size}x{size} Box "
        f"Pushing grid, beside the published bp{size} curves",
        (
            StudyTask(
                "box_pushing_grid",
                (0, 1, 2, 3, 4),
                frozen({"size": size}),
                frozen({"total_samples": 500_000}),
                frozen({**RECURRENT_HISTORY, **ACAC_PUBLISHED, **macromarl(size)}),
                threshold=BOX_PUSHING_THRESHOLD,
            ),
        ),
        (*BOX_PUSHING_METHODS, "acac", "mac-iaicc"),
        overrides=LITERATURE_EVALUATION,
        published=f"bp{size}",
    )


def _grid6_variant(name: str, what: str, methods: tuple[str, ...], **changes: Any) -> Study:
    """A study of ``box-pushing-6``'s task with ``changes`` (its seeds, a method's settings),
    set beside the same published bp6 curves, for what the 6x6 runs left open."""
    grid = _box_pushing_grid(6)
    (task,) = grid.tasks
    return Study(
        name, what, (replace(task, **changes),), methods, overrides=grid.overrides, published="bp6"
    )


def _mac_iaicc_history() -> Study:
    """Mac-IAICC on the 6x6 grid at MacroMARL's Box Pushing settings (:func:`macromarl`) but
    with the critics its paper describes, of the joint observation history, where the scripts
    give theirs the global state: the one detail in which maopg's first Mac-IAICC runs differed
    from the published ones, and what its study sets beside the same published bp6 curves
    (docs/results/box-pushing.md)."""
    return _grid6_variant(
        "mac-iaicc-history",
        "mac-iaicc with history critics on the 6x6 Box Pushing grid, beside the published bp6 "
        "curves and the box-pushing-6 study's state critics",
        ("mac-iaicc",),
        method_overrides=macromarl(6, critic="history"),
    )


def _acac_seeds() -> Study:
    """ACAC on the 6x6 grid at its published settings, as in ``box-pushing-6``, with seeds 5-9:
    a second sample of five seeds, beside the same published bp6 curves. Two of
    ``box-pushing-6``'s five ACAC seeds are caught by the small boxes where none of the
    authors' five are; five more say whether that is ACAC's rate here or the draw of five
    (docs/results/box-pushing.md). About 35 minutes a seed on this machine (``study_cost``)."""
    return _grid6_variant(
        "acac-seeds",
        "acac on the 6x6 Box Pushing grid with seeds 5-9, a second sample beside box-pushing-6's "
        "and the published bp6 curves",
        ("acac",),
        seeds=(5, 6, 7, 8, 9),
    )


MUJOCO_SAMPLES = 300_000
"""The MuJoCo studies' budget: at 500K they would take 27 CPU-hours, 33 with the grid studies'
5.5, and over the 40 CPU-hours the studies may take if many seeds never deliver; on 6x6 every
published method's value at 300K is within 4 of its value at 500K (ACAC's from 100K on)."""


def _box_pushing_mujoco(images: bool) -> Study:
    """The Box Pushing methods in MuJoCo (``box_pushing``, 6x6) from state or from
    RGB (``images``), 3 seeds, 300K samples, evaluating during training as the published runs do
    and set beside the published bp6 curves: the same layout and rewards as the grid, with
    physical robots and boxes. State and RGB are two studies, as a task appears once in a study.

    Cost, measured on this machine with 4K-sample runs (CPU time per sample, the evaluations
    of their early policies included; an evaluation tick costs a training tick here), 300K
    samples a run, 3 seeds: from state async 3.9 ms, partial 4.7, async-rnn 4.9, mac-dqn 4.1:
    4.4 CPU-hours; from RGB async 10.0 ms, partial 10.4, async-rnn 10.1, mac-dqn 17.4: 12.0
    CPU-hours. The grid studies add 5.5: 22 in all, about 25 if no seed ever delivers (its
    evaluations then play 100-tick episodes, half as many ticks again as its training, where
    the measured early ones played a quarter). Mac-DQN's
    replay rows hold images from RGB and every checkpoint saves them: 10K rows, as the paper's
    Water Filling runs keep."""
    what = "RGB" if images else "state"
    return Study(
        "box-pushing-mujoco" + ("-rgb" if images else ""),
        f"async, partial, async-rnn and mac-dqn on Box Pushing in MuJoCo (6x6) from {what}, "
        "beside the published bp6 curves",
        (
            StudyTask(
                "box_pushing",
                (0, 1, 2),
                frozen({"size": 6}),
                overrides=frozen({"total_samples": MUJOCO_SAMPLES, "images": images}),
                method_overrides=frozen(
                    {**RECURRENT_HISTORY, "mac-dqn": frozen({"dqn.buffer_size": 10_000})}
                    if images
                    else RECURRENT_HISTORY
                ),
                threshold=BOX_PUSHING_THRESHOLD,
            ),
        ),
        BOX_PUSHING_METHODS,
        overrides=LITERATURE_EVALUATION,
        published="bp6",
    )


register_study(PAPER, _paper)
register_study("teams", _teams)
register_study("teams-canonical", _teams_canonical)
register_study("memory", _memory)
register_study("chain-rule", _chain_rule)
for size in BOX_PUSHING_SIZES:
    register_study(f"box-pushing-{size}", partial(_box_pushing_grid, size))
register_study("mac-iaicc-history", _mac_iaicc_history)
register_study("acac-seeds", _acac_seeds)
register_study("box-pushing-mujoco", partial(_box_pushing_mujoco, False))
register_study("box-pushing-mujoco-rgb", partial(_box_pushing_mujoco, True))
