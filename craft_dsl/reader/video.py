"""Decoding a CRAFT video into RGB frames, uint8 [T, H, W, 3].

Two decoders, both shipping their own FFmpeg and both core dependencies: PyAV (in-process) and imageio-ffmpeg
(an ``ffmpeg`` subprocess writing raw frames to a pipe). Measured on the same
600-frame MPEG-1 videos (``benchmarks/reader.py --decoders``), PyAV is the faster on an idle machine and uses less
CPU in all, so it is used when installed; on a busy machine the pipe, whose decoder runs in its own process, can be
faster (docs/reader.md). Both decode single-threaded so that several videos can be read in parallel processes.

Raw MPEG-1 streams (``.mpg``, as the published dataset stores them) carry no trustworthy timestamps, so frames are
taken by position: frame ``k`` shows the state after ``k + 1`` physics steps.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..errors import ReaderError

Decoder = Literal["auto", "pyav", "ffmpeg"]
DECODERS: tuple[str, ...] = ("auto", "pyav", "ffmpeg")


def have_pyav() -> bool:
    try:
        import av  # noqa: F401
    except ImportError:
        return False
    return True


def _check_file(path: Path) -> None:
    if not path.is_file():
        raise ReaderError(f"{path}: no such video file")
    if path.stat().st_size == 0:
        raise ReaderError(f"{path}: the video file is empty")


def _decode_pyav(path: Path, size: int | None = None) -> np.ndarray:
    import av

    try:
        fmt = "mpegvideo" if path.suffix.lower() == ".mpg" else None
        container = av.open(str(path), format=fmt)
    except Exception as err:  # noqa: BLE001 - PyAV raises its own error classes
        raise ReaderError(f"{path}: cannot be decoded ({err})") from None
    try:
        stream = container.streams.video[0]
        stream.thread_type = "NONE"
        _check_square(path, stream.width, stream.height)
        scale: dict[str, Any] = {}
        if size is not None and (stream.width, stream.height) != (size, size):
            scale = {"width": size, "height": size, "interpolation": "AREA" if stream.width > size else "BILINEAR"}
        frames = [f.to_ndarray(format="rgb24", **scale) for f in container.decode(stream)]
    except ReaderError:
        raise
    except Exception as err:  # noqa: BLE001
        raise ReaderError(f"{path}: cannot be decoded ({err})") from None
    finally:
        container.close()
    if not frames:
        raise ReaderError(f"{path}: the video has no frames")
    return np.stack(frames)


def _probe_size(path: Path, exe: str) -> tuple[int, int]:
    """(width, height) from ffmpeg's stream description."""
    import re

    proc = subprocess.run([exe, "-hide_banner", "-i", str(path)], capture_output=True, text=True, check=False)
    match = re.search(r"Video:.*?(\d{2,5})x(\d{2,5})", proc.stderr)
    if match is None:
        raise ReaderError(f"{path}: not a video ffmpeg can read")
    return int(match.group(1)), int(match.group(2))


def _decode_ffmpeg(path: Path, size: int | None = None) -> np.ndarray:
    import imageio_ffmpeg

    exe = imageio_ffmpeg.get_ffmpeg_exe()
    width, height = _probe_size(path, exe)
    _check_square(path, width, height)
    fmt = ["-f", "mpegvideo"] if path.suffix.lower() == ".mpg" else []
    scale: list[str] = []
    if size is not None and (width, height) != (size, size):
        scale = ["-vf", f"scale={size}:{size}:flags={'area' if width > size else 'bilinear'}"]
        width = height = size
    cmd = [exe, "-loglevel", "error", "-threads", "1", *fmt, "-i", str(path), *scale, "-f", "rawvideo", "-pix_fmt",
           "rgb24", "-"]
    proc = subprocess.run(cmd, capture_output=True, check=False)
    if proc.returncode != 0:
        message = proc.stderr.decode("utf-8", "replace").strip().splitlines()
        raise ReaderError(f"{path}: cannot be decoded ({message[-1] if message else 'ffmpeg failed'})")
    data = np.frombuffer(proc.stdout, dtype=np.uint8)
    frame_bytes = width * height * 3
    if data.size == 0 or data.size % frame_bytes:
        raise ReaderError(f"{path}: decoded {data.size} bytes, not a whole number of {width}x{height} frames")
    return data.reshape(-1, height, width, 3)


def _check_square(path: Path, width: int, height: int) -> None:
    if width != height:
        raise ReaderError(f"{path}: frames are {width}x{height}; CRAFT videos are square")


def decode(path: str | os.PathLike[str], decoder: Decoder = "auto", size: int | None = None) -> np.ndarray:
    """RGB frames of a video, uint8 [T, H, W, 3]; ``decoder``: ``auto`` (PyAV if installed), ``pyav``,
    ``ffmpeg`` (imageio-ffmpeg). ``size``: frames of another size are rescaled to ``size`` x ``size`` as they are
    decoded (area averaging when shrinking, bilinear when enlarging). Frames that are not square are refused."""
    target = Path(path)
    _check_file(target)
    if decoder not in DECODERS:
        raise ReaderError(f"unknown decoder {decoder!r}; allowed: {', '.join(DECODERS)}")
    if decoder == "pyav" or (decoder == "auto" and have_pyav()):
        if not have_pyav():
            raise ReaderError("the pyav decoder needs PyAV, a dependency of craft-dsl that is missing here: "
                              "pip install 'av>=12'")
        frames = _decode_pyav(target, size)
    else:
        frames = _decode_ffmpeg(target, size)
    return frames


#: The MPEG sequence end code, the last four bytes of a whole MPEG-1 elementary stream (``.mpg``, as craft_dsl and
#: the original CRAFT renderer write them).
MPEG_END_CODE = b"\x00\x00\x01\xb7"
_MPEG_SEQUENCE_HEADER = b"\x00\x00\x01\xb3"


def incomplete(path: str | os.PathLike[str], frames: int) -> str | None:
    """Why the video file at ``path``, of which ``frames`` frames were decoded, is not whole (None when nothing says
    so): an MPEG-1 elementary stream that ends without its end code was cut short; a container that states its
    frame count and holds fewer decodable frames lost some."""
    target = Path(path)
    with target.open("rb") as f:
        head = f.read(4)
        f.seek(max(target.stat().st_size - 4, 0))
        tail = f.read(4)
    if head == _MPEG_SEQUENCE_HEADER:
        if tail != MPEG_END_CODE:
            return f"the MPEG stream ends without its end code: the file was cut short ({frames} frames decoded)"
        return None
    if not have_pyav():
        return None
    import av

    try:
        with av.open(str(target)) as container:
            stated = int(container.streams.video[0].frames or 0)
    except Exception:  # noqa: BLE001 - decoding already succeeded; a container that cannot say is not evidence
        return None
    if stated and frames < stated:
        return f"{frames} of the {stated} frames its container states could be decoded"
    return None
