"""The learners' Adam against ``torch.optim.Adam``: the same bits after many steps, checkpoints
that load either way, and no ``torch._dynamo`` import (the reason it exists)."""

from __future__ import annotations

import subprocess
import sys

import pytest
import torch
from torch import nn

from maopg.learner import Adam


def _networks() -> tuple[nn.Module, nn.Module]:
    """Two copies of one small network (an MLP and a GRU, like the learners')."""
    torch.manual_seed(0)
    net = nn.ModuleDict({"mlp": nn.Sequential(nn.Linear(5, 16), nn.Tanh(), nn.Linear(16, 3))})
    net["gru"] = nn.GRU(3, 4, batch_first=True)
    twin = nn.ModuleDict({"mlp": nn.Sequential(nn.Linear(5, 16), nn.Tanh(), nn.Linear(16, 3))})
    twin["gru"] = nn.GRU(3, 4, batch_first=True)
    twin.load_state_dict(net.state_dict())
    return net, twin


def _train(net: nn.Module, optimizer, steps: int, seed: int) -> None:
    """``steps`` clipped gradient steps on seeded data (the learners' zero/backward/clip/step)."""
    data = torch.Generator().manual_seed(seed)
    for _ in range(steps):
        x = torch.randn(8, 2, 5, generator=data)
        out, _ = net["gru"](net["mlp"](x))
        loss = out.pow(2).mean() + out.sum() * 1e-3
        optimizer.zero_grad()
        loss.backward()
        nn.utils.clip_grad_norm_(net.parameters(), 0.5)
        optimizer.step()


def _same(a, b) -> bool:
    if isinstance(a, torch.Tensor):
        return isinstance(b, torch.Tensor) and a.dtype == b.dtype and torch.equal(a, b)
    if isinstance(a, dict):
        return set(a) <= set(b) and all(_same(v, b[k]) for k, v in a.items())
    if isinstance(a, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return a == b


@pytest.mark.parametrize("kwargs", [{"lr": 5e-4, "eps": 1e-5}, {"lr": 6e-4}])
def test_bit_identical_to_torch_adam(kwargs):
    ours_net, torch_net = _networks()
    ours, theirs = (
        Adam(ours_net.parameters(), **kwargs),
        torch.optim.Adam(torch_net.parameters(), **kwargs),
    )
    _train(ours_net, ours, 25, seed=1)
    _train(torch_net, theirs, 25, seed=1)
    for a, b in zip(ours_net.parameters(), torch_net.parameters(), strict=True):
        assert torch.equal(a, b)
    # Our state dict is torch's (which also carries keys of newer options, all at defaults).
    assert _same(ours.state_dict(), theirs.state_dict())


def test_checkpoints_interchange_with_torch_adam():
    """A torch.optim.Adam checkpoint (as every run before this class wrote) resumes here, and
    ours resumes in torch.optim.Adam, both continuing bit for bit."""
    ours_net, torch_net = _networks()
    ours, theirs = (
        Adam(ours_net.parameters(), lr=1e-3),
        torch.optim.Adam(torch_net.parameters(), lr=1e-3),
    )
    _train(ours_net, ours, 5, seed=2)
    _train(torch_net, theirs, 5, seed=2)
    resumed = Adam(torch_net.parameters(), lr=0.5)  # the saved lr wins, as in torch
    resumed.load_state_dict(theirs.state_dict())
    back = torch.optim.Adam(ours_net.parameters(), lr=0.5)
    back.load_state_dict(ours.state_dict())
    _train(torch_net, resumed, 5, seed=3)
    _train(ours_net, back, 5, seed=3)
    for a, b in zip(ours_net.parameters(), torch_net.parameters(), strict=True):
        assert torch.equal(a, b)
    with pytest.raises(ValueError, match="parameter groups of sizes"):
        Adam(list(ours_net.parameters())[:2]).load_state_dict(ours.state_dict())


def test_building_and_stepping_does_not_import_dynamo():
    code = (
        "import sys, torch\n"
        "from maopg.learner import Adam\n"
        "net = torch.nn.Linear(3, 2)\n"
        "opt = Adam(net.parameters())\n"
        "net(torch.ones(1, 3)).sum().backward()\n"
        "opt.step(); opt.load_state_dict(opt.state_dict()); opt.zero_grad()\n"
        "print('torch._dynamo' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False"]
