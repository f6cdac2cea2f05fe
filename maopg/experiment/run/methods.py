"""The method registry: a method's name → its termination strategy, policy builder and learner.

The learner class brings the rest of what a method is — its config section (``ppo.lr=...``),
its logged columns, its ``final.pt`` entry and how the trained policy acts — so the trainer, the
loader, the tables and the reproduction grid all read a method from here and nothing else.
A new method is one module (a :class:`~maopg.learner.Learner`, and a policy builder if its
network is new) plus one :func:`register_method` line, from anywhere::

    register_method(Method("reinforce", "continue", ReinforceLearner, centralized_policy))

The built-in methods name their learners and builders as ``"module:Attr"`` strings, imported on
first use, and give their config sections beside them: the registry, the command line's
``--help`` and the settings reference know every method and section without importing torch.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from maopg.experiment.run.directory import TIMING_COLUMNS
from maopg.exports import resolve
from maopg.learner.sections import ACACConfig, MacDQNConfig, MacIAICCConfig, PPOConfig
from maopg.options.base import Strategy

if TYPE_CHECKING:
    from torch import nn

    from maopg.env.contract import EnvSpec
    from maopg.learner import Learner
    from maopg.policy.joint_size import BuildTarget

BUILDER_KEYWORDS = ("hidden", "layers", "config", "target")
"""The keywords every policy builder is called with (:data:`PolicyBuilder`)."""

PolicyBuilder = Callable[..., "nn.Module"]
"""``builder(spec, *, hidden, layers, config, target) -> network``: the acting network of a
method from the environment's spec, the run's network size, the learner's config section and
what it is built for (:class:`~maopg.policy.joint_size.BuildTarget`: the memory a head with one
output per joint option must fit in)."""


@dataclass(frozen=True)
class Method:
    """One row of the paper's comparison (docs/DESIGN.md §6)."""

    name: str
    strategy: Strategy | str
    learner: type[Learner] | str
    """Its learner class, or ``"module:Class"`` imported on first use (:attr:`learner_class`;
    then ``config`` says what its section is)."""
    policy: PolicyBuilder | str
    """Its policy builder, or ``"module:function"`` imported on first use."""
    settings: tuple[tuple[str, Any], ...] = ()
    """Its own defaults for fields of its config section, as ``(name, value)`` pairs: a variant
    of a method that differs only in a setting (``async-rnn`` is ``async`` with
    ``ppo.recurrent=true``) is a row of its own in the tables; ``SECTION.NAME=VALUE`` on the
    command line still wins."""
    config: type | None = None
    """Its learner's ``Config``, required where ``learner`` is a string: a settings dataclass
    whose ``PREFIX`` names the section (``"ppo."``), read without importing the learner."""

    @property
    def learner_class(self) -> type[Learner]:
        """The learner class (imported now if it was named by a string)."""
        learner = resolve(self.learner)
        if self.config is not None and (
            learner.Config is not self.config or learner.section != self.section
        ):
            raise TypeError(
                f"method {self.name!r}: {self.learner!r} has section {learner.section!r} "
                f"({learner.Config.__name__}), not {self.section!r} ({self.config.__name__})"
            )
        return learner

    @property
    def section(self) -> str:
        """Name of the config section holding its hyper-parameters."""
        if isinstance(self.learner, str):
            return str(getattr(self.config, "PREFIX", "")).removesuffix(".")
        return self.learner.section

    @property
    def config_class(self) -> type:
        return self.config if self.config is not None else self.learner_class.Config

    @property
    def columns(self) -> tuple[str, ...]:
        """Its ``metrics.csv`` header."""
        from maopg.learner.base import SHARED_COLUMNS

        return (*SHARED_COLUMNS, *self.learner_class.columns, *TIMING_COLUMNS)

    def default_config(self, task: Mapping[str, Any] | None = None, **given: Any) -> Any:
        """Its config section: the learner's defaults, then the ``task``'s defaults for this
        section (``register_task(train_defaults={"ppo.explore_eps": 1.0})``, keys without the
        section), then :attr:`settings`, then ``given``: a method's own settings say what the
        method is, so they win over what a task would like every method to use."""
        return self.config_class(**{**dict(task or {}), **dict(self.settings), **given})

    def build_policy(
        self,
        spec: EnvSpec,
        *,
        hidden: int,
        layers: int,
        config: Any,
        target: BuildTarget | None = None,
    ) -> nn.Module:
        """Its acting network, built for ``target`` (default: to act on this machine)."""
        from maopg.policy.joint_size import BuildTarget

        target = target if target is not None else BuildTarget.this_machine()
        builder = resolve(self.policy)
        _check_builder(self.name, builder)
        return builder(spec, hidden=hidden, layers=layers, config=config, target=target)


_METHODS: dict[str, Method] = {}


def register_method(method: Method, *, overwrite: bool = False) -> Method:
    """Add ``method`` to the registry (a name already taken is an error unless ``overwrite``)."""
    if method.name in _METHODS and not overwrite:
        raise ValueError(f"method {method.name!r} is already registered (pass overwrite=True)")
    if isinstance(method.learner, str) and not method.section:
        raise ValueError(
            f"method {method.name!r}: a learner named by a string needs config=, its Config, "
            "whose PREFIX names the section ('mine.')"
        )
    if not isinstance(method.policy, str):
        _check_builder(method.name, method.policy)
    Strategy(method.strategy)
    taken = section_classes().get(method.section)
    if taken is not None and taken is not method.config_class:
        raise ValueError(
            f"config section {method.section!r} already belongs to {taken.__name__}; "
            f"method {method.name!r} brings {method.config_class.__name__}"
        )
    _METHODS[method.name] = method
    return method


def _check_builder(name: str, builder: PolicyBuilder) -> None:
    """A policy builder must take the keywords the trainer passes (:data:`PolicyBuilder`): one
    written before ``target`` existed is refused at registration (or, named by a string, when
    first built), in one line, rather than with a ``TypeError`` inside it."""
    try:
        parameters = inspect.signature(builder).parameters
    except (TypeError, ValueError):  # a builder whose signature cannot be read: trust it
        return
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values()):
        return
    missing = [k for k in BUILDER_KEYWORDS if k not in parameters]
    if missing:
        raise ValueError(
            f"method {name!r}: its policy builder {getattr(builder, '__name__', '')}"
            f" lacks the keyword(s) {missing}; a builder is called as builder(spec, hidden=, "
            "layers=, config=, target=) (target: what it is built for, "
            "maopg.policy.joint_size.BuildTarget)"
        )


def get_method(name: str) -> Method:
    try:
        return _METHODS[name]
    except KeyError:
        known = ", ".join(method_names())
        raise ValueError(f"unknown method {name!r}; known methods: {known}") from None


def method_names() -> list[str]:
    """Registered methods, in registration order (the paper's methods first)."""
    return list(_METHODS)


def section_classes() -> dict[str, type]:
    """Every registered learner's config section: name → dataclass."""
    return {m.section: m.config_class for m in _METHODS.values()}


# The built-in learners and policy builders, imported when a run first needs them.
PPO = {"learner": "maopg.learner.mappo:MAPPOLearner", "config": PPOConfig}
DQN = {"learner": "maopg.learner.macdqn:MacDQNLearner", "config": MacDQNConfig}
ACAC = {"learner": "maopg.learner.acac:ACACLearner", "config": ACACConfig}
MAC_IAICC = {"learner": "maopg.learner.mac_iaicc:MacIAICCLearner", "config": MacIAICCConfig}
CENTRALIZED = "maopg.learner.mappo:centralized_policy"
PARTIAL = "maopg.learner.mappo:partial_policy"
AUTOREGRESSIVE = "maopg.learner.mappo:autoregressive_policy"
MACRO_ACTORS = "maopg.learner.mac_iaicc:macro_actors"

# The paper's method and its baselines (docs/DESIGN.md §6), in the order of its tables.
register_method(Method("async", "continue", policy=CENTRALIZED, **PPO))
register_method(Method("sync-cut", "any", policy=CENTRALIZED, **PPO))
register_method(Method("sync-wait", "all", policy=CENTRALIZED, **PPO))
register_method(Method("end2end", "primitive", policy=CENTRALIZED, **PPO))
register_method(Method("mac-dqn", "continue", policy="maopg.learner.macdqn:joint_q_network", **DQN))
register_method(Method("partial", "continue", policy=PARTIAL, **PPO))
# The conditional factored by the chain rule over the choosing agents, for teams whose joint
# option set is too large for the product categorical (maopg.policy.autoregressive), and the
# paper's baselines built on it: the methods of the at-scale comparison (study "teams").
register_method(Method("async-ar", "continue", policy=AUTOREGRESSIVE, **PPO))
register_method(Method("sync-cut-ar", "any", policy=AUTOREGRESSIVE, **PPO))
register_method(
    Method("partial-ar", "continue", policy="maopg.learner.mappo:partial_factored_policy", **PPO)
)
# Recurrent policies and critics (a GRU over the option-level history, rMAPPO): for partially
# observable tasks such as Water Filling. Any MAPPO method is recurrent with ppo.recurrent=true;
# these three are the rows of the study "memory".
RECURRENT = {"settings": (("recurrent", True),), **PPO}
register_method(Method("async-rnn", "continue", policy=CENTRALIZED, **RECURRENT))
register_method(Method("sync-wait-rnn", "all", policy=CENTRALIZED, **RECURRENT))
register_method(Method("partial-rnn", "continue", policy=PARTIAL, **RECURRENT))
# The field's strongest published asynchronous policy-gradient method, as a baseline: ACAC
# (Agent-Centric Actor-Critic, ICML 2025; maopg.learner.acac), decentralized recurrent actors
# and an attention critic, trained on whole episodes collected in rounds.
register_method(
    Method("acac", "continue", policy="maopg.learner.acac:agent_centric_policy", **ACAC)
)
# MacroMARL's asynchronous actor-critics (Xiao, Tan, Amato, NeurIPS 2022): one actor per agent
# on its own macro-action trajectory, with individual centralized critics (Mac-IAICC), critics of
# the agent's own history (Mac-IAC) or one centralized critic (Naive Mac-IACC).
register_method(Method("mac-iaicc", "continue", policy=MACRO_ACTORS, **MAC_IAICC))
OWN_CRITIC = {"settings": (("critic", "own"),), **MAC_IAICC}
JOINT_CRITIC = {"settings": (("critic", "joint"),), **MAC_IAICC}
register_method(Method("mac-iac", "continue", policy=MACRO_ACTORS, **OWN_CRITIC))
register_method(Method("naive-mac-iacc", "continue", policy=MACRO_ACTORS, **JOINT_CRITIC))
