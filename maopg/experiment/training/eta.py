"""The whole run's ETA, shown in the training bar: the training that is left plus the steps
after it (:func:`maopg.experiment.training.trainer.after_training`), from what this run has
measured.

The training left includes the evaluations during training still due (``eval_every``), at the
mean time of this session's evaluations, or estimated as their episodes until one has run;
the training rate is measured without them.

The bar's own ETA covers the samples only, yet a run is not over when they are: the final
evaluation, the video (and its GIF, with ``video_gif``), the plot take their time (about 30 s on
Tool Delivery's defaults, minutes on Water Filling). Their cost is estimated from the run's own
measurements — the training rate, the time one environment tick takes while collecting (acting
and stepping, timed by :class:`maopg.experiment.training.watch.StepWatch`) and the mean length
of the episodes seen in training — plus a per-frame cost of the video that training never
measures (it renders no overview), a constant measured once. It is an estimate, labelled as one:
a greedy policy's episodes may be longer than the training's, and a parallel backend's tick cost
per environment is taken as if its environments ran fully in parallel (the conservative side).
"""

from __future__ import annotations

from dataclasses import dataclass

from maopg.env.video import FRAMES_PER_TICK, VIDEO_MAX_TICKS
from maopg.experiment.evaluation.evaluate import EVAL_MAX_TICKS
from maopg.experiment.run.config import TrainConfig

VIDEO_SECONDS_PER_FRAME = 0.13
"""Rendering and encoding one video frame (:data:`maopg.env.video.FRAMES_PER_TICK` a tick),
beyond the tick itself: ``bench/perf/video_speed.py`` filmed Tool Delivery's scripted episode,
165 frames, in 10.1 s of wall time at a load average of 6 to 7 on the 2-core development
machine (0.06 s a frame; BENCHMARKS.md) and in 21.2 s in a run before it at 5 to 11 (0.13 s).
The busier figure is taken: the estimate errs long rather than short."""
GIF_SECONDS_PER_FRAME = 0.045
"""The TensorBoard GIF (``video_gif``) of one frame: :func:`maopg.experiment.run.tb_video.add_video`
ran at 0.045 s a frame inside a default training run (``python -m train --task tool_delivery
--total-samples 1600``) on a busy 2-core machine."""
SETUP_SECONDS = 2.0
"""Loading ``final.pt``, building the evaluation environment and the TensorBoard writer."""
PLOT_SECONDS = 1.0
"""The learning-curve plot, mostly importing matplotlib (:attr:`TrainConfig.plot`)."""


@dataclass(frozen=True)
class RunRates:
    """What a run has measured of itself by now."""

    samples_per_s: float
    """Training samples a second, over this session's iterations (logging and checkpoints in)."""
    collecting_s: float
    """Seconds spent collecting: from an iteration's start to each vector step's end."""
    ticks: int
    """Environment ticks collected in that time, over all environments."""
    episode_length: float | None
    """Mean length (ticks) of the episodes that ended in training; ``None`` while none did."""
    evaluation_s: float | None = None
    """Mean seconds of this session's evaluations during training (``eval_every``), which
    ``samples_per_s`` leaves out; ``None`` while none has run."""


def envs_at_once(config: TrainConfig) -> int:
    """How many environments a vector step runs side by side (at most): one for ``local``, a
    group per worker otherwise (the ``threads`` backend has at least 2; docs of
    :attr:`TrainConfig.num_workers`)."""
    if config.backend == "local":
        return 1
    workers = max(config.num_workers, 2 if config.backend == "threads" else 1)
    return min(config.num_envs, workers)


def tick_seconds(config: TrainConfig, rates: RunRates) -> float:
    """What one tick of one environment costs, acting included: the evaluation and the video
    play one environment alone."""
    return rates.collecting_s * envs_at_once(config) / max(rates.ticks, 1)


def after_training_seconds(config: TrainConfig, rates: RunRates, max_ticks: int) -> float:
    """The estimated time of what follows training (``max_ticks``: the task's episode limit,
    the length guessed while no episode has ended): 2 x ``eval_episodes`` episodes of the
    training's mean length (bounded at :data:`EVAL_MAX_TICKS`), the video's ticks (bounded at
    :data:`VIDEO_MAX_TICKS`) with their frames (and GIF), the plot, and the set-up they share."""
    length = min(rates.episode_length or max_ticks, max_ticks)
    tick = tick_seconds(config, rates)
    seconds = 0.0
    if config.eval_episodes or config.video:
        seconds += SETUP_SECONDS
    if config.eval_episodes:
        seconds += 2 * config.eval_episodes * min(length, EVAL_MAX_TICKS) * tick
    if config.video:
        filmed = min(length, VIDEO_MAX_TICKS)
        per_frame = VIDEO_SECONDS_PER_FRAME + (GIF_SECONDS_PER_FRAME if config.video_gif else 0.0)
        seconds += filmed * tick + (FRAMES_PER_TICK * filmed + 1) * per_frame
    if config.plot:
        seconds += PLOT_SECONDS
    return seconds


def evaluations_seconds(
    config: TrainConfig, samples: int, rates: RunRates, max_ticks: int
) -> float:
    """The estimated time of the evaluations during training still due after ``samples``: each
    at the measured mean, or, before one has run, ``eval_during_episodes`` episodes of the
    training's mean length (``max_ticks`` while none has ended; bounded at
    :data:`EVAL_MAX_TICKS`)."""
    every = config.eval_every
    if not every:
        return 0.0
    due = config.total_samples // every - samples // every  # type: ignore[operator]
    if due <= 0:
        return 0.0
    each = rates.evaluation_s
    if each is None:
        length = min(rates.episode_length or max_ticks, max_ticks, EVAL_MAX_TICKS)
        each = config.eval_during_episodes * length * tick_seconds(config, rates)
    return due * each


def estimate_run(
    config: TrainConfig, samples: int, rates: RunRates, max_ticks: int
) -> tuple[float, float]:
    """The estimated seconds until the whole run is done, in two parts: the training left (the
    samples left at the measured rate, and :func:`evaluations_seconds`) and
    :func:`after_training_seconds`."""
    left = max(config.total_samples - samples, 0)  # type: ignore[operator]
    training = left / rates.samples_per_s + evaluations_seconds(config, samples, rates, max_ticks)
    return training, after_training_seconds(config, rates, max_ticks)


def about(seconds: float) -> str:
    """``~45s``, ``~3m10s``, ``~2h05m``: an estimate, said as one."""
    whole = round(seconds)
    if whole < 60:
        return f"~{whole}s"
    if whole < 3600:
        return f"~{whole // 60}m{whole % 60:02d}s"
    return f"~{whole // 3600}h{whole % 3600 // 60:02d}m"
