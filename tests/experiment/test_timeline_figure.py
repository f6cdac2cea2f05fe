"""``python -m eval timeline``: an episode's options per agent as a figure."""

from __future__ import annotations

import numpy as np
from PIL import Image

from maopg.env import make_env
from maopg.env.timeline import option_colours
from maopg.experiment.cli.eval_cli import main


def test_the_timeline_figure_of_a_scripted_episode(tmp_path, capsys):
    out = tmp_path / "td.png"
    args = ["timeline", "--reference", "scripted", "--task", "tool_delivery", "--out", str(out)]
    assert main(args) == 0
    assert f"{out}: options of 3 agents over 41 ticks" in capsys.readouterr().out
    image = np.asarray(Image.open(out).convert("RGB"))
    assert image.shape[1] >= 800 and image.shape[0] >= 150
    env = make_env("tool_delivery", "continue")
    colours = option_colours(env.spec)
    env.close()
    pixels = image.reshape(-1, 3)
    for option in ("GoToWS", "GetTool", "SearchTool(0)", "PassTo(0)"):  # the scripted plan's
        assert (np.abs(pixels - colours[option]).max(axis=1) <= 2).sum() > 100, option


def test_a_timeline_out_of_no_figure_format_is_refused_before_anything_runs(tmp_path, user_error):
    out = tmp_path / "t.mp4"
    args = ["timeline", "--reference", "scripted", "--out", str(out)]
    user_error(main, args, r"--out .*t\.mp4: must end in \.png, \.svg, \.pdf")
    assert not out.exists()
