"""Adam for the learners: ``torch.optim.Adam``'s arithmetic and checkpoint format, without the
second of start-up that ``torch.optim.Optimizer`` costs.

Why not ``torch.optim.Adam`` itself: in torch 2.13 building *any* ``torch.optim.Optimizer``
imports ``torch._dynamo`` (``add_param_group``, called by the constructor, is wrapped in
``torch._disable_dynamo``, which imports it on first call), and so does every ``step()``
(``_use_grad_for_differentiable`` imports it and calls ``torch._dynamo.graph_break()``), whatever
``foreach``, ``fused`` or ``differentiable`` say. Building an optimiser and its first step in a
fresh process take 1.67 s with ``torch.optim.Adam`` and 0.001 s here (``bench/perf/
learner_plumbing.py``, side by side): paid by every training process, for a compiler the
learners never use.

What is kept: the update is torch's own, the public functional ``torch.optim.adam.adam`` called
with the arguments ``torch.optim.Adam.step`` passes for a parameter group of its defaults (so
``foreach`` is chosen by torch as for ``Adam``: off on the CPU, on for CUDA parameters), on
state initialised as ``Adam._init_group`` does. The results are bit-identical to
``torch.optim.Adam``'s, and :meth:`Adam.state_dict` is in its format, so checkpoints written
with ``torch.optim.Adam`` resume here and the other way round (``tests/learner/test_adam.py``
checks both, and that neither building nor stepping imports ``torch._dynamo``).

Only what the learners use is supported: one parameter group, no weight decay, no AMSGrad.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import torch
from torch import Tensor
from torch.optim.adam import adam


class Adam:
    """``torch.optim.Adam(params, lr=lr, betas=betas, eps=eps)`` (module docstring)."""

    def __init__(
        self,
        params: Iterable[Tensor],
        lr: float = 1e-3,
        betas: tuple[float, float] = (0.9, 0.999),
        eps: float = 1e-8,
    ) -> None:
        self.params = list(params)
        if not self.params:
            raise ValueError("optimizer got an empty parameter list")
        self.group: dict[str, Any] = {
            "lr": lr,
            "betas": betas,
            "eps": eps,
            "weight_decay": 0,
            "amsgrad": False,
            "maximize": False,
            "foreach": None,
            "capturable": False,
            "differentiable": False,
            "fused": None,
        }
        """The hyper-parameters, keyed as in ``torch.optim.Adam``'s ``param_groups[0]``."""
        self.state: dict[int, dict[str, Tensor]] = {}
        """Per parameter index: ``step`` (a CPU scalar tensor), ``exp_avg``, ``exp_avg_sq``."""

    def zero_grad(self) -> None:
        """Drop the gradients (``torch.optim.Optimizer.zero_grad``'s default ``set_to_none``)."""
        for param in self.params:
            param.grad = None

    @torch.no_grad()
    def step(self) -> None:
        """One Adam update of every parameter that has a gradient."""
        with_grad = [(i, p) for i, p in enumerate(self.params) if p.grad is not None]
        for i, param in with_grad:
            if i not in self.state:
                self.state[i] = {
                    # Adam._init_group (not capturable, not fused): a CPU scalar step.
                    "step": torch.tensor(0.0, dtype=_scalar_dtype()),
                    "exp_avg": torch.zeros_like(param, memory_format=torch.preserve_format),
                    "exp_avg_sq": torch.zeros_like(param, memory_format=torch.preserve_format),
                }
        states = [self.state[i] for i, _ in with_grad]
        params = [p for _, p in with_grad]
        group = self.group
        beta1, beta2 = group["betas"]
        adam(
            params,
            [p.grad for p in params],
            [s["exp_avg"] for s in states],
            [s["exp_avg_sq"] for s in states],
            [],
            [s["step"] for s in states],
            foreach=group["foreach"],
            capturable=group["capturable"],
            differentiable=group["differentiable"],
            fused=group["fused"],
            grad_scale=None,
            found_inf=None,
            has_complex=any(torch.is_complex(p) for p in params),
            amsgrad=group["amsgrad"],
            beta1=beta1,
            beta2=beta2,
            lr=group["lr"],
            weight_decay=group["weight_decay"],
            eps=group["eps"],
            maximize=group["maximize"],
        )

    def state_dict(self) -> dict[str, Any]:
        """In ``torch.optim.Adam.state_dict()``'s format (state by parameter index)."""
        return {
            "state": {i: dict(self.state[i]) for i in sorted(self.state)},
            "param_groups": [{**self.group, "params": list(range(len(self.params)))}],
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Load :meth:`state_dict`'s (or ``torch.optim.Adam``'s) format: the saved
        hyper-parameters, and the moments moved to their parameters' devices and dtypes (the
        step stays a CPU scalar), as ``torch.optim.Optimizer.load_state_dict`` does."""
        groups = state["param_groups"]
        if len(groups) != 1 or len(groups[0]["params"]) != len(self.params):
            sizes = [len(g["params"]) for g in groups]
            raise ValueError(
                f"loaded state dict has parameter groups of sizes {sizes}, "
                f"this optimizer one of {len(self.params)}"
            )
        saved = groups[0]
        self.group.update({key: saved[key] for key in self.group if key in saved})
        self.group["betas"] = tuple(self.group["betas"])
        index = {saved_id: i for i, saved_id in enumerate(saved["params"])}
        self.state = {}
        for saved_id, entry in state["state"].items():
            param = self.params[index[saved_id]]
            self.state[index[saved_id]] = {
                key: value if key == "step" else value.to(device=param.device, dtype=param.dtype)
                for key, value in entry.items()
            }


def _scalar_dtype() -> torch.dtype:
    """The dtype ``torch.optim`` keeps ``step`` in (float64 only under a float64 default)."""
    return torch.float64 if torch.get_default_dtype() == torch.float64 else torch.float32
