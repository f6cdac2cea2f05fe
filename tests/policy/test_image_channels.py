"""The CNN encoder reads any combination of camera channels, each normalised as it should be."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from maopg.env.contract import AgentSpec, EnvSpec, Strategy
from maopg.policy.batch import ObsBatch
from maopg.policy.encoders import JointEncoder, NatureCNN, image_inputs
from maopg.sim.channels import RGB, ImageChannels

FULL = ImageChannels(("rgb", "depth", "seg"), (0.5, 10.5), ("background", "floor", "wall"))


def _spec(channels: ImageChannels, side: int = 36) -> EnvSpec:
    agents = tuple(AgentSpec(f"a{i}", "turtlebot", ("x", "y"), 2) for i in range(2))
    shape = (side, side, channels.planes)
    return EnvSpec("t", Strategy.CONTINUE, agents, shape, 1.0, 10, 0.99, channels)


def test_each_channel_is_normalised_to_the_unit_range():
    image = torch.zeros(1, 2, 2, 5)
    image[0, 0, 0, :3] = torch.tensor([255.0, 0.0, 51.0])
    image[0, :, :, 3] = torch.tensor([[0.0, 0.5], [5.5, 99.0]])  # below near, near, mid, far+
    image[0, :, :, 4] = torch.tensor([[0.0, 1.0], [2.0, 1.0]])
    x = image_inputs(image, FULL)
    assert x.shape == (1, 3 + 1 + 3, 2, 2)
    assert x[0, :3, 0, 0].tolist() == pytest.approx([1.0, 0.0, 0.2])
    assert x[0, 3].flatten().tolist() == pytest.approx([0.0, 0.0, 0.5, 1.0])
    assert x[0, 4:].argmax(0).tolist() == [[0, 1], [2, 1]] and x[0, 4:].sum(0).eq(1).all()


def test_colour_alone_reads_the_bytes_as_before():
    images = torch.randint(0, 256, (3, 36, 36, 3), dtype=torch.uint8)
    expected = images.permute(0, 3, 1, 2).float() / 255.0
    assert torch.equal(image_inputs(images, RGB), expected)


@pytest.mark.parametrize(
    ("channels", "inputs"),
    [
        (RGB, 3),
        (ImageChannels(("depth",), (0.1, 5.0)), 1),
        (ImageChannels(("seg",), classes=("a", "b", "c", "d")), 4),
        (FULL, 7),
    ],
)
def test_the_cnn_reads_the_channels_of_its_spec(channels, inputs):
    spec = _spec(channels)
    cnn = NatureCNN.of_spec(spec, features=16)
    assert cnn.convs[0].in_channels == inputs
    dtype = np.dtype(channels.dtype)
    images = torch.from_numpy(np.ones((4, 36, 36, channels.planes), dtype))
    assert cnn(images).shape == (4, 16)
    wrong = torch.float32 if dtype == np.uint8 else torch.uint8
    with pytest.raises(TypeError, match=channels.dtype):
        cnn(images.to(wrong))
    encoder = JointEncoder(spec, hidden=8, cnn_features=16)
    batch = ObsBatch(
        torch.zeros(5, 4), torch.from_numpy(np.ones((5, 2, 36, 36, channels.planes), dtype))
    )
    assert encoder(batch).shape == (5, 8)


def test_a_spec_refuses_an_image_shape_its_channels_do_not_fill():
    with pytest.raises(ValueError, match="5 planes"):
        EnvSpec("t", Strategy.CONTINUE, (), (36, 36, 3), 1.0, 10, 0.99, FULL)
