"""What a camera image holds: its channels, their order, value ranges and storage type.

A robot's camera can give three channels, stacked along the image's last axis in this fixed
order whatever order the user writes them in:

- ``rgb``: 3 planes of colour, 0-255;
- ``depth``: 1 plane, the distance in metres from the camera's plane along its view axis (what
  a depth sensor reports, not the length of the ray), between the task's ``near`` and ``far``
  (:attr:`ImageChannels.depth_range`; nothing nearer than ``near`` is drawn, and a pixel whose
  surface lies beyond ``far``, or that shows no surface at all, reads ``far``);
- ``seg``: 1 plane, the segmentation class id of the surface each pixel shows, an index into
  the task's class names (:attr:`ImageChannels.classes`; 0 is ``background``: nothing drawn).

Storage: ``uint8`` while depth is off (colour and class ids are small integers; a rollout
keeps thousands of images, and bytes take a quarter of the memory of floats), ``float32`` with
depth (metres need fractions; colour then stays 0-255 and class ids stay whole numbers, so a
plane means the same whatever else is on).

This module is plain Python (no numpy, MuJoCo or torch), so a task's settings can parse a
channel list when the command line's ``--help`` reads them.
"""

from __future__ import annotations

from dataclasses import dataclass

CHANNELS = ("rgb", "depth", "seg")
"""Every channel a camera can give, in the order they are stacked."""
PLANES = {"rgb": 3, "depth": 1, "seg": 1}
"""How many planes of the stored image each channel takes."""
SEPARATOR = "+"
"""Joins channel names in a setting (``rgb+depth``)."""


def parse_channels(text: str, setting: str = "channels") -> tuple[str, ...]:
    """The channels ``text`` names (``"depth+rgb"`` → ``("rgb", "depth")``), in stacking
    order; a ``ValueError`` naming ``setting`` for an unknown, repeated or missing one."""
    names = [name.strip() for name in str(text).split(SEPARATOR)]
    allowed = f"any of {', '.join(CHANNELS)} joined by {SEPARATOR!r} (rgb+depth+seg)"
    for name in names:
        if name not in CHANNELS:
            raise ValueError(f"{setting}: unknown channel {name!r}; allowed: {allowed}")
    if len(set(names)) != len(names):
        raise ValueError(f"{setting}={text!r} names a channel twice; allowed: {allowed}")
    return tuple(name for name in CHANNELS if name in names)


@dataclass(frozen=True)
class ImageChannels:
    """The channels of every camera image of a team (one set: every agent's image travels in one
    ``[N, H, W, planes]`` array and a rollout banks them together, so they have one shape) and
    what their values mean.

    ``depth_range`` is ``(near, far)`` in metres where depth is on, else ``None``; ``classes``
    the segmentation class names (id = index) where seg is on, else empty.
    """

    names: tuple[str, ...] = ("rgb",)
    depth_range: tuple[float, float] | None = None
    classes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.names or tuple(n for n in CHANNELS if n in self.names) != self.names:
            raise ValueError(f"channels must be a non-empty subset of {CHANNELS} in that order")
        if ("depth" in self.names) != (self.depth_range is not None):
            raise ValueError("depth_range is given exactly when depth is on")
        if self.depth_range is not None and not 0 <= self.depth_range[0] < self.depth_range[1]:
            raise ValueError(f"depth_range must be 0 <= near < far, got {self.depth_range}")
        if ("seg" in self.names) != bool(self.classes):
            raise ValueError("classes are given exactly when seg is on")

    @property
    def planes(self) -> int:
        """Planes of a stored image (its last axis): 3 for rgb, 1 each for depth and seg."""
        return sum(PLANES[name] for name in self.names)

    @property
    def dtype(self) -> str:
        """``"uint8"``, or ``"float32"`` with depth (the module docstring says why)."""
        return "float32" if "depth" in self.names else "uint8"

    @property
    def inputs(self) -> int:
        """Channels a CNN reads: 3 for rgb, 1 for depth, one per class for seg (one-hot)."""
        return sum(len(self.classes) if n == "seg" else PLANES[n] for n in self.names)

    def plane_slice(self, name: str) -> slice:
        """Where channel ``name`` lies along the image's last axis."""
        start = 0
        for own in self.names:
            if own == name:
                return slice(start, start + PLANES[own])
            start += PLANES[own]
        raise KeyError(f"channel {name!r} is off (on: {', '.join(self.names)})")

    def bounds(self) -> tuple[list[float], list[float]]:
        """The lowest and highest value of each plane: 0-255 for colour, ``near``-``far`` for
        depth, 0 to the last class id for seg."""
        low: list[float] = []
        high: list[float] = []
        for name in self.names:
            if name == "rgb":
                low += [0.0] * 3
                high += [255.0] * 3
            elif name == "depth":
                assert self.depth_range is not None
                low.append(self.depth_range[0])
                high.append(self.depth_range[1])
            else:
                low.append(0.0)
                high.append(float(len(self.classes) - 1))
        return low, high


RGB = ImageChannels()
"""Colour only: the default, and what a task without depth or segmentation renders."""
