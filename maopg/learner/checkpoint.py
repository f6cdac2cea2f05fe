"""Atomic checkpoint files and the RNG states they carry.

A training run may be killed at any moment (a laptop lid, a CI timeout, an out-of-memory kill).
A checkpoint is therefore written to a temporary file in the same directory, flushed to disk and
moved over the old one with :func:`os.replace`, which is atomic on POSIX: a reader sees either the
old checkpoint or the new one, never half of one.

A kill before the move leaves the temporary behind; :func:`remove_stale_temporaries` clears it
when a run reopens its directory.

Loading uses ``torch.load(weights_only=True)``: a checkpoint holds only tensors and plain Python
containers, so opening a file from elsewhere cannot execute code. Anything that is not a tensor
(RNG states, counters, config) is stored as ints, floats, strings, lists and dicts.

Every tensor is written from the CPU (:func:`on_cpu`) and read onto it (``map_location``), so a
checkpoint is the same file whichever device trained it: one written on a GPU opens on a machine
without one, and the learner moves what it loads onto its own device.

torch does not verify the zip's CRCs, so flipped bits inside tensor data would load silently as
other weights: every checkpoint also stores a SHA-256 of its tensors (:data:`CHECKSUM_KEY`),
which loading verifies. Checkpoints written before the checksum existed load unchecked.
"""

from __future__ import annotations

import copy
import hashlib
import os
import pickle
import random
import re
import tempfile
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import torch

from maopg.learner.errors import CheckpointError

CHECKSUM_KEY = "tensors_sha256"
"""The entry holding :func:`tensors_digest` of the rest of the checkpoint (a plain string)."""


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


def _tensors(value: Any, path: str = "") -> Iterator[tuple[str, torch.Tensor]]:
    """Every tensor in nested dicts / lists / tuples, with a path naming where it sits."""
    if isinstance(value, torch.Tensor):
        yield path, value
    elif isinstance(value, dict):
        for key, item in value.items():
            yield from _tensors(item, f"{path}/{key!r}")
    elif isinstance(value, list | tuple):
        for index, item in enumerate(value):
            yield from _tensors(item, f"{path}/{index}")


def tensors_digest(state: dict[str, Any]) -> str:
    """SHA-256 over every tensor of ``state``: its path, dtype, shape and bytes, in path order
    (so the digest does not depend on the order in which the dicts were filled)."""
    digest = hashlib.sha256()
    for name, tensor in sorted(_tensors(state), key=lambda item: item[0]):
        digest.update(f"{name} {tensor.dtype} {tuple(tensor.shape)}\n".encode())
        flat = tensor.detach().cpu().reshape(-1)
        if flat.stride(0) != 1:  # a tensor of one element (or none) may have a stride of 0
            flat = torch.empty(flat.shape, dtype=flat.dtype).copy_(flat)
        digest.update(flat.view(torch.uint8).numpy())
    return digest.hexdigest()


def _temporary_prefix(path: Path) -> str:
    return f".{path.name}."


def save_checkpoint(path: str | os.PathLike[str], state: dict[str, Any]) -> Path:
    """Write ``state`` and the checksum of its tensors to ``path`` atomically (temporary file +
    ``os.replace``), its tensors on the CPU (:func:`on_cpu`)."""
    state = on_cpu(state)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    stored = {**state, CHECKSUM_KEY: tensors_digest(state)}
    fd, tmp_name = tempfile.mkstemp(prefix=_temporary_prefix(path), suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            torch.save(stored, handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp_name, path)
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise
    return path


def remove_stale_temporaries(path: str | os.PathLike[str]) -> list[Path]:
    """Delete what a killed :func:`save_checkpoint` of ``path`` left behind: files named exactly
    like its temporaries (``.NAME.XXXXXXXX.tmp``, ``tempfile``'s eight random characters), nothing
    else. Only for a directory no other process is writing ``path`` into. Returns them."""
    path = Path(path)
    pattern = re.compile(re.escape(_temporary_prefix(path)) + r"[a-z0-9_]{8}\.tmp")
    stale = [
        p for p in path.parent.glob(f"{_temporary_prefix(path)}*.tmp") if pattern.fullmatch(p.name)
    ]
    for orphan in stale:
        orphan.unlink(missing_ok=True)
    return stale


def load_checkpoint(path: str | os.PathLike[str], required: tuple[str, ...] = ()) -> dict:
    """Read a checkpoint written by :func:`save_checkpoint` and verify its checksum (the entry
    is removed from the returned state); errors name the file."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint {path} does not exist")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except (RuntimeError, EOFError, OSError, pickle.UnpicklingError, zipfile.BadZipFile) as err:
        raise CheckpointError(f"checkpoint {path} is corrupt or unreadable: {err}") from err
    if not isinstance(state, dict):
        raise CheckpointError(f"checkpoint {path} holds a {type(state).__name__}, not a dict")
    checksum = state.pop(CHECKSUM_KEY, None)
    if checksum is not None and checksum != tensors_digest(state):
        raise CheckpointError(
            f"checkpoint {path} is corrupt: its tensors do not match the checksum saved with them"
        )
    missing = [key for key in required if key not in state]
    if missing:
        raise CheckpointError(f"checkpoint {path} lacks the entries {missing}")
    return state


@contextmanager
def fitting(path: str | os.PathLike[str]) -> Iterator[None]:
    """Around loading a checkpoint's entries into objects built from its config: an entry that
    does not fit them (weights of another shape, a missing key, a foreign RNG state) is the
    checkpoint's fault, so it becomes a one-line :class:`CheckpointError` naming the file
    instead of torch's multi-line traceback."""
    try:
        yield
    except CheckpointError:
        raise
    except (RuntimeError, KeyError, ValueError, TypeError) as err:
        detail = " ".join(str(err).split())
        if "state_dict" in detail:  # a network of another architecture wrote it
            detail = (
                "its networks have another architecture (other settings, another method, or a "
                f"maopg version whose networks differ from this one's): {detail}"
            )
        raise CheckpointError(
            f"checkpoint {path} does not fit the run it is loaded into: {detail}"
        ) from err


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
