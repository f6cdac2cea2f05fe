"""A rollout video in TensorBoard, as an animated GIF in its IMAGES tab.

TensorBoard plays videos only as animated GIFs inside an image summary; torch's ``add_video``
makes that GIF with moviepy, which is no dependency of ours. Pillow (one) writes GIFs, so the
MP4 the run already recorded is read back, shrunk and re-encoded here. The GIF is kept small
because it is stored inside the event file: at most :data:`MAX_FRAMES` frames (every k-th of a
longer video, so that the GIF still shows the whole episode), 40% of the size, 64 colours.
Reading and shrinking the frames takes a while
(:data:`maopg.experiment.training.eta.GIF_SECONDS_PER_FRAME`), so it shows a progress bar of its
own. A run makes the GIF only when asked (``video_gif``,
:class:`~maopg.experiment.run.config.TrainConfig`).
"""

from __future__ import annotations

import io
from pathlib import Path

from PIL import Image
from tqdm import tqdm

from maopg.progress import shows_bar

MAX_FRAMES = 300
SCALE = 0.4


def gif_bytes(frames: list[Image.Image], fps: float) -> bytes:
    buffer = io.BytesIO()
    frames[0].save(
        buffer,
        format="GIF",
        save_all=True,
        append_images=frames[1:],
        duration=int(1000 / fps),
        loop=0,
    )
    return buffer.getvalue()


def add_video(
    writer, tag: str, mp4: Path, step: int, *, frames: int, progress: bool = False
) -> None:
    """Add the video at ``mp4`` of ``frames`` frames (the recorder knows how many: counting
    them would decode the file once more) to ``writer`` (a ``SummaryWriter``) as an animated
    GIF (``progress``: a bar over the frames on stderr)."""
    import imageio.v2 as imageio
    from tensorboard.compat.proto.summary_pb2 import Summary

    reader = imageio.get_reader(mp4)
    try:
        fps = float(reader.get_meta_data().get("fps", 4.0))
        every = max(1, -(-frames // MAX_FRAMES))
        kept: list[Image.Image] = []
        bar = tqdm(
            reader,
            total=frames,
            desc=f"TensorBoard GIF of {mp4.name}",
            unit="frame",
            disable=not shows_bar(progress),
            leave=False,
        )
        for k, frame in enumerate(bar):
            if k % every or len(kept) >= MAX_FRAMES:
                continue
            image = Image.fromarray(frame)
            size = (int(image.width * SCALE), int(image.height * SCALE))
            kept.append(image.resize(size, Image.BILINEAR).quantize(colors=64))
    finally:
        reader.close()
    if not kept:
        return
    width, height = kept[0].size
    image = Summary.Image(
        height=height,
        width=width,
        colorspace=3,
        encoded_image_string=gif_bytes(kept, fps / every),
    )
    writer.file_writer.add_summary(Summary(value=[Summary.Value(tag=tag, image=image)]), step)
