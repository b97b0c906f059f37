"""PyAV decoding: one converter for a video's frames, no threads started per frame, frames in one array."""

from __future__ import annotations

import os
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest

from craft_dsl.reader.video import _CRAFT_FRAMES, _FrameBuffer, decode_sized, rgb_converter


def _frames_one_by_one(path: Path, size: int | None = None) -> np.ndarray:
    """PyAV's own conversion, frame by frame (the reference the converter must reproduce exactly)."""
    import av

    with av.open(str(path), format="mpegvideo" if path.suffix == ".mpg" else None) as container:
        stream = container.streams.video[0]
        scale = {} if size is None else {"width": size, "height": size,
                                          "interpolation": "AREA" if stream.width > size else "BILINEAR"}
        return np.stack([f.to_ndarray(format="rgb24", **scale) for f in container.decode(stream)])


def _copy(source: Path, target: Path, *args: str) -> Path:
    import imageio_ffmpeg

    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "mpegvideo", "-i",
                    str(source), *args, str(target)], check=True)
    return target


def test_the_decoded_frames_are_pyavs_own_pixels(video: Path) -> None:
    frames, source = decode_sized(video, "pyav", size=256)
    assert source == 256 and frames.flags.c_contiguous
    np.testing.assert_array_equal(frames, _frames_one_by_one(video))


@pytest.mark.parametrize("side", [128, 320])
def test_rescaled_frames_are_pyavs_own_pixels(video: Path, tmp_path: Path, side: int) -> None:
    copy = _copy(video, tmp_path / f"v{side}.mp4", "-vf", f"scale={side}:{side}", "-c:v", "libx264", "-crf", "18")
    frames, source = decode_sized(copy, "pyav", size=256)
    assert source == side and frames.shape[1:] == (256, 256, 3)
    np.testing.assert_array_equal(frames, _frames_one_by_one(copy, 256))


def test_decoding_starts_no_thread_per_frame(video: Path) -> None:
    """The converter scales on the calling thread: a whole video decoded starts no new OS thread (the per-frame
    conversion started one per CPU for every frame)."""
    tasks = Path("/proc/self/task")
    if not tasks.is_dir():
        pytest.skip("counting threads needs /proc (Linux)")
    import av

    before = threading.active_count()
    with av.open(str(video), format="mpegvideo") as container:
        stream = container.streams.video[0]
        stream.thread_type = "NONE"
        to_rgb = rgb_converter()
        first = next(container.decode(stream))
        to_rgb(first)  # the scaler is made here
        made = set(os.listdir(tasks))
        seen = set(made)
        for frame in container.decode(stream):
            to_rgb(frame)
            seen |= set(os.listdir(tasks))
    assert seen == made, f"threads started while converting: {sorted(seen - made)}"
    assert threading.active_count() == before


def test_the_frame_buffer_grows_and_keeps_order() -> None:
    buffer = _FrameBuffer(2, 4)
    frames = [np.full((4, 4, 3), k, dtype=np.uint8) for k in range(7)]
    for f in frames:
        buffer.append(f)
    out = buffer.array()
    assert out.shape == (7, 4, 4, 3)
    assert [int(f[0, 0, 0]) for f in out] == list(range(7))


def test_a_short_video_does_not_hold_a_long_buffer() -> None:
    buffer = _FrameBuffer(_CRAFT_FRAMES, 4)
    for k in range(10):
        buffer.append(np.full((4, 4, 3), k, dtype=np.uint8))
    out = buffer.array()
    assert out.shape == (10, 4, 4, 3) and out.base is None  # a copy of the ten frames, not a view of 600


def test_a_truncated_and_a_longer_video_decode_whole(video: Path, tmp_path: Path) -> None:
    """Fewer frames than a CRAFT run, and more than the buffer's first guess (a raw MPEG stream states no count)."""
    short = _copy(video, tmp_path / "short.mpg", "-frames:v", "37", "-c:v", "mpeg1video", "-q:v", "2",
                  "-f", "mpeg1video")
    frames, _ = decode_sized(short, "pyav", size=256)
    np.testing.assert_array_equal(frames, _frames_one_by_one(short))
    assert len(frames) == 37
    n = len(_frames_one_by_one(video))
    loops = _CRAFT_FRAMES // n + 1  # repeats of the whole video past the buffer's first guess
    long = _copy(video, tmp_path / "long.mpg", "-vf", f"loop=loop={loops}:size={n}:start=0", "-c:v", "mpeg1video",
                 "-q:v", "2", "-f", "mpeg1video")
    frames, _ = decode_sized(long, "pyav", size=256)
    assert len(frames) > _CRAFT_FRAMES
    np.testing.assert_array_equal(frames, _frames_one_by_one(long))
