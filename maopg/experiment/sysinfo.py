"""The conditions a measurement was taken under: machine, library versions, GL renderer.

Benchmarks print these beside their figures and training runs store them in their config, so a
number is never separated from what produced it.
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
        "numpy": np.__version__,
        # Other processes share the cores: timings taken under load read slower.
        "load average (1 min) at start": f"{os.getloadavg()[0]:.2f}",
    }
    if gl:
        from maopg.sim.egl_check import check

        info["gl"] = f"MUJOCO_GL={os.environ.get('MUJOCO_GL')}, {check()}"
    return info


def markdown(gl: bool = True) -> str:
    """``conditions()`` as a Markdown bullet list."""
    return "\n".join(f"- {k}: {v}" for k, v in conditions(gl).items())
