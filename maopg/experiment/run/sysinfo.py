"""The conditions a measurement was taken under: machine, library versions, the torch device,
the GL vendor and renderer.

Benchmarks print these beside their figures, so a number is never separated from what produced
it (a training run records its resolved ``device`` in its ``config.json``). Two devices matter
and they are chosen apart: torch's (``device=auto`` takes CUDA where torch sees it) and
MuJoCo's, which renders through EGL on the GPU when the driver offers one (software Mesa
otherwise; ``MUJOCO_EGL_DEVICE_ID`` picks among several).
"""

from __future__ import annotations

import os
import platform
import sys
from pathlib import Path


def cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


BF16_FLAGS = ("avx512_bf16", "amx_bf16")
"""``/proc/cpuinfo`` flags of the instructions that compute in bf16 (``precision=bf16`` is fast
only with one of them: elsewhere oneDNN converts to float32 and back around every operation)."""


def bf16_instructions() -> list[str]:
    """Which of :data:`BF16_FLAGS` this CPU has (none where ``/proc/cpuinfo`` is missing)."""
    try:
        flags = next(
            set(line.split(":", 1)[1].split())
            for line in Path("/proc/cpuinfo").read_text().splitlines()
            if line.startswith("flags")
        )
    except (OSError, StopIteration):
        return []
    return [f for f in BF16_FLAGS if f in flags]


def cpu_extensions() -> str:
    """The widest vector instructions torch's CPU kernels use here, and the CPU's bf16 ones."""
    import torch

    bf16 = ", ".join(bf16_instructions()) or "none"
    return f"{torch.backends.cpu.get_cpu_capability()}, bf16 instructions: {bf16}"


def torch_device() -> str:
    """What ``device=auto`` resolves to on this machine, with the GPU's name."""
    import torch

    if not torch.cuda.is_available():
        return f"cpu (device=auto; torch {torch.__version__} sees no CUDA device)"
    index = torch.cuda.current_device()
    return (
        f"cuda:{index} {torch.cuda.get_device_name(index)} (device=auto; "
        f"{torch.cuda.device_count()} visible, CUDA {torch.version.cuda})"
    )


def conditions(gl: bool = True) -> dict[str, str]:
    """Machine and versions; ``gl=True`` also renders one frame to name the GL renderer."""
    import mujoco
    import numpy as np
    import torch

    info = {
        "machine": f"{cpu_name()}, {os.cpu_count()} CPUs, {platform.system()} {platform.release()}",
        "python": sys.version.split()[0],
        "mujoco": mujoco.__version__,
        "torch": torch.__version__,
        "torch_threads": str(torch.get_num_threads()),
        "cpu vector extensions": cpu_extensions(),
        "torch device": torch_device(),
        "numpy": np.__version__,
        # Other processes share the cores: timings taken under load read slower.
        "load average (1 min) at start": f"{os.getloadavg()[0]:.2f}",
    }
    if gl:
        from maopg.sim.egl_check import gl_strings

        vendor, renderer = gl_strings()
        chosen = os.environ.get("MUJOCO_EGL_DEVICE_ID")
        where = "" if chosen is None else f", MUJOCO_EGL_DEVICE_ID={chosen}"
        info["gl"] = f"MUJOCO_GL={os.environ.get('MUJOCO_GL')}{where}, {vendor}: {renderer}"
    return info


def markdown(gl: bool = True) -> str:
    """``conditions()`` as a Markdown bullet list."""
    return "\n".join(f"- {k}: {v}" for k, v in conditions(gl).items())
