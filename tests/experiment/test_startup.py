"""Start-up costs a short run must not pay (``bench/perf/startup.py`` measures them): a training
process with ``plot=false video=false`` imports neither torch's compiler (``torch._dynamo``,
~1 s: :mod:`maopg.learner.adam`) nor sympy (~0.3 s: :func:`maopg.policy.unravel_joint`) nor
matplotlib (~0.3 s), and the replacements compute what torch's own functions do."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import torch

from maopg.policy import ravel_joint, unravel_joint

HEAVY = ("torch._dynamo", "sympy", "matplotlib")
RUN = (
    "import json, sys\n"
    "from maopg.experiment.cli.train_cli import main\n"
    "root = sys.argv[1]\n"
    "for method, extra in (('async', 'ppo.epochs=2'), ('mac-dqn', 'dqn.learning_starts=60')):\n"
    "    argv = ['--method', method, '--total-samples', '180', 'batch_ticks=60', 'num_envs=2',\n"
    "            'env.max_ticks=40', 'progress=false', 'video=false', 'eval_episodes=0',\n"
    "            'plot=false', extra,\n"
    "            'dqn.train_every=20' if method == 'mac-dqn' else 'ppo.num_minibatches=2',\n"
    "            '--run-dir', f'{root}/{method}']\n"
    "    assert main(argv) == 0\n"
    f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))\n"
)


def test_a_short_run_imports_no_compiler_sympy_or_matplotlib(tmp_path):
    done = subprocess.run(
        [sys.executable, "-c", RUN, str(tmp_path)], capture_output=True, text=True, check=True
    )
    assert json.loads(done.stdout.splitlines()[-1]) == []
    for method in ("async", "mac-dqn"):
        assert (tmp_path / method / "done.json").is_file()


def test_unravel_joint_is_torch_unravel_index():
    for counts in [(3, 3, 6), (2,), (4, 5), (6, 3, 3, 2)]:
        flat = torch.arange(math.prod(counts))
        ours = unravel_joint(flat, counts)
        assert torch.equal(ours, torch.stack(torch.unravel_index(flat, counts), dim=-1))
        assert ours.dtype == torch.int64 and torch.equal(ravel_joint(ours, counts), flat)
