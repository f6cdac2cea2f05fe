"""The learners' config sections: ``ppo`` (MAPPO), ``dqn`` (Mac-DQN), ``acac`` (ACAC) and
``maciaicc`` (Mac-IAICC and its siblings), the hyper-parameters a command line sets as
``SECTION.NAME=VALUE``.

Plain settings dataclasses (:mod:`maopg.settings`) in a module of their own, importable without
torch: the command line's ``--help`` and the settings reference
(:mod:`maopg.experiment.run.settings_reference`) list them, and the run's config validates
them, before anything loads a learner. Each learner module uses its section as its ``Config``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import ClassVar

from maopg.policy.choices import EXPLORE_FORMS
from maopg.settings import Settings, setting
from maopg.tasks.config import TaskConfig


class DiscountForm(enum.StrEnum):
    """How the learner discounts across an option step (:mod:`maopg.learner.gae` says how
    each does): the values of ``ppo.discount``."""

    SMDP = "smdp"
    EVENT = "event"
    OPTION = "option"


def falling_epsilon(start: float, end: float, decay: int, count: int) -> float:
    """The ε of the exploration every learner mixes in (``ppo.explore_*``, ``acac.explore_*``,
    ``maciaicc.explore_*``): ``start`` falling linearly to ``end`` over ``decay`` units of
    ``count`` (samples or finished training episodes), ``end`` after; a ``start`` of 0 is no
    exploration throughout."""
    if not start:
        return start
    return start + min(count / decay, 1.0) * (end - start)


@dataclass(frozen=True)
class PPOConfig(Settings):
    """MAPPO's hyper-parameters: the config section ``ppo`` (defaults: the MAPPO reference,
    docs/DESIGN.md §5). The discount γ is the run's ``gamma`` (it also discounts the
    environment's rewards), the network size its ``hidden`` and ``layers``. Each field declares
    its bounds (:mod:`maopg.settings`); inf means "no limit" for the clip ranges and bounds."""

    PREFIX: ClassVar[str] = "ppo."

    epochs: int = setting(10, ge=1)
    """Passes of the PPO update over each batch."""
    num_minibatches: int = setting(1, ge=1)
    """Minibatches each pass splits the batch into (of decision points; of chunks when
    ``recurrent``), one gradient step each."""
    clip: float = setting(0.2, ge=0.0, infinite=True)
    """PPO's ratio clip ε: the policy loss clips the probability ratio to [1 - ε, 1 + ε]."""
    value_clip: float = setting(0.2, ge=0.0, infinite=True)
    """Clip range of the value around its prediction at collection: the value loss is the
    larger of the clipped and the unclipped one (MAPPO's clipped value loss)."""
    huber_delta: float = setting(10.0, gt=0.0, infinite=True)
    """δ of the critic's Huber loss (quadratic within δ of the target, linear beyond)."""
    ent_coef: float = 0.01
    """The entropy bonus's weight (from the first update on, with ``ent_decay``)."""
    ent_coef_end: float = setting(0.0, ge=0.0)
    """With ``ent_decay``: the weight the bonus falls to, and keeps after ``ent_decay`` ticks."""
    ent_decay: int = setting(0, ge=0)
    """Ticks over which the entropy bonus's weight falls linearly from ``ent_coef`` to
    ``ent_coef_end`` (as Mac-DQN's ε falls over ``dqn.eps_decay``, except at 0, which here
    means no decay: ``ent_coef`` throughout). Annealing is a common way to let a policy end
    sure of its choices; on Water Filling it left recurrent ``async`` as soft as before."""
    value_coef: float = setting(1.0, ge=0.0)
    """Weight of the value loss in the critic's step."""
    lr: float = setting(5e-4, gt=0.0)
    """The policy's Adam step size."""
    critic_lr: float = setting(5e-4, gt=0.0)
    """The critic's Adam step size."""
    adam_eps: float = setting(1e-5, ge=0.0)
    """Adam's ε (both optimisers)."""
    max_grad_norm: float = setting(10.0, gt=0.0, infinite=True)
    """Gradients are clipped to this norm, the policy's and the critic's each."""
    normalize_advantages: bool = True
    """Standardise the batch's advantages (mean 0, std 1) before the update."""
    gae_lambda: float = setting(0.95, ge=0.0, le=1.0)
    """GAE's λ: the advantages' trade of bias (0) against variance (1)."""
    discount: str = setting(DiscountForm.SMDP.value, choices=[f.value for f in DiscountForm])
    """``smdp`` (γ^k per option step, default), ``event`` (ACAC's: γ^k, and λ once per
    decision event) or ``option`` (the paper's γ per option step); :mod:`maopg.learner.gae`."""
    value_norm: bool = True
    """Running mean/var normalisation of the critic's targets."""
    recurrent: bool = False
    """A GRU over the option-level history in the policy and the critic (rMAPPO; the same key
    as ``dqn.recurrent``): the policy's state advances at its decision points (a partially
    centralized policy's per-agent state only at that agent's own), the critic's at every one,
    and both restart with each episode. Off by default: feed-forward is cheaper, and the
    committed grid is feed-forward."""
    option_history: bool = False
    """Recurrent only: the GRUs also read each agent's option and who chooses at every point
    (:mod:`maopg.policy.memory`, "Option history"), the macro-action-observation histories of
    the literature; off, they read the encoders' features alone (the committed ``memory``
    study's runs)."""
    memory_norm: bool = False
    """Recurrent only: layer-normalise each GRU's input features and its output, as rMAPPO
    does (:mod:`maopg.policy.memory`, "Normalisation"); off, the GRUs read the encoders'
    unnormalised features (the committed ``memory`` study's runs)."""
    chunk_length: int = setting(10, ge=1)
    """Recurrent only: consecutive decision points per training chunk, the horizon of truncated
    backpropagation through time (rMAPPO's ``data_chunk_length``); minibatches are sets of
    chunks, each re-run from the state it was collected with."""

    explore_eps: float = setting(0.0, ge=0.0, le=1.0)
    """Exploration by ε-mixed sampling: the weight ε of the uniform distribution over the
    available options mixed into the policy's conditional while collecting (per choosing agent
    or over the joint option: ``explore_form``), at the start of training; 0 (the default)
    turns exploration off, whatever ``explore_eps_end`` says, and collects from the policy
    itself. Evaluation never mixes. It is how the policy may find a reward its own samples
    miss once an easy one has made them sure (Box Pushing's big box, whose training defaults
    turn it on: ``docs/results/exploration.md``)."""
    explore_eps_end: float = setting(0.0, ge=0.0, le=1.0)
    """The ε that ``explore_eps`` falls to linearly over ``explore_decay``, and keeps after."""
    explore_decay: int = setting(0, ge=0)
    """How long ε falls from ``explore_eps`` to ``explore_eps_end``, counted in
    ``explore_unit``s (0: ``explore_eps`` throughout, as ``ent_decay``)."""
    explore_unit: str = setting("samples", choices=("samples", "episodes"))
    """What ``explore_decay`` counts: low-level ticks trained on, or training episodes
    finished (ACAC's published schedule: ε from 1.0 to 0.01 over 30,000 episodes)."""
    explore_form: str = setting("agent", choices=EXPLORE_FORMS)
    """How the uniform is mixed in: into each choosing agent's chain-rule factor (``agent``,
    :class:`~maopg.policy.EpsilonMixture`; ACAC's, whose actors are per agent), or into the
    joint option (``joint``, :class:`~maopg.policy.JointMixture`: with probability ε every
    choosing agent explores at once, and for the product categorical of ``async`` a failed
    lone move lowers only the joint option it was part of)."""
    explore_ratio: str = setting("mixture", choices=("mixture", "policy"))
    """The probabilities in PPO's ratio while exploring: ``mixture`` — the mixed ones, for the
    acting and the updated policy alike (ACAC's; the update is on-policy for the behaviour
    that collected the batch, but an option the policy has all but dropped gets all but no
    gradient, since the mixture's probability of it hardly depends on the policy's), or
    ``policy`` — the policy's own, as if it had chosen every option itself (biased, but an
    explored option that paid gets the full push of its advantage)."""

    def validate(self) -> None:
        super().validate()
        for name in ("option_history", "memory_norm"):
            if getattr(self, name) and not self.recurrent:
                raise ValueError(
                    f"ppo.{name}=true is a part of the GRUs: it needs ppo.recurrent=true"
                )

    def exploration(self, samples: int, episodes: int) -> float:
        """ε for a rollout collected after ``samples`` ticks and ``episodes`` finished training
        episodes (``explore_*``)."""
        done = samples if self.explore_unit == "samples" else episodes
        if self.explore_decay == 0:
            return self.explore_eps
        return falling_epsilon(self.explore_eps, self.explore_eps_end, self.explore_decay, done)

    def entropy_coef(self, samples: int) -> float:
        """The entropy bonus's weight in the update after ``samples`` ticks (``ent_decay``)."""
        if self.ent_decay == 0:
            return self.ent_coef
        if samples >= self.ent_decay:
            return self.ent_coef_end
        return self.ent_coef + samples / self.ent_decay * (self.ent_coef_end - self.ent_coef)


@dataclass(frozen=True)
class MacDQNConfig(Settings):
    """Mac-DQN's own hyper-parameters (the ``dqn`` section of ``train``'s config). Durations are
    in low-level ticks (samples), as everywhere here.

    The discount and the network size are not here: they are the run's ``gamma`` (which also
    discounts the environment's rewards, so the two cannot disagree), ``hidden`` and ``layers``,
    shared with MAPPO so both methods optimise the same objective with the same encoders
    (docs/DESIGN.md §5; MacDeepMARL's TD command used ``--rnn_h_size=128`` too, and γ = 1.0 per
    macro-step where we use 0.99 per tick). Each field declares its bounds
    (:mod:`maopg.settings`).
    """

    PREFIX: ClassVar[str] = "dqn."

    lr: float = setting(6e-4, gt=0.0)
    """Adam step size: MacDeepMARL TD command ``--l_rate=0.0006``."""
    batch_size: int = setting(64, ge=1)
    """Transitions per update (feed-forward). Chosen here (the original samples whole episodes)."""
    batch_episodes: int = setting(16, ge=1)
    """Episodes per update (recurrent): MacDeepMARL TD command ``--batch_size=16 --sample_epi``."""
    buffer_size: int = setting(50_000, ge=1)
    """Decision-point transitions kept. The original kept 1,000 episodes
    (``--replay_buffer_size=1000``), about 30-60K decision points on Tool Delivery."""
    learning_starts: int = setting(1_000, ge=0)
    """Ticks collected before the first update. Chosen here (original: 2 episodes, ~300 ticks)."""
    train_every: int = setting(5, ge=1)
    """Ticks between updates. Chosen here to keep MacDeepMARL's replay ratio: its TD command
    (``--train_freq=30 --batch_size=16 --sample_epi``) replays 16 episodes of ~40 decision
    points every 30 ticks (~20 transitions per tick); 64 rows every 5 ticks is ~13. With
    ``recurrent`` (16 whole episodes per update) use the original 30."""
    target_update_every: int = setting(1_000, ge=1)
    """Ticks between target-network syncs. Chosen here: MacDeepMARL's default
    ``--target_update_freq=5000`` spans ~170 of its updates; 1,000 ticks spans 200 of ours."""
    eps_start: float = setting(1.0, ge=0.0, le=1.0)
    """MacDeepMARL ``EPS_START``."""
    eps_end: float = setting(0.1, ge=0.0, le=1.0)
    """MacDeepMARL ``EPS_END``."""
    eps_decay: int = setting(15_000, ge=0)
    """Ticks of the linear ε decay. Chosen here: the original decays over 6,000 *episodes*
    (``--eps_l_d_steps=6000``, ~0.5-0.9M ticks), far beyond our budgets."""
    huber_delta: float = setting(10.0, gt=0.0, infinite=True)
    """Huber TD loss. Chosen here (original: squared error unless ``--huber_l``); δ as MAPPO's
    value loss (docs/DESIGN.md §5), so ±100 delivery rewards do not dominate the gradient."""
    max_grad_norm: float = setting(10.0, gt=0.0, infinite=True)
    """Gradient-norm clip. Chosen here (original: off unless ``--g_clip_norm``), as MAPPO."""
    reward_scale: float = setting(1.0, gt=0.0)
    """Factor on every reward the Q-network learns from, so Q-values (and ``q_mean`` in the log)
    are in scaled units; the greedy option is unchanged by a positive factor. ``huber_delta``
    and ``max_grad_norm`` were chosen for Tool Delivery's ±100 rewards: Water Filling's are
    ~-10³ per tick, where ``1e-3`` brings them to the same scale.
    MAPPO needs no such factor: its value normalisation rescales the returns."""
    recurrent: bool = False
    """GRU over the option-level history (the original used an LSTM over squeezed episodes).
    Off by default: the joint observation of Tool Delivery is nearly Markov and the feed-forward
    net is several times cheaper on 2 cores."""

    def check_task(self, task: TaskConfig) -> None:
        """The replay holds each episode whole until it ends (:class:`~maopg.learner.replay.
        SqueezedReplay`), so ``buffer_size`` must hold the longest: ``env.max_ticks`` decision
        points, one a tick at most."""
        if self.buffer_size < task.max_ticks:
            raise ValueError(
                f"dqn.buffer_size={self.buffer_size} cannot hold one episode of "
                f"env.max_ticks={task.max_ticks} ticks: set dqn.buffer_size >= {task.max_ticks} "
                f"or env.max_ticks <= {self.buffer_size}"
            )

    def epsilon(self, samples: int) -> float:
        """Linear ε schedule over ticks (MacDeepMARL ``Linear_Decay``)."""
        frac = min(1.0, samples / self.eps_decay) if self.eps_decay > 0 else 1.0
        return self.eps_start + frac * (self.eps_end - self.eps_start)


@dataclass
class ACACConfig(Settings):
    """The ``acac.*`` settings; defaults are the published runs' (Box Pushing, reference §10)."""

    PREFIX: ClassVar[str] = "acac."

    lr: float = setting(3e-4, gt=0.0)
    """Each actor's Adam learning rate."""
    critic_lr: float = setting(3e-4, gt=0.0)
    """The critic's Adam learning rate."""
    clip: float = setting(0.05, gt=0.0)
    """PPO's ratio clip."""
    train_repeat: int = setting(2, ge=1)
    """Full-batch gradient steps of the critic and of each actor per round."""
    gae_lambda: float = setting(0.95, ge=0.0, le=1.0)
    """GAE's λ (ACAC's ``event`` form: :mod:`maopg.learner.gae`)."""
    episodes_per_update: int = setting(16, ge=1)
    """Finished episodes a round waits for and trains on (the last ones to finish)."""
    target_every: int = setting(64, ge=1)
    """Episodes of the counter between copies of the critic into the target critic."""
    explore_eps: float = setting(1.0, ge=0.0, le=1.0)
    """ε of the mixture at the first round (0: no exploration)."""
    explore_eps_end: float = setting(0.01, ge=0.0, le=1.0)
    """The ε that ``explore_eps`` falls to over ``explore_decay``, and keeps after."""
    explore_decay: int = setting(30_000, ge=1)
    """Episodes of the counter over which ε falls linearly to ``explore_eps_end``."""
    width: int = setting(32, ge=1)
    """Width of every layer of the actors and the critic."""
    heads: int = setting(2, ge=1)
    """Attention heads of the critic (``width`` must be a multiple)."""
    popart_beta: float = setting(0.99999, gt=0.0, lt=1.0)
    """Decay of the running return statistics of the critic's PopArt value head (closer to 1:
    slower)."""
    cut_decisions: str = setting("train", choices=("train", "drop"))
    """An agent's last decision of an episode whose option the episode's end cut short (its
    partner delivered a box, or time ran out): ``train`` its actor on it as on every decision
    (the paper's description); ``drop`` it from the actor's loss, as ACAC's code does."""
    last_target: str = setting("return", choices=("return", "advantage"))
    """The critic's target at an episode's last decision: ``return``, ``A + V`` as at every
    other; ``advantage``, ``A`` alone, as ACAC's code computes it (its value there is left at
    0), which holds the critic there near half the last step's reward."""

    def validate(self) -> None:
        super().validate()
        if self.width % self.heads:
            raise ValueError(
                f"acac.width ({self.width}) must be a multiple of acac.heads ({self.heads})"
            )

    def exploration(self, episodes: int) -> float:
        """ε after ``episodes`` episodes of the counter."""
        return falling_epsilon(self.explore_eps, self.explore_eps_end, self.explore_decay, episodes)


CRITICS = ("history", "own", "joint", "state")


@dataclass
class MacIAICCConfig(Settings):
    """The ``maciaicc.*`` settings; defaults are MacroMARL's Mac-IAICC on 6x6 Box Pushing."""

    PREFIX: ClassVar[str] = "maciaicc."

    critic: str = setting("history", choices=CRITICS)
    """``history``: Mac-IAICC; ``state``: Mac-IAICC with critics of the task's global state, as
    MacroMARL's Box Pushing scripts run it (tasks with a state only: the Box Pushing tasks);
    ``own``: Mac-IAC; ``joint``: Naive Mac-IACC (:mod:`maopg.learner.mac_iaicc`)."""
    lr: float = setting(3e-4, gt=0.0)
    """Each actor's Adam learning rate."""
    critic_lr: float = setting(3e-3, gt=0.0)
    """The critics' Adam learning rate."""
    episodes_per_update: int = setting(32, ge=1)
    """Finished episodes a round waits for and trains on (the last ones to finish)."""
    target_every: int = setting(128, ge=1)
    """Episodes of the counter between copies of the critics into their targets."""
    n_step: int = setting(1, ge=1)
    """Macro-actions whose rewards a critic's target sums before it bootstraps (MacroMARL's
    ``n_step_TD``: 1 in its Mac-IAICC Box Pushing scripts, 5 in its Warehouse tool-delivery
    ones). With
    per-tick costs, a one-step target from a young critic (values near 0, above the true
    negative ones) makes the shortest options look best; more steps of real reward temper
    that."""
    explore_eps: float = setting(1.0, ge=0.0, le=1.0)
    """ε of the mixture at the first round (0: no exploration)."""
    explore_eps_end: float = setting(0.01, ge=0.0, le=1.0)
    """The ε that ``explore_eps`` falls to over ``explore_decay``, and keeps after."""
    explore_decay: int = setting(4_000, ge=1)
    """Episodes of the counter over which ε falls linearly to ``explore_eps_end``."""
    width: int = setting(32, ge=1)
    """Width of every layer of the actors and the critics."""

    def exploration(self, episodes: int) -> float:
        """ε after ``episodes`` episodes of the counter."""
        return falling_epsilon(self.explore_eps, self.explore_eps_end, self.explore_decay, episodes)

    def check_task(self, task: TaskConfig) -> None:
        """Critics of the global state need a task that reports one (``HAS_STATE``)."""
        if self.critic == "state" and not task.HAS_STATE:
            raise ValueError(
                "maciaicc.critic=state reads the task's global state, which this task does not "
                "report; choose maciaicc.critic from history, own or joint (the Box Pushing "
                "tasks have one)"
            )
