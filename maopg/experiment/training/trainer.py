"""The training loop, readable top to bottom: each iteration the method's learner collects a
batch of low-level ticks and learns from it (``learner.iteration``; for MAPPO see
:meth:`maopg.learner.MAPPOLearner.iteration`), then the loop logs the row and checkpoints; a
killed run resumes from its last checkpoint.

Everything random flows from ``config.seed``: network initialisation (torch's global RNG),
acting (``sample_gen``), minibatches / replay sampling (``update_gen``) and the environments'
episode seeds (:func:`maopg.env.vector.episode_seed`); the evaluation during training
(``eval_every``, :class:`TrainingEvaluation`) has seeds of its own and reads none of these.
The checkpoint stores the generators' states and each environment's (episode, options since
reset), so a resumed run continues bit for bit, whatever the backend. All of it is CPU state
whatever ``config.device``: networks are initialised on the CPU and moved, and the generators
are CPU generators that draw on the CPU (:class:`maopg.learner.LearnerSetup`), so
``device=cpu`` computes exactly what the code did before it had a device, and a ``cuda`` run
differs from it only by the GPU's rounding.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import random
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import torch

from maopg.env import OptionEnv
from maopg.env.contract import EnvSpec
from maopg.env.vector import SeededVectorEnv
from maopg.env.video import record_episode
from maopg.experiment.evaluation import evaluate as evaluation
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.config import RUN_SECTIONS, TrainConfig
from maopg.experiment.run.directory import (
    CHECKPOINT,
    CONFIG,
    CURVE,
    DONE,
    EVAL_COLUMNS,
    FINAL,
    FINAL_FRACTION,
    METRICS,
    TENSORBOARD,
    VIDEO,
    RunLog,
    plot_learning_curve,
    read_columns,
    read_done,
    scalar_tag,
    write_done,
)
from maopg.experiment.run.errors import writing_into
from maopg.experiment.run.lock import RunDirLock
from maopg.experiment.run.methods import get_method
from maopg.experiment.run.migration import CHECKPOINT_SCHEMA, SCHEMA_KEY, read_checkpoint
from maopg.experiment.run.sysinfo import BF16_FLAGS, bf16_instructions
from maopg.experiment.run.tb_video import add_video
from maopg.experiment.run.wandb_log import WandbMirror
from maopg.experiment.training.eta import RunRates, about, estimate_run
from maopg.experiment.training.watch import StepWatch
from maopg.learner import (
    CheckpointError,
    Learner,
    LearnerSetup,
    NonFiniteError,
    capture_global_rng,
    fitting,
    remove_stale_temporaries,
    restore_global_rng,
    save_checkpoint,
)
from maopg.policy.joint_size import BuildTarget
from maopg.progress import run_progress
from maopg.tasks import make_config

RESUMABLE_KEYS = (
    "total_samples",
    "progress",
    "video",
    "video_sample",
    "video_gif",
    "eval_episodes",
    "eval_every",
    "eval_during_episodes",
    "eval_during_sample",
    "plot",
    "backend",
    "num_workers",
    "run_dir",
    "plugins",
    "logger",
    *(f"{name}.{f.name}" for name, cls in RUN_SECTIONS.items() for f in dataclasses.fields(cls)),
    "device",
)
"""Config fields a resumed run may change: none of them changes what is computed. ``device``
changes only how it is rounded: a run moved from ``cpu`` to ``cuda`` (or back) continues the
same updates on the same state (checkpoints hold CPU tensors, :mod:`maopg.learner.checkpoint`),
but its curve from there on is not bit-identical to an unmoved run's. The evaluation during
training (``eval_every``) changes no training column either: a resumed run may switch it on
(its earlier rows read ``nan`` in the new columns), off (the columns stay, ``nan`` from there
on) or change its cadence; its rows up to the checkpoint are kept, not evaluated again."""


def _seed_everything(seed: int) -> tuple[torch.Generator, torch.Generator]:
    """Seed the global RNGs; return independent generators for sampling and minibatching."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)
    sample_seed, update_seed = np.random.SeedSequence([seed, 1]).generate_state(2)
    return (
        torch.Generator().manual_seed(int(sample_seed)),
        torch.Generator().manual_seed(int(update_seed)),
    )


def build_learner(
    config: TrainConfig,
    spec: EnvSpec,
    sample_gen: torch.Generator,
    update_gen: torch.Generator,
) -> Learner:
    """The learner of a resolved ``config`` with the method's freshly initialised policy, for
    environments of ``spec``: what :func:`train` learns with, and what a benchmark times."""
    method = get_method(config.method)
    size = {"hidden": config.hidden, "layers": config.layers}
    target = BuildTarget.for_training(config.device, batch_ticks=config.batch_ticks)  # type: ignore[arg-type]
    policy = method.build_policy(spec, **size, config=config.learner, target=target)
    setup = LearnerSetup(
        spec=spec,
        config=config.learner,
        num_envs=config.num_envs,
        batch_ticks=config.batch_ticks,  # type: ignore[arg-type]
        gamma=config.gamma,
        **size,
        sample_gen=sample_gen,
        update_gen=update_gen,
        device=torch.device(config.device),
        precision=config.precision,
    )
    return method.learner_class(policy, setup)


def _note(message: str) -> None:
    print(f"note: {message}", file=sys.stderr)


def _note_slow_bf16(config: TrainConfig) -> None:
    """Say where ``precision=bf16`` makes the CNNs slower, not faster (bench/perf/precision.py)."""
    if not (config.precision == "bf16" and config.images and config.device == "cpu"):
        return
    if torch.get_num_threads() > 1:
        _note(
            f"precision=bf16 with {torch.get_num_threads()} torch threads: the actor's and "
            "critic's updates, each on a thread of its own, then run several times slower than "
            "in fp32 (bench/perf/precision.py --torch-threads 2); torch_threads=1 is the fast "
            "setting"
        )
    if not bf16_instructions():
        _note(
            "precision=bf16 on a CPU without bf16 instructions (none of "
            f"{', '.join(BF16_FLAGS)} in /proc/cpuinfo): its convolutions are emulated and "
            "may run slower than in fp32 (bench/perf/precision.py measures both)"
        )


def _note_raw_memory(config: TrainConfig) -> None:
    """Say where a recurrent MAPPO run builds the GRUs that read unnormalised features: they
    stay the default so that runs saved before ``ppo.memory_norm`` existed load as they
    trained, but on Water Filling their gates saturated and the greedy policies looped
    (results/memory/README.md, findings 3 and 4)."""
    section = config.learner
    if getattr(section, "recurrent", False) and getattr(section, "memory_norm", True) is False:
        _note(
            f"{config.section}.recurrent=true without {config.section}.memory_norm=true: the "
            "GRUs read the encoders' unnormalised features, which saturated their gates on "
            f"Water Filling (results/memory/README.md); add {config.section}.memory_norm=true "
            f"{config.section}.option_history=true, as the memory study does"
        )


def _differences(ours: dict, theirs: dict) -> dict[str, tuple]:
    """The keys of two :meth:`TrainConfig.flat` views that differ, but for RESUMABLE_KEYS."""
    return {
        key: (ours.get(key), theirs.get(key))
        for key in sorted(set(ours) | set(theirs))
        if key not in RESUMABLE_KEYS and ours.get(key) != theirs.get(key)
    }


def _check_run_dir(config: TrainConfig, resume: bool, overwrite: bool) -> TrainConfig | None:
    """What the run directory allows, before anything is written: the saved config of the run
    that ``--resume`` continues (the given config must agree with it, see RESUMABLE_KEYS), or
    ``None`` for a new run."""
    run_dir = Path(config.run_dir)  # type: ignore[arg-type]
    saved = run_dir / CONFIG
    if resume:
        if not saved.exists():
            raise FileNotFoundError(
                f"--resume: {run_dir} holds no run ({CONFIG} is missing); check --run-dir, "
                "or drop --resume to start a new run there"
            )
        # Resolved on this machine's device: the saved one may be a GPU this machine lacks, and
        # the device is resumable anyway.
        before = dataclasses.replace(TrainConfig.load(saved), device=config.device).resolved()
        clashes = _differences(before.flat(), config.flat())
        if clashes:
            raise ValueError(
                f"--resume of {run_dir}: the config differs from the saved one in "
                + ", ".join(f"{k} (saved {a!r}, given {b!r})" for k, (a, b) in clashes.items())
            )
        return before
    if saved.exists() and not overwrite:
        raise FileExistsError(_holds_a_run(run_dir))
    return None


def _holds_a_run(run_dir: Path) -> str:
    return (
        f"run directory {run_dir} already holds a run; pass --resume to continue it, "
        "--overwrite to start over, or choose another --run-dir"
    )


def _empty(run_dir: Path) -> None:
    """Remove what ``run_dir`` holds, keeping the directory (and so its lock)."""
    for entry in run_dir.iterdir():
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()


def _open_run_dir(
    config: TrainConfig, lock: RunDirLock, *, overwrite: bool, new_run: bool
) -> WandbMirror | None:
    """Create (``overwrite``: empty) the run directory, open the run's W&B mirror
    (``logger=wandb``) and save the config; a checkpoint write that a kill interrupted left a
    temporary file, which goes. ``config.json`` comes last: it marks the directory as holding
    a run, so a W&B start that fails (no login, no network) leaves none behind.

    A directory created here is locked before its first file. A ``new_run`` checks again, under
    the lock, that the directory holds no run: another process may have started one there since
    :func:`_check_run_dir` looked (without ``overwrite``, that run is left as it is)."""
    run_dir = Path(config.run_dir)  # type: ignore[arg-type]
    new = not run_dir.exists()
    run_dir.mkdir(parents=True, exist_ok=True)
    lock.acquire()
    if new_run and not overwrite and (run_dir / CONFIG).exists():
        raise FileExistsError(_holds_a_run(run_dir))
    if overwrite and (run_dir / CONFIG).exists():
        _empty(run_dir)
    for name in (CHECKPOINT, FINAL):
        remove_stale_temporaries(run_dir / name)
    mirror = None
    if config.logger == "wandb":
        name = f"{config.task}/{config.method}/seed{config.seed}"
        try:
            mirror = WandbMirror(run_dir, config.wandb, name=name, config=config.flat())
        except ValueError:
            if new:  # the failed start leaves no directory behind
                shutil.rmtree(run_dir, ignore_errors=True)
            raise
    config.save(run_dir / CONFIG)
    return mirror


def _check_checkpoint(state: dict, config: TrainConfig, path: Path) -> None:
    """The checkpoint must come from the run it resumes: method, task, network, settings."""
    try:
        written = TrainConfig.from_dict(state["config"]).flat()
    except ValueError as err:
        raise CheckpointError(
            f"checkpoint {path} holds a config this run cannot read: {err}"
        ) from err
    clashes = _differences(written, config.flat())
    if clashes:
        raise CheckpointError(
            f"checkpoint {path} was written by another run: its config differs from {CONFIG} in "
            + ", ".join(f"{k} (checkpoint {a!r}, {CONFIG} {b!r})" for k, (a, b) in clashes.items())
        )


def _envs_state(state: dict, path: Path) -> dict:
    """The environments' entry of a checkpoint (of any schema: :func:`read_checkpoint`)."""
    if "envs" not in state:
        raise CheckpointError(f"checkpoint {path} lacks the entries ['envs']")
    return state["envs"]


def _against(trained: int, budget: int) -> str:
    """How ``trained`` samples stand to a ``budget`` they met: past it, or exactly at it."""
    return f"{'more than' if trained > budget else 'which reaches'} the budget of {budget}"


def _nothing_left(trained: int, config: TrainConfig, saved: TrainConfig) -> bool:
    """For a finished run that ``config`` resumes: whether its budget is already met (said on
    stderr, so a smaller budget does not pass unnoticed). A finished run keeps no checkpoint
    in a results folder, which only matters for a larger budget: it cannot be extended."""
    run_dir, budget = config.run_dir, config.total_samples
    if trained >= budget:  # type: ignore[operator]
        if budget < saved.total_samples:  # type: ignore[operator]
            _note(
                f"{run_dir} already trained {trained} samples, {_against(trained, budget)} "
                "it was resumed with; nothing to do"
            )
        else:
            _note(f"{run_dir} is finished ({trained} samples); nothing to do")
        return True
    if not (Path(run_dir) / CHECKPOINT).exists():  # type: ignore[arg-type]
        raise CheckpointError(
            f"cannot extend {run_dir} to {budget} samples: it finished at {trained} and has no "
            f"{CHECKPOINT} to continue from"
        )
    return False


def _stopped(
    err: NonFiniteError, iteration: int, samples: int, checkpointed: int | None
) -> NonFiniteError:
    """The one line that ends a run whose learner went non-finite in ``iteration``: where, what,
    and which iteration ``checkpoint.pt`` still holds (it never receives non-finite weights)."""
    kept = (
        f"{CHECKPOINT} keeps iteration {checkpointed}"
        if checkpointed is not None
        else f"no {CHECKPOINT} was written"
    )
    return NonFiniteError(
        f"training stopped in iteration {iteration} (after {samples} samples): {err}; {kept}"
    )


class TrainingEvaluation:
    """The evaluation during training (``eval_every``): the evaluation columns of each
    iteration's row, the outcome of an evaluation where one is due
    (:func:`~maopg.experiment.evaluation.evaluate.evaluation_due`) and ``nan`` elsewhere.

    An evaluation plays :func:`~maopg.experiment.evaluation.evaluate.evaluate` in an environment of
    its own (built at the first one, in this process whatever the backend) with a CPU copy of the
    learner's acting network, acting as every trained policy acts (:meth:`Learner.actor`:
    sampled, Mac-DQN ε-greedy at its final ε; greedy with ``eval_during_sample=false``), from
    the evaluation's own seeds (:func:`~maopg.experiment.evaluation.evaluate.evaluation_seeds`). It
    touches nothing the training reads — the learner's network, the training's environments and
    their episode counters, its generators — and the global RNGs are restored after it, should a
    task's code draw from them: the training columns are the same bit for bit with evaluation
    on or off. An evaluation depends only on the weights and its index, so a resumed run
    evaluates as an uninterrupted one.
    """

    def __init__(self, config: TrainConfig) -> None:
        self.config = config
        self.seconds = 0.0
        """Spent evaluating in this session: in no row's ``wall_time`` or ``samples_per_s``."""
        self.count = 0
        """Evaluations in this session."""
        self._env: OptionEnv | None = None
        self._cut_said = False

    @property
    def mean_seconds(self) -> float | None:
        """The mean time of this session's evaluations, ``None`` while none has run."""
        return self.seconds / self.count if self.count else None

    def row(self, learner: Learner, before: int, after: int) -> dict[str, float]:
        """The evaluation columns of the iteration that took the run from ``before`` to
        ``after`` samples, evaluating ``learner``'s policy if one is due."""
        config = self.config
        index = evaluation.evaluation_due(before, after, config.eval_every)
        if index is None:
            return dict(evaluation.NO_EVALUATION)
        start = time.perf_counter()
        episode_seed, acting_seed = evaluation.evaluation_seeds(config.seed, index)
        actor = get_method(config.method).learner_class.actor(
            copy.deepcopy(learner.policy).cpu(),
            config.learner,
            greedy=not config.eval_during_sample,
            seed=acting_seed,
        )
        global_rng = capture_global_rng()
        try:
            if self._env is None:
                self._env = config.env().make(0)
            result = evaluation.evaluate(
                self._env,
                actor,
                config.eval_during_episodes,
                seed=episode_seed,
                label=f"at {after} samples",
                progress=config.progress,
                max_ticks=evaluation.EVAL_MAX_TICKS,
            )
        finally:
            restore_global_rng(global_rng)
        if any(result.cut) and not self._cut_said:
            self._cut_said = True
            _note(
                f"evaluation at {after} samples: {sum(result.cut)} of its "
                f"{config.eval_during_episodes} episodes went on past tick "
                f"{evaluation.EVAL_MAX_TICKS} and were cut there (said once; so may later ones)"
            )
        self.seconds += time.perf_counter() - start
        self.count += 1
        return evaluation.evaluation_row(result)

    def close(self) -> None:
        if self._env is not None:
            self._env.close()


def _columns(config: TrainConfig, resume: bool) -> tuple[str, ...]:
    """The run's ``metrics.csv`` columns: its method's, and the evaluation's where it evaluates
    during training or its file already has them (a resumed run keeps its columns)."""
    columns = get_method(config.method).columns
    path = Path(config.run_dir) / METRICS  # type: ignore[arg-type]
    if config.eval_every or (resume and EVAL_COLUMNS[0] in read_columns(path)):
        columns += EVAL_COLUMNS
    return columns


def train(config: TrainConfig, *, resume: bool = False, overwrite: bool = False) -> Path:
    """Train ``config`` (resolved here) and return the run directory.

    Everything that can be checked is checked before the first file is written — the config,
    whether the machine can render what the run renders, the run directory, the networks and
    learner it builds — so a failed start leaves nothing that blocks the corrected command.
    The run directory stays locked while this runs (:mod:`maopg.experiment.run.lock`): another
    process that names it stops with :class:`~maopg.experiment.run.lock.RunDirBusy`. An
    existing directory is locked before what it holds is read, a new one once it is created.
    A write the machine refuses (a full disk, a read-only file system) is an ``OSError`` that
    names its file, or the run directory where Python kept no name (:func:`writing_into`);
    the checkpoint before it is intact (:func:`~maopg.learner.save_checkpoint`).
    """
    config = config.resolved()
    run_dir = Path(config.run_dir)  # type: ignore[arg-type]
    with RunDirLock(run_dir) as lock, writing_into(run_dir):
        return _train(config, lock, resume=resume, overwrite=overwrite)


def _train(config: TrainConfig, lock: RunDirLock, *, resume: bool, overwrite: bool) -> Path:
    problem = config.rendering_problem()
    if problem:
        raise ValueError(problem)
    saved = _check_run_dir(config, resume, overwrite)
    run_dir = Path(config.run_dir)  # type: ignore[arg-type]
    checkpoint_path = run_dir / CHECKPOINT
    done = read_done(run_dir) if resume else None
    if done is not None and _nothing_left(done["samples"], config, saved):  # type: ignore[arg-type]
        return run_dir
    if done is None and resume and not checkpoint_path.exists():
        _note(f"{run_dir} has no {CHECKPOINT} yet; --resume starts it from the beginning")
    resume = resume and checkpoint_path.exists()
    if config.torch_threads:
        torch.set_num_threads(config.torch_threads)
    _note_slow_bf16(config)
    _note_raw_memory(config)
    for advice in make_config(config.task, config.env_overrides).advice():  # type: ignore[arg-type]
        _note(advice)
    sample_gen, update_gen = _seed_everything(config.seed)

    # Workers are spawned before this process builds anything that renders (docs/DESIGN.md §2).
    envs = SeededVectorEnv(
        config.env(),
        num_envs=config.num_envs,
        seed=config.seed,
        backend=config.backend,  # type: ignore[arg-type]
        num_workers=config.num_workers,
        backend_options=config.backend_options(),
    )
    mirror: WandbMirror | None = None
    evaluations = TrainingEvaluation(config)
    try:
        learner = build_learner(config, envs.spec, sample_gen, update_gen)
        new_run = saved is None  # --resume wins over --overwrite
        mirror = _open_run_dir(config, lock, overwrite=overwrite and new_run, new_run=new_run)
        if done is not None:
            # A larger budget: unfinished again until it is reached. The old weights go with
            # the marker, so a killed extension cannot pass its old policy off as the final one
            # (nor an old curve: with plot=false none is drawn at the end).
            (run_dir / DONE).unlink()
            for stale in (FINAL, VIDEO, CURVE):
                (run_dir / stale).unlink(missing_ok=True)
        iteration, samples, wall_time = 0, 0, 0.0
        if resume:
            state = read_checkpoint(checkpoint_path, required=("iteration", "config"))
            _check_checkpoint(state, config, checkpoint_path)
            with fitting(checkpoint_path):
                learner.load_state_dict(state)
                sample_gen.set_state(state["sample_gen"])
                update_gen.set_state(state["update_gen"])
                restore_global_rng(state["global_rng"])
            envs.load_state_dict(_envs_state(state, checkpoint_path))
            iteration, samples, wall_time = state["iteration"], state["samples"], state["wall_time"]
            if samples >= config.total_samples:  # type: ignore[operator]
                _note(
                    f"{checkpoint_path} already trained {samples} samples, "
                    f"{_against(samples, config.total_samples)} it was resumed with; "  # type: ignore[arg-type]
                    "the run finishes there"
                )
        else:
            envs.reset()
        log = RunLog(
            run_dir,
            _columns(config, resume),
            resume_samples=samples if resume else None,
            mirror=mirror,
        )
        checkpointed = iteration if resume else None

        def checkpoint() -> None:
            log.flush()
            save_checkpoint(
                checkpoint_path,
                {
                    SCHEMA_KEY: CHECKPOINT_SCHEMA,
                    "config": config.to_dict(),
                    "iteration": iteration,
                    "samples": samples,
                    "wall_time": wall_time,
                    **learner.state_dict(),
                    "sample_gen": sample_gen.get_state(),
                    "update_gen": update_gen.get_state(),
                    "global_rng": capture_global_rng(),
                    "envs": envs.state_dict(),
                },
            )

        bar = run_progress(
            total=config.total_samples,  # type: ignore[arg-type]
            initial=min(samples, config.total_samples),  # type: ignore[type-var]
            unit="tick",
            desc=f"{config.task}/{config.method}/seed{config.seed}",
            enabled=config.progress,
        )
        watch = StepWatch(envs.spec, bar)
        envs.on_step = watch
        session_start, session_samples = time.perf_counter(), samples
        after: float | None = None  # the after-training steps' estimated time, once measured
        ret = ""  # the postfix's last episode return
        if not resume:
            evaluated = (scalar_tag(EVAL_COLUMNS[0]),) if config.eval_every else ()
            log.hparams(config.flat(), (*EVAL_TAGS, *evaluated))
        try:
            while samples < config.total_samples:  # type: ignore[operator]
                start = time.perf_counter()
                watch.start()
                try:
                    row, ticks = learner.iteration(envs, samples)
                except NonFiniteError as err:
                    raise _stopped(err, iteration + 1, samples, checkpointed) from err
                elapsed = time.perf_counter() - start
                first = samples == session_samples  # the session's first iteration
                budget: int = config.total_samples  # type: ignore[assignment]
                if first and (rounding := rounding_note(budget, samples + ticks, ticks)):
                    bar.write(f"note: {rounding}", file=sys.stderr)  # a line, not in the bar
                iteration += 1
                samples += ticks
                wall_time += elapsed
                row.update(
                    iteration=iteration,
                    samples=samples,
                    samples_per_s=ticks / elapsed,
                    wall_time=wall_time,
                )
                row.update(evaluations.row(learner, samples - ticks, samples))
                log.write(row)
                log.scalars("options", watch.take_frequencies(), samples)
                bar.n = min(samples, config.total_samples)  # type: ignore[type-var]
                if row["episodes"]:
                    ret = f"ret={row['episode_return']:.1f}, "
                training_s = time.perf_counter() - session_start - evaluations.seconds
                rates = RunRates(
                    samples_per_s=(samples - session_samples) / training_s,
                    collecting_s=watch.collecting_s,
                    ticks=watch.ticks,
                    episode_length=watch.episode_length,
                    evaluation_s=evaluations.mean_seconds,
                )
                training, after = estimate_run(config, samples, rates, envs.spec.max_ticks)
                bar.set_postfix_str(f"{ret}run done in {about(training + after)}", refresh=False)
                bar.refresh()
                if iteration % config.checkpoint_every == 0 or samples >= config.total_samples:  # type: ignore[operator]
                    checkpoint()
                    checkpointed = iteration
        finally:
            bar.close()
            log.close()
        save_checkpoint(
            run_dir / FINAL,
            {
                SCHEMA_KEY: CHECKPOINT_SCHEMA,
                "config": config.to_dict(),
                "iteration": iteration,
                "samples": samples,
                **learner.final_state(),
            },
        )
    except BaseException:
        if mirror is not None:
            mirror.close(failed=True)
        raise
    finally:
        evaluations.close()
        envs.close()
    failed = True  # the W&B run ends failed unless the after-training steps finish
    try:
        evaluated = after_training(run_dir, mirror, estimate=after)
        failed = False
    finally:
        if mirror is not None:
            mirror.close(failed=failed)
    write_done(
        run_dir, iterations=iteration, samples=samples, wall_time=wall_time, evaluation=evaluated
    )
    return run_dir


ROUNDING_NOTE = 0.01
"""How far past ``total_samples`` a run may end, as a share of it, before it says so: every
iteration ends a little past its ``batch_ticks`` (the options running then finish), which is
not worth a line; a budget that is no multiple of the iterations (3,000 samples in iterations
of 2,000) is."""


def rounding_note(total: int, samples: int, ticks: int) -> str | None:
    """The line that says where a run will end, if its iterations all take ``ticks`` like the
    first of this session (which took it to ``samples``), when that is more than
    :data:`ROUNDING_NOTE` past ``total``: the loop stops at the end of the iteration that
    reaches the budget, it never cuts one short. ``None`` when the end is near enough."""
    end = samples + math.ceil(max(0, total - samples) / ticks) * ticks
    if end - total <= ROUNDING_NOTE * total:
        return None
    return (
        f"total_samples {total} → about {end}: training stops after the iteration that "
        f"reaches it, and an iteration here takes {ticks} ticks"
    )


def after_training_plan(config: TrainConfig, estimate: float | None = None) -> str:
    """The line that says what follows training and how big each step is, so the time after
    the training bar (about 30 s for Tool Delivery's defaults on 2 cores; docs/getting-started.md,
    "Progress and estimates") is announced rather than silent; empty when nothing follows.
    ``estimate``: the seconds these steps should take, from the rates the training measured
    (:func:`maopg.experiment.training.eta.after_training_seconds`, the part of the training bar's
    ``run done in ~...`` that follows the samples), said as an estimate; each step's own bar
    then gives its ETA from its own measured rate.
    """
    steps = []
    if config.eval_episodes:
        steps.append(f"evaluation of 2 x {config.eval_episodes} episodes (greedy, sampled)")
    if config.plot:
        steps.append("the learning-curve plot")
    if config.video:
        gif = " and its TensorBoard GIF" if config.video_gif else ""
        steps.append(f"a rollout video of one episode{gif}")
    if not steps:
        return ""
    guess = f" (estimated {about(estimate)})" if estimate is not None else ""
    return f"after training{guess}: {', '.join(steps)}"


EVAL_TAGS = ("eval/return_greedy", "eval/return_sampled")
"""The final policy's evaluation in TensorBoard, also the metrics of its HPARAMS tab."""


def after_training(
    run_dir: Path, mirror: WandbMirror | None = None, *, estimate: float | None = None
) -> dict[str, dict[str, float]]:
    """Artifacts of a finished run, each in TensorBoard too: with ``eval_episodes``, the final
    policy's mean return, greedy and sampled, over that many seeded episodes (its option choices
    per agent beside them); with ``plot``, the learning-curve plot; with ``video``, a rollout of
    the trained policy (seed 0; sampled, or greedy with ``video_sample=false``) as
    ``rollout.mp4`` (in TensorBoard too, as a GIF, with ``video_gif``).

    The policy is loaded back from ``final.pt`` the way ``python -m eval`` loads it, so what is
    reported is what the saved checkpoint does. The video's length is bounded
    (:data:`maopg.env.video.VIDEO_MAX_TICKS`) whatever the task's ``max_ticks``, and so is
    each evaluation episode's (:data:`maopg.experiment.evaluation.evaluate.EVAL_MAX_TICKS`): an
    episode still going there is cut, its return is that of its first ticks, and one ``note:`` line
    says how many were.

    With ``progress``, one line first names the steps to come (:func:`after_training_plan`,
    with the ``estimate`` of their time when the training measured one),
    and the evaluation, the video and its TensorBoard GIF (``video_gif``) each show a bar with its
    own ETA.
    With ``mirror`` the evaluation becomes the W&B run's summary, and the video goes there too.
    Returns the evaluation for ``done.json`` (:func:`write_done`): per way of acting
    (``greedy``, ``sampled``) its ``episodes``, ``return_mean`` and ``success_rate``; empty
    without ``eval_episodes``.
    """
    from torch.utils.tensorboard import SummaryWriter

    config = TrainConfig.load(run_dir / CONFIG)
    plan = after_training_plan(config, estimate)
    if config.progress and plan:
        _note(plan)
    if config.plot:
        title = f"{config.task} · {config.method} · seed {config.seed}"
        plot_learning_curve(run_dir / METRICS, run_dir / CURVE, title)
    evaluated: dict[str, dict[str, float]] = {}
    if not (config.eval_episodes or config.video):
        return evaluated
    trained = load_trained(run_dir / FINAL)
    env = trained.make_env(0)
    tb = SummaryWriter(str(run_dir / TENSORBOARD))
    summary: dict[str, float] = {}
    video_path = None
    try:
        evaluations = zip((True, False), EVAL_TAGS, strict=True) if config.eval_episodes else ()
        cut = 0
        for greedy, tag in evaluations:
            result = evaluation.evaluate(
                env,
                trained.actor(greedy=greedy),
                config.eval_episodes,
                label=tag,
                progress=config.progress,
                max_ticks=evaluation.EVAL_MAX_TICKS,
            )
            cut += sum(result.cut)
            summary[tag] = float(np.mean(result.returns))
            kind = tag.split("_")[-1]
            outcome = result.summary
            evaluated[kind] = {key: outcome[key] for key in EVALUATED}
            for agent, counts in result.choices.items():
                total = sum(counts.values())
                for option, count in counts.items():
                    summary[f"eval_options_{kind}/{agent}/{option}"] = count / total
        if cut:
            limit = evaluation.EVAL_MAX_TICKS
            _note(
                f"evaluation: {cut} of the {2 * config.eval_episodes} episodes (greedy and "
                f"sampled) went on past tick {limit} and were cut there; their returns are over "
                f"the first {limit} ticks"
            )
        for tag, value in summary.items():
            tb.add_scalar(tag, value, trained.samples)
        if config.video:
            greedy = not config.video_sample
            video = record_episode(
                env,
                trained.actor(greedy=greedy),
                run_dir / VIDEO,
                seed=0,
                policy_label=trained.label(greedy=greedy),
                progress=config.progress,
            )
            if video.cut:
                _note(f"{video.path} stops at tick {video.ticks}; the episode went on")
            if config.video_gif:
                add_video(
                    tb,
                    "rollout",
                    video.path,
                    trained.samples,
                    frames=video.frames,
                    progress=config.progress,
                )
            video_path = video.path
    finally:
        tb.close()
        env.close()
    if mirror is not None:
        mirror.final(summary, video_path)
    return evaluated


EVALUATED = ("episodes", "return_mean", "success_rate")
"""What ``done.json`` keeps of each final evaluation (:attr:`EvalResult.summary`'s keys)."""


def run_summary(run_dir: Path) -> str:
    """What a finished run ends with on the command line, from its ``done.json``: the samples
    and time it trained, its final return, its final policy's evaluation greedy and sampled,
    and the files of the run directory."""
    done = read_done(run_dir) or {}
    lines = []
    if "samples" in done:
        lines.append(
            f"trained {done['samples']} samples in {done['iterations']} iterations "
            f"({about(done['wall_time']).removeprefix('~')} of training)"
        )
    if done.get("final_return") is not None:
        lines.append(
            f"final return {done['final_return']:.1f} (the training episodes of the last "
            f"{FINAL_FRACTION:.0%} of the samples)"
        )
    for kind, result in done.get("evaluation", {}).items():
        lines.append(
            f"final policy, {kind}: return {result['return_mean']:.1f}, success "
            f"{result['success_rate']:.0%} ({result['episodes']} episodes)"
        )
    files = ", ".join(
        f"{p.name}/" if p.is_dir() else p.name
        for p in sorted(run_dir.iterdir())
        if not p.name.startswith(".")
    )
    lines.append(f"run directory: {run_dir} ({files})")
    return "\n".join(lines)
