"""A camera image's channels as pictures: what a video's robot tiles show beside each other.

Colour is shown as it is; depth in grey, white at the task's ``near`` and black at its
``far``, scaled as the CNN encoder scales it (:func:`maopg.policy.encoders.image_inputs`), so a
tile shows what a policy reads; segmentation in one fixed colour per class
(:func:`class_colours`): the five classes every scene has keep theirs in every task, the
task's prop classes take the next colours of a qualitative palette in class order.
"""

from __future__ import annotations

import numpy as np

from maopg.sim.channels import ImageChannels

FIXED_COLOURS = (
    (0, 0, 0),  # background
    (110, 110, 110),  # floor
    (190, 190, 190),  # wall
    (230, 50, 50),  # robot
    (255, 0, 255),  # distractor
)
"""The colours of the classes every scene has (:data:`maopg.sim.segmentation.FIXED_CLASSES`)."""
PROP_COLOURS = (
    (31, 119, 180),
    (44, 160, 44),
    (255, 127, 14),
    (23, 190, 207),
    (188, 189, 34),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
)
"""The task's prop classes' colours, in class order, repeated past the eighth (matplotlib's
``tab10`` without its red, grey and magenta-like pink, which the fixed classes use)."""


def class_colours(classes: int) -> np.ndarray:
    """``uint8 [classes, 3]``: the colour of each class id."""
    props = [PROP_COLOURS[i % len(PROP_COLOURS)] for i in range(classes - len(FIXED_COLOURS))]
    return np.array([*FIXED_COLOURS, *props][:classes], dtype=np.uint8)


def channel_tiles(image: np.ndarray, channels: ImageChannels) -> list[np.ndarray]:
    """One ``uint8 [H, W, 3]`` picture per channel of ``image`` (``[H, W, planes]``), in the
    channels' order."""
    tiles = []
    for name in channels.names:
        plane = image[..., channels.plane_slice(name)]
        if name == "rgb":
            tiles.append(plane.astype(np.uint8, copy=False))
        elif name == "depth":
            near, far = channels.depth_range  # type: ignore[misc]  (depth is on)
            scaled = np.clip((plane[..., 0] - near) / (far - near), 0.0, 1.0)
            grey = np.round(255.0 * (1.0 - scaled)).astype(np.uint8)
            tiles.append(np.repeat(grey[..., None], 3, axis=-1))
        else:
            palette = class_colours(len(channels.classes))
            ids = np.clip(plane[..., 0].astype(np.int64), 0, len(palette) - 1)
            tiles.append(palette[ids])
    return tiles
