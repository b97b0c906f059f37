"""Helpers of the reader's tests."""

from __future__ import annotations

import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from craft_dsl.reader.perceive import Perception
from craft_dsl.render.raster import world_to_pixel


def tracks_px(perception: Perception) -> dict[tuple[str, str, str], np.ndarray]:
    """Each dynamic body's reconstructed path in pixels ([steps, 2], from step 1), by (shape, colour, size)."""
    traj = perception.reconstruction.simulation.trajectory
    out = {}
    for b in perception.reconstruction.simulation.world_spec.bodies:
        if b.dynamic:
            pos = traj.positions[1:, traj.column(b.uid)]
            out[(b.shape, b.color, b.size)] = np.stack(world_to_pixel(pos[:, 0], pos[:, 1]), axis=1)
    return out


def reencoded(source: Path, target: Path, video_filter: str = "null", options: Sequence[str] = ()) -> Path:
    """The MPEG-1 video ``source`` re-encoded to ``target`` (H.264, crf 18) through ffmpeg's ``video_filter``, with
    ffmpeg's output ``options`` besides (``-fps_mode vfr``, say)."""
    import imageio_ffmpeg

    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "mpegvideo", "-i",
                    str(source), "-vf", video_filter, *options, "-c:v", "libx264", "-crf", "18", "-pix_fmt",
                    "yuv420p", str(target)], check=True)
    return target
