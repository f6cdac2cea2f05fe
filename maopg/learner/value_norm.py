"""Running normalisation of value targets (MAPPO's "ValueNorm").

Returns in our tasks span hundreds (Tool Delivery: −150 .. +260) and drift as the policy
improves; a critic regressing raw returns sees huge, moving gradients. MAPPO instead has the critic
predict *normalised* values, keeps a running mean and variance of the value targets, and
denormalises predictions whenever they enter GAE. The statistics are exponential moving averages
with a debiasing term (as in Adam), so the first updates are not biased towards zero.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn


class ValueNorm(nn.Module):
    """Running mean/variance of scalar value targets, kept as buffers (saved in ``state_dict``).

    ``beta`` is the per-sample decay: a batch of ``n`` targets decays the old statistics by
    ``beta**n``, so the memory is measured in samples, not in update calls.
    """

    def __init__(self, beta: float = 0.99999, epsilon: float = 1e-5, min_var: float = 1e-2):
        super().__init__()
        self.beta = beta
        self.epsilon = epsilon
        self.min_var = min_var
        self.register_buffer("running_mean", torch.zeros((), dtype=torch.float64))
        self.register_buffer("running_mean_sq", torch.zeros((), dtype=torch.float64))
        self.register_buffer("debias", torch.zeros((), dtype=torch.float64))

    @torch.no_grad()
    def update(self, targets: Tensor) -> None:
        """Fold a batch of value targets (any shape) into the running statistics."""
        x = targets.detach().to(self.running_mean.device, torch.float64).reshape(-1)
        if x.numel() == 0:
            return
        weight = self.beta ** x.numel()
        self.running_mean.mul_(weight).add_((1.0 - weight) * x.mean())
        self.running_mean_sq.mul_(weight).add_((1.0 - weight) * (x * x).mean())
        self.debias.mul_(weight).add_(1.0 - weight)

    def mean_var(self, device: torch.device | None = None) -> tuple[Tensor, Tensor]:
        """Debiased mean and variance (variance floored at ``min_var`` for a stable scale), on
        ``device`` (default: the buffers'). The statistics live with the learner's networks,
        but GAE denormalises on the CPU, so the two scalars travel to the values, not back."""
        debias = self.debias.clamp(min=self.epsilon)
        mean = self.running_mean / debias
        var = (self.running_mean_sq / debias - mean * mean).clamp(min=self.min_var)
        return mean.to(device), var.to(device)

    def normalize(self, values: Tensor) -> Tensor:
        mean, var = self.mean_var(values.device)
        return ((values.to(torch.float64) - mean) / var.sqrt()).to(values.dtype)

    def denormalize(self, values: Tensor) -> Tensor:
        mean, var = self.mean_var(values.device)
        return (values.to(torch.float64) * var.sqrt() + mean).to(values.dtype)
