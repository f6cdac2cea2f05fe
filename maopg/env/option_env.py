"""The option scheduler: runs a :class:`~maopg.tasks.base.Task` tick by tick and stops at
decision points according to a termination strategy ("soft-sync", paper §III-A).

Between two decision points every agent executes its option (or idles under ``all``); the
scheduler sums the ticks' shared rewards, discounts them, and returns one
:class:`~maopg.env.contract.DecisionPoint`. An agent's observation is refreshed exactly when it
chooses (its own option ended, or ``any``/``all`` made it choose): that is the paper's
"observations refresh when the robot's own option ends", and it means cameras are rendered
only for the agents that need a fresh image.

A tick whose physics went unstable (:class:`~maopg.sim.scene.PhysicsInstability`) ends the
episode at once, truncated and unsolved (see :mod:`maopg.env.contract`, "Physics warnings").
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from maopg.env.contract import AgentSpec, DecisionPoint, EnvSpec, Strategy
from maopg.options.base import Execution
from maopg.sim.channels import RGB
from maopg.sim.scene import PhysicsInstability
from maopg.tasks.base import Task, require_strategy


class OptionEnv:
    """Asynchronous option-level environment over one task (see :mod:`maopg.env.contract`)."""

    def __init__(
        self, task: Task, strategy: Strategy | str, *, gamma: float = 0.99, seed: int = 0
    ) -> None:
        self.task = task
        self.strategy = Strategy(strategy)
        require_strategy(type(task), task.name, self.strategy.value)
        if (self.strategy is Strategy.PRIMITIVE) != task.config.primitive:
            raise ValueError(
                f"strategy {self.strategy.value!r} needs a task built with "
                f"primitive={self.strategy is Strategy.PRIMITIVE} "
                f"(got primitive={task.config.primitive}); use maopg.env.make_env"
            )
        if not 0.0 <= gamma <= 1.0:
            raise ValueError(f"gamma must be in [0, 1], got {gamma}")
        self.gamma = gamma
        self._seed = _seed(seed, "seed")
        self._episode = 0
        n = len(task.agent_names)
        self._options = [tuple(task.options(i)) for i in range(n)]
        size = task.config.image_size
        channels = task.image_channels() if task.config.images else RGB
        shape = (size, size, channels.planes)
        self.spec = EnvSpec(
            task=task.name,
            strategy=self.strategy,
            agents=tuple(
                AgentSpec(
                    name=name,
                    robot=task.robot_of(i),
                    option_names=tuple(o.name for o in self._options[i]),
                    vector_size=task.vector_size(i),
                    layout=task.observation_layout(i),
                )
                for i, name in enumerate(task.agent_names)
            ),
            image_shape=shape if task.config.images else None,
            tick_seconds=task.tick_seconds,
            max_ticks=task.config.max_ticks,
            gamma=gamma,
            image_channels=channels,
            state_size=task.global_state_size(),
        )
        self._executions: list[Execution | None] = [None] * n
        self._idle = np.zeros(n, dtype=bool)
        self._running = np.full(n, -1, dtype=np.int64)
        self._choosing = np.ones(n, dtype=bool)
        self._vectors = [np.zeros(a.vector_size, dtype=np.float32) for a in self.spec.agents]
        self._images = np.zeros((n, *shape), channels.dtype) if task.config.images else None
        self._episode_return = 0.0
        self._physics_warning: str | None = None
        self._needs_reset = True
        self._masks: tuple[np.ndarray, ...] = ()  # availability reported at the last point
        self._tick_listeners: list[Callable[[OptionEnv, float], None]] = []

    # ------------------------------------------------------------------ public API
    @property
    def num_agents(self) -> int:
        return self.spec.num_agents

    def reset(self, seed: int | None = None) -> DecisionPoint:
        """Start an episode. Without ``seed``, episode ``e`` uses a seed derived from
        ``(env seed, e)``, so a run is reproducible from its seed alone."""
        if seed is None:
            seed = int(np.random.SeedSequence([self._seed, self._episode]).generate_state(1)[0])
        seed = _seed(seed, "reset seed")
        self._episode += 1
        self.task.reset(seed)
        self.task.draw_appearance(seed)
        self._executions = [None] * self.num_agents
        self._idle[:] = False
        self._running[:] = -1
        self._choosing[:] = True
        self._episode_return = 0.0
        self._physics_warning = None
        self._needs_reset = False
        self._refresh(self._choosing)
        return self._point(0.0, 0.0, 0, False, False)

    def step(self, joint_option: Sequence[int] | np.ndarray) -> DecisionPoint:
        """Start the choosing agents' options and run ticks until the next decision point."""
        joint = self._validate(joint_option)
        task = self.task
        for i in np.flatnonzero(self._choosing):
            option = self._options[i][joint[i]]
            ex = Execution(option=option, agent=int(i), started_tick=task.ticks)
            option.start(task, ex)
            self._executions[i] = ex
            self._running[i] = joint[i]
            self._idle[i] = False

        total, discounted, discount, k = 0.0, 0.0, 1.0, 0
        while True:
            for i, ex in enumerate(self._executions):
                if self._idle[i]:
                    task.hold(i)
                else:
                    ex.option.step(task, ex)
            try:
                reward = task.tick()
            except PhysicsInstability as err:  # the tick is spent, its outcome is void
                self._physics_warning = str(err)
                self._choosing[:] = True  # every option is void: all observations refresh
                k += 1
                terminated, truncated = False, True
                break
            for listener in self._tick_listeners:
                listener(self, reward)
            total += reward
            discounted += discount * reward
            discount *= self.gamma
            k += 1

            ended = np.zeros(self.num_agents, dtype=bool)
            for i, ex in enumerate(self._executions):
                if not self._idle[i]:
                    ex.ticks += 1
                    if ex.option.done(task, ex):
                        ex.option.finish(task, ex)
                        ended[i] = True
            terminated = task.terminated()
            truncated = not terminated and (task.ticks >= task.config.max_ticks or task.truncated())
            if self._decide(ended) or terminated or truncated:
                break

        self._episode_return += total
        if terminated or truncated:
            self._needs_reset = True
        self._refresh(self._choosing)
        return self._point(total, discounted, k, terminated, truncated)

    def add_tick_listener(self, listener: Callable[[OptionEnv, float], None]) -> None:
        """Call ``listener(env, reward)`` after every tick (videos, tick-level logging, tests).

        Between decision points this is the only window on the low-level time scale.
        """
        self._tick_listeners.append(listener)

    def remove_tick_listener(self, listener: Callable[[OptionEnv, float], None]) -> None:
        self._tick_listeners.remove(listener)

    def running_option_names(self) -> tuple[str, ...]:
        """Name of the option each agent executes now (``idle`` under ``all``, ``-`` at reset)."""
        return tuple(
            "idle" if self._idle[i] else ("-" if ex is None else ex.option.name)
            for i, ex in enumerate(self._executions)
        )

    def action_masks(self) -> tuple[np.ndarray, ...]:
        """Availability of every option of every agent in the current state."""
        return tuple(
            np.fromiter((o.available(self.task, i) for o in opts), bool, len(opts))
            for i, opts in enumerate(self._options)
        )

    def close(self) -> None:
        self.task.close()

    # ------------------------------------------------------------------ internals
    def _decide(self, ended: np.ndarray) -> bool:
        """Apply the termination strategy to this tick's endings; True at a decision point."""
        if self.strategy in (Strategy.CONTINUE, Strategy.PRIMITIVE):
            self._choosing[:] = ended
            return bool(ended.any())
        if self.strategy is Strategy.ANY:
            if not ended.any():
                return False
            for i in np.flatnonzero(~ended):
                ex = self._executions[i]
                ex.option.interrupt(self.task, ex)
                ex.option.finish(self.task, ex)
            self._choosing[:] = True
            return True
        # Strategy.ALL: finished agents idle (hold position) until everyone has finished.
        self._idle |= ended
        everyone = bool(self._idle.all())
        self._choosing[:] = everyone
        return everyone

    def _refresh(self, agents: np.ndarray) -> None:
        idx = np.flatnonzero(agents)
        for i in idx:
            self._vectors[i] = self.task.observe(int(i))
        if self._images is not None and idx.size:
            self.task.render(idx.tolist(), self._images)

    def _point(
        self, reward: float, discounted: float, k: int, terminated: bool, truncated: bool
    ) -> DecisionPoint:
        self._masks = self.action_masks()
        info: dict[str, object] = {"task": self.task.describe()}
        if self._physics_warning is not None:
            info["physics_warning"] = self._physics_warning
        if terminated or truncated:
            info["episode"] = {
                "return": self._episode_return,
                "ticks": self.task.ticks,
                "solved": self._physics_warning is None and self.task.solved(),
            }
        return DecisionPoint(
            vectors=tuple(self._vectors),
            images=self._images,
            choosing=self._choosing.copy(),
            running=self._running.copy(),
            available=self._masks,
            reward=reward,
            discounted_reward=discounted,
            duration=k,
            terminated=terminated,
            truncated=truncated,
            ticks=self.task.ticks,
            info=info,
            state=self.task.global_state(),
        )

    def _validate(self, joint_option: Sequence[int] | np.ndarray) -> np.ndarray:
        if self._needs_reset:
            raise ValueError("step() called before reset() or after the episode ended")
        joint = np.asarray(joint_option)
        names = self.spec.agent_names
        if joint.shape != (self.num_agents,) or not np.issubdtype(joint.dtype, np.integer):
            raise ValueError(
                f"joint_option must be {self.num_agents} integers, one per agent {names}; "
                f"got {joint_option!r}"
            )
        masks = self._masks  # those reported at this decision point
        for i, name in enumerate(names):
            o = int(joint[i])
            if not self._choosing[i]:
                if o not in (-1, self._running[i]):
                    running = self._options[i][self._running[i]].name
                    raise ValueError(
                        f"agent {name!r} is executing {running!r} and is not choosing; its entry "
                        f"must be -1 or {self._running[i]}, got {o}"
                    )
                continue
            if o < 0:
                raise ValueError(f"agent {name!r} must choose an option now (it is in U_t)")
            if o >= len(self._options[i]):
                raise ValueError(
                    f"agent {name!r} has {len(self._options[i])} options "
                    f"{[x.name for x in self._options[i]]}; option {o} is out of range"
                )
            if not masks[i][o]:
                raise ValueError(
                    f"option {o} ({self._options[i][o].name!r}) of agent {name!r} "
                    "is not available now"
                )
        return joint.astype(np.int64)


def _seed(value: Any, name: str) -> int:
    """A seed as numpy's generators take it: an integer >= 0 (a numpy integer too), else a
    ``ValueError`` naming it (numpy's own message would not say which seed)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
    return int(value)
