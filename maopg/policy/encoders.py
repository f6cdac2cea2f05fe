"""Observation encoders shared by the policies, the critic and Mac-DQN's Q-net (docs/DESIGN.md §5).

Images go through one small Nature-style CNN whose weights are shared by every camera the
encoder sees (agents' cameras look at the same world, and one set of weights learns from N times
the images); the per-camera features are concatenated with the observation vectors and mixed by
an MLP. :class:`JointEncoder` reads every agent's observation (the centralized policy and critic);
:class:`LocalEncoder` reads one agent's own (the partially centralized policy).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
from torch import Tensor, nn

from maopg.env.contract import EnvSpec, ImageChannels
from maopg.policy.batch import ObsBatch, compact_bank, vector_slices
from maopg.policy.choices import PRECISION_NAMES

__all__ = [
    "PRECISIONS",
    "JointEncoder",
    "LocalEncoder",
    "NatureCNN",
    "ObsBatch",
    "init_orthogonal",
    "set_precision",
]

RELU_GAIN = math.sqrt(2.0)

PRECISIONS: dict[str, torch.dtype] = dict(
    zip(PRECISION_NAMES, (torch.float32, torch.bfloat16), strict=True)
)
"""The ``precision`` setting → the dtype the CNNs compute in (:func:`set_precision`)."""


def init_orthogonal(module: nn.Module, gain: float) -> None:
    """Orthogonal weights with ``gain`` and zero biases on every Linear/Conv2d in ``module``.

    The MAPPO reference initialisation: ``sqrt(2)`` for ReLU layers; heads set their own gain.
    """
    for layer in module.modules():
        if isinstance(layer, nn.Linear | nn.Conv2d):
            nn.init.orthogonal_(layer.weight, gain=gain)
            nn.init.zeros_(layer.bias)


def image_inputs(images: Tensor, channels: ImageChannels) -> Tensor:
    """``float [M, C, H, W]`` CNN inputs of images ``[M, H, W, planes]`` holding ``channels``,
    each channel normalised to [0, 1]: colour divided by 255, depth as ``(d - near) / (far -
    near)`` (clipped: :attr:`~ImageChannels.depth_range`), segmentation one-hot over the
    task's classes (a class id is a category, not a quantity), so ``C`` is
    :attr:`~ImageChannels.inputs`: 3 + 1 + K with every channel on."""
    if channels.names == ("rgb",):  # colour alone: the bytes straight to floats
        return images.permute(0, 3, 1, 2).float().div_(255.0)
    parts = []
    for name in channels.names:
        plane = images[..., channels.plane_slice(name)].float()
        if name == "rgb":
            parts.append(plane.div_(255.0))
        elif name == "depth":
            near, far = channels.depth_range  # type: ignore[misc]  (depth is on)
            parts.append(plane.sub_(near).div_(far - near).clamp_(0.0, 1.0))
        else:
            ids = plane[..., 0].long().clamp_(0, len(channels.classes) - 1)
            parts.append(nn.functional.one_hot(ids, len(channels.classes)).float())
    return torch.cat(parts, dim=-1).permute(0, 3, 1, 2)


class NatureCNN(nn.Module):
    """The DQN-Nature conv stack (32-64-64 channels) + a linear layer, for 36-128 px cameras.

    Input: images ``[M, H, W, planes]`` straight from the environment, of ``channels``
    (default colour alone, uint8 ``[M, H, W, 3]``): normalised per channel here
    (:func:`image_inputs`) so rollout buffers keep the environment's compact form. The first
    convolution reads :attr:`~ImageChannels.inputs` channels, so a checkpoint's weights fit
    the channels it was trained with. Output: ``float [M, features]`` (after ReLU).
    """

    MIN_SIZE = 36
    """Smallest side the 8/4 → 4/2 → 3/1 conv stack maps to at least one pixel."""

    def __init__(
        self,
        image_shape: tuple[int, int, int],
        features: int = 256,
        channels: ImageChannels | None = None,
    ) -> None:
        super().__init__()
        channels = channels or ImageChannels()
        height, width, planes = image_shape
        if min(height, width) < self.MIN_SIZE or planes != channels.planes:
            raise ValueError(
                f"NatureCNN needs images of at least {self.MIN_SIZE}x{self.MIN_SIZE} "
                f"(image_size >= {self.MIN_SIZE}) with the {channels.planes} planes of "
                f"{'+'.join(channels.names)}, got {image_shape}"
            )
        self.image_shape = tuple(image_shape)
        self.channels = channels
        self._dtype = getattr(torch, channels.dtype)
        self.convs = nn.Sequential(
            nn.Conv2d(channels.inputs, 32, kernel_size=8, stride=4),
            nn.ReLU(),
            nn.Conv2d(32, 64, kernel_size=4, stride=2),
            nn.ReLU(),
            nn.Conv2d(64, 64, kernel_size=3, stride=1),
            nn.ReLU(),
            nn.Flatten(),
        )
        with torch.no_grad():
            flat = self.convs(torch.zeros(1, channels.inputs, height, width)).shape[1]
        self.fc = nn.Sequential(nn.Linear(flat, features), nn.ReLU())
        self.out_dim = features
        init_orthogonal(self, RELU_GAIN)

        self.compute_dtype = torch.float32
        """What the convolutions and the linear layer compute in (:func:`set_precision`); the
        weights, their gradients and the output stay ``float32`` whatever it is."""

    @classmethod
    def of_spec(cls, spec: EnvSpec, features: int = 256) -> NatureCNN:
        """The CNN for the camera images of ``spec`` (which must have them)."""
        if spec.image_shape is None:
            raise ValueError(f"task {spec.task!r} was created without images")
        return cls(spec.image_shape, features, spec.image_channels)

    def forward(self, images: Tensor) -> Tensor:
        if images.dtype != self._dtype:
            raise TypeError(
                f"NatureCNN takes {self.channels.dtype} images of {'+'.join(self.channels.names)} "
                f"(normalised here), got {images.dtype}"
            )
        x = image_inputs(images, self.channels)
        if self.compute_dtype == torch.float32:
            return self.fc(self.convs(x))
        with torch.autocast(x.device.type, dtype=self.compute_dtype):
            features = self.fc(self.convs(x))
        return features.float()


def set_precision(module: nn.Module, precision: str) -> None:
    """Let every :class:`NatureCNN` inside ``module`` compute in ``precision`` (a key of
    :data:`PRECISIONS`).

    Why only the CNNs: from camera images they are nearly all of a run's arithmetic (the PPO
    update runs them forward and backward over every distinct image, ten epochs per
    iteration), and on a CPU with bf16 instructions (AVX512-BF16, AMX) or a recent GPU they run
    about twice as fast in ``bf16``. The MLPs, heads, GRU cells, losses and optimiser stay in
    ``float32``: they are cheap, and the log-probabilities and value targets PPO takes ratios
    and differences of need the precision. A run is as deterministic in ``bf16`` as in ``fp32``
    on the same machine, but it follows another trajectory: a curve is reproduced with the
    precision it was trained in (``config.json`` records it).
    """
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {list(PRECISIONS)}, got {precision!r}")
    for layer in module.modules():
        if isinstance(layer, NatureCNN):
            layer.compute_dtype = PRECISIONS[precision]


def _mlp(in_dim: int, hidden: int, layers: int) -> nn.Sequential:
    """``layers`` × (Linear → ReLU), orthogonally initialised for ReLU."""
    modules: list[nn.Module] = []
    for index in range(layers):
        modules += [nn.Linear(in_dim if index == 0 else hidden, hidden), nn.ReLU()]
    mlp = nn.Sequential(*modules)
    init_orthogonal(mlp, RELU_GAIN)
    return mlp


class _FusionEncoder(nn.Module):
    """Images of a subset of agents through one shared CNN, concatenated with their vectors, MLP.

    ``agents`` selects whose vectors (columns of :attr:`ObsBatch.vectors`) and cameras are read.
    """

    def __init__(
        self,
        spec: EnvSpec,
        agents: Sequence[int],
        hidden: int,
        layers: int,
        cnn_features: int,
        use_images: bool | None,
    ) -> None:
        super().__init__()
        if use_images is None:
            use_images = spec.image_shape is not None
        if use_images and spec.image_shape is None:
            raise ValueError(f"task {spec.task!r} was created without images")
        self.agents = tuple(agents)
        slices = vector_slices(spec)
        columns = [c for a in self.agents for c in range(slices[a].start, slices[a].stop)]
        self._all_columns = len(columns) == slices[-1].stop
        self.register_buffer("columns", torch.tensor(columns, dtype=torch.long), persistent=False)
        self.register_buffer(
            "cameras", torch.tensor(self.agents, dtype=torch.long), persistent=False
        )
        self.cnn = NatureCNN.of_spec(spec, cnn_features) if use_images else None
        in_dim = len(columns) + (len(self.agents) * cnn_features if use_images else 0)
        if in_dim == 0:
            raise ValueError("nothing to encode: no vector entries and images off")
        self.mlp = _mlp(in_dim, hidden, layers)
        self.out_dim = hidden

    def image_features(self, obs: ObsBatch) -> Tensor:
        """``[B, n_agents, cnn_features]`` of this encoder's agents' cameras.

        A banked batch runs the CNN once per distinct image these cameras saw and gathers the
        features per point: the same numbers as encoding every point's images (each image goes
        through the CNN on its own), at a fraction of the cost when agents continue.
        """
        assert self.cnn is not None and obs.images is not None
        if obs.image_index is None:
            selected = obs.images.index_select(1, self.cameras)
            batch, cams = selected.shape[:2]
            features = self.cnn(selected.reshape(batch * cams, *selected.shape[2:]))
            return features.view(batch, cams, -1)
        bank, index = compact_bank(obs.images, obs.image_index.index_select(1, self.cameras))
        return self.cnn(bank)[index]

    def forward(self, obs: ObsBatch) -> Tensor:
        parts = [obs.vectors if self._all_columns else obs.vectors.index_select(1, self.columns)]
        if self.cnn is not None:
            if obs.images is None:
                raise ValueError("this encoder reads images but the batch has none")
            parts.append(self.image_features(obs).flatten(1))
        return self.mlp(torch.cat(parts, dim=-1))


class JointEncoder(_FusionEncoder):
    """Encodes the joint observation ``z`` (all agents' vectors and cameras) to ``[B, out_dim]``.

    ``use_images=None`` reads images iff the task renders them; ``False`` ignores them.
    """

    def __init__(
        self,
        spec: EnvSpec,
        hidden: int = 128,
        layers: int = 2,
        cnn_features: int = 256,
        use_images: bool | None = None,
    ) -> None:
        super().__init__(spec, range(spec.num_agents), hidden, layers, cnn_features, use_images)


class LocalEncoder(_FusionEncoder):
    """Encodes agent ``agent``'s own observation ``z^i`` (its vector and camera) only."""

    def __init__(
        self,
        spec: EnvSpec,
        agent: int,
        hidden: int = 128,
        layers: int = 2,
        cnn_features: int = 256,
        use_images: bool | None = None,
    ) -> None:
        if not 0 <= agent < spec.num_agents:
            raise ValueError(f"agent {agent} out of range for {spec.num_agents} agents")
        super().__init__(spec, [agent], hidden, layers, cnn_features, use_images)
