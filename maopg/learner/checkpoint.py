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
other weights, and an edited entry (a config whose method was relabelled) as another run's:
every checkpoint also stores a SHA-256 of all its other entries, tensors and plain values
(:data:`CHECKSUM_KEY`, :func:`state_digest`), which loading verifies, and a checkpoint without
it is refused. Checkpoints of earlier releases carry a checksum of their tensors alone
(:data:`TENSORS_CHECKSUM_KEY`) or, the earliest, none; the caller that knows their format says
which it accepts (``accepts`` of :func:`load_checkpoint`;
:func:`maopg.experiment.run.migration.read_checkpoint` from the checkpoint's schema).

A write the machine refuses — a full disk, a read-only file system — is an ``OSError`` naming
the checkpoint (not its temporary) and saying that the one before it is intact: the temporary
goes, the previous file was never touched.
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
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import torch

from maopg.learner.errors import CheckpointError

CHECKSUM_KEY = "sha256"
"""The entry holding :func:`state_digest` of the rest of the checkpoint (a plain string)."""
TENSORS_CHECKSUM_KEY = "tensors_sha256"
"""Where checkpoints of earlier releases hold :func:`tensors_digest` of their tensors alone."""


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


def _nodes(value: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    """Every node of nested dicts / lists / tuples — the containers themselves, then what they
    hold: tensors and plain values — with a path naming where it sits."""
    yield path, value
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _nodes(item, f"{path}/{key!r}")
    elif isinstance(value, list | tuple):
        for index, item in enumerate(value):
            yield from _nodes(item, f"{path}/{index}")


def _tensors(value: Any) -> list[tuple[str, torch.Tensor]]:
    """Every tensor in nested dicts / lists / tuples, with its path."""
    return [(path, node) for path, node in _nodes(value) if isinstance(node, torch.Tensor)]


def _add_tensor(digest: Any, name: str, tensor: torch.Tensor) -> None:
    digest.update(f"{name} {tensor.dtype} {tuple(tensor.shape)}\n".encode())
    flat = tensor.detach().cpu().reshape(-1)
    if flat.stride(0) != 1:  # a tensor of one element (or none) may have a stride of 0
        flat = torch.empty(flat.shape, dtype=flat.dtype).copy_(flat)
    digest.update(flat.view(torch.uint8).numpy())


def tensors_digest(state: dict[str, Any]) -> str:
    """SHA-256 over every tensor of ``state``: its path, dtype, shape and bytes, in path order
    (so the digest does not depend on the order in which the dicts were filled). The checksum
    of earlier releases' checkpoints (:data:`TENSORS_CHECKSUM_KEY`)."""
    digest = hashlib.sha256()
    for name, tensor in sorted(_tensors(state), key=lambda item: item[0]):
        _add_tensor(digest, name, tensor)
    return digest.hexdigest()


def state_digest(state: dict[str, Any]) -> str:
    """SHA-256 over everything in ``state``, in path order: each tensor as
    :func:`tensors_digest` hashes it, each plain value as its ``repr`` (its type shows: ``1``,
    ``1.0``, ``'1'`` and ``True`` differ, and floats round-trip exactly), each container by its
    kind and size (a list is no tuple, an emptied dict no missing one; an ``OrderedDict`` is a
    dict)."""
    digest = hashlib.sha256()
    for name, node in sorted(_nodes(state), key=lambda item: item[0]):
        if isinstance(node, torch.Tensor):
            _add_tensor(digest, name, node)
        elif isinstance(node, dict | list | tuple):
            kind = next(k for k in (dict, list, tuple) if isinstance(node, k)).__name__
            digest.update(f"{name} {kind} of {len(node)}\n".encode())
        else:
            digest.update(f"{name} = {node!r}\n".encode())
    return digest.hexdigest()


DIGESTS: dict[str, Callable[[dict[str, Any]], str]] = {
    CHECKSUM_KEY: state_digest,
    TENSORS_CHECKSUM_KEY: tensors_digest,
}
"""The digest each checksum entry holds."""


def _temporary_prefix(path: Path) -> str:
    return f".{path.name}."


def _refused(err: OSError, path: Path) -> OSError:
    """The machine's refusal ``err`` of a write of ``path`` (a full disk, a read-only file
    system), as an error of its kind naming ``path`` and saying that the file is as it was."""
    if err.errno is None:
        return err
    kept = f" (the {path.name} there before is intact)" if path.exists() else ""
    return type(err)(err.errno, f"{err.strerror}{kept}", str(path))


def save_checkpoint(path: str | os.PathLike[str], state: dict[str, Any]) -> Path:
    """Write ``state`` and its checksum (:func:`state_digest`) to ``path`` atomically
    (temporary file + ``os.replace``), its tensors on the CPU (:func:`on_cpu`). A write the
    machine refuses is an ``OSError`` naming ``path`` (module docstring)."""
    state = on_cpu(state)
    path = Path(path)
    stored = {**state, CHECKSUM_KEY: state_digest(state)}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(
            prefix=_temporary_prefix(path), suffix=".tmp", dir=path.parent
        )
    except OSError as err:
        raise _refused(err, path) from err
    try:
        with os.fdopen(fd, "wb") as handle:
            torch.save(stored, handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp_name, path)
    except BaseException as err:
        Path(tmp_name).unlink(missing_ok=True)
        if isinstance(err, OSError):
            raise _refused(err, path) from err
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


def _only_ours(state: dict[str, Any]) -> tuple[str | None, ...]:
    return (CHECKSUM_KEY,)


def load_checkpoint(
    path: str | os.PathLike[str],
    required: tuple[str, ...] = (),
    *,
    accepts: Callable[[dict[str, Any]], Collection[str | None]] = _only_ours,
) -> dict:
    """Read a checkpoint written by :func:`save_checkpoint` and verify its checksum (the entry
    is removed from the returned state); errors name the file.

    ``accepts(state)`` says which checksum entries a checkpoint holding ``state`` may carry —
    :data:`TENSORS_CHECKSUM_KEY` and ``None`` (none at all) for the formats of earlier releases,
    which only their caller knows (:func:`maopg.experiment.run.migration.read_checkpoint`); by
    default :data:`CHECKSUM_KEY` alone, so that a checkpoint whose checksum was deleted is
    refused rather than loaded unverified.
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"checkpoint {path} does not exist")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except (RuntimeError, EOFError, OSError, pickle.UnpicklingError, zipfile.BadZipFile) as err:
        raise CheckpointError(f"checkpoint {path} is corrupt or unreadable: {err}") from err
    if not isinstance(state, dict):
        raise CheckpointError(f"checkpoint {path} holds a {type(state).__name__}, not a dict")
    checksums = {key: state.pop(key) for key in DIGESTS if key in state}
    kind = next(iter(checksums), None)  # the checksum over everything first
    if kind not in accepts(state):
        has = "none" if kind is None else f"only {kind!r}, over its tensors alone"
        raise CheckpointError(
            f"checkpoint {path} lacks the checksum its format carries ({CHECKSUM_KEY!r}; it has "
            f"{has}), so what it holds cannot be verified: was it edited?"
        )
    if kind is not None and checksums[kind] != DIGESTS[kind](state):
        what = "tensors" if kind == TENSORS_CHECKSUM_KEY else "entries"
        raise CheckpointError(
            f"checkpoint {path} is corrupt or was edited: its {what} do not match the checksum "
            "saved with them"
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
