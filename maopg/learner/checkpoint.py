"""Atomic checkpoint files and the RNG states they carry.

A training run may be killed at any moment (a laptop lid, a CI timeout, an out-of-memory kill).
A checkpoint is therefore written to a temporary file in the same directory, flushed to disk and
moved over the old one with :func:`os.replace`, which is atomic on POSIX: a reader sees either the
old checkpoint or the new one, never half of one.

Loading uses ``torch.load(weights_only=True)``: a checkpoint holds only tensors and plain Python
containers, so opening a file from elsewhere cannot execute code. Anything that is not a tensor
(RNG states, counters, config) is stored as ints, floats, strings, lists and dicts.

Every tensor is written from the CPU (:func:`on_cpu`) and read onto it (``map_location``), so a
checkpoint is the same file whichever device trained it: one written on a GPU opens on a machine
without one, and the learner moves what it loads onto its own device.
"""

from __future__ import annotations

import copy
import os
import pickle
import random
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import torch


class CheckpointError(RuntimeError):
    """A checkpoint file is missing, truncated, corrupt, or not one of ours."""


def on_cpu(value: Any) -> Any:
    """``value`` with every tensor in it (through dicts, lists and tuples) moved to the CPU.

    A container holding nothing to move is returned as it is, so a CPU run saves exactly the
    objects it always did; a changed one is a shallow copy of its own type (a module's
    ``state_dict`` keeps its ``_metadata``).
    """
    if isinstance(value, torch.Tensor):
        return value.cpu()
    if isinstance(value, dict):
        moved = {key: on_cpu(item) for key, item in value.items()}
        if all(moved[key] is item for key, item in value.items()):
            return value
        result = copy.copy(value)
        result.update(moved)
        return result
    if isinstance(value, list | tuple):
        items = [on_cpu(item) for item in value]
        if all(new is old for new, old in zip(items, value, strict=True)):
            return value
        return type(value)(items)
    return value


def save_checkpoint(path: str | os.PathLike[str], state: dict[str, Any]) -> Path:
    """Write ``state`` to ``path`` atomically (temporary file + ``os.replace``), its tensors
    on the CPU (:func:`on_cpu`)."""
    state = on_cpu(state)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            torch.save(state, handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp_name, path)
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise
    return path


def load_checkpoint(path: str | os.PathLike[str], required: tuple[str, ...] = ()) -> dict:
    """Read a checkpoint written by :func:`save_checkpoint`; errors name the file."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint {path} does not exist")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except (RuntimeError, EOFError, OSError, pickle.UnpicklingError, zipfile.BadZipFile) as err:
        raise CheckpointError(f"checkpoint {path} is corrupt or unreadable: {err}") from err
    if not isinstance(state, dict):
        raise CheckpointError(f"checkpoint {path} holds a {type(state).__name__}, not a dict")
    missing = [key for key in required if key not in state]
    if missing:
        raise CheckpointError(f"checkpoint {path} lacks the entries {missing}")
    return state


def capture_global_rng() -> dict[str, Any]:
    """The global RNG states of torch, numpy and Python, as checkpoint-safe values."""
    kind, keys, pos, has_gauss, gauss = np.random.get_state()
    version, internal, gauss_next = random.getstate()
    return {
        "torch": torch.get_rng_state(),
        "numpy": [kind, torch.from_numpy(keys.astype(np.int64)), pos, has_gauss, gauss],
        "python": [version, list(internal), gauss_next],
    }


def restore_global_rng(states: dict[str, Any]) -> None:
    """Inverse of :func:`capture_global_rng`."""
    torch.set_rng_state(states["torch"])
    kind, keys, pos, has_gauss, gauss = states["numpy"]
    np.random.set_state((kind, keys.numpy().astype(np.uint32), pos, has_gauss, gauss))
    version, internal, gauss_next = states["python"]
    random.setstate((version, tuple(internal), gauss_next))
