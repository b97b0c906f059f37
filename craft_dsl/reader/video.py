"""Decoding a CRAFT video into RGB frames, uint8 [T, H, W, 3].

Two decoders, both shipping their own FFmpeg and both core dependencies: PyAV (in-process) and imageio-ffmpeg
(an ``ffmpeg`` subprocess writing raw frames to a pipe). PyAV is used when installed: converting each video's frames
with one scaler on the calling thread (:func:`rgb_converter`), it decodes a 600-frame MPEG-1 video about six times
as fast as the pipe (``benchmarks/reader.py --decoders``, docs/reader.md). Both decode single-threaded so that
several videos can be read in parallel processes.

Frames are taken by position, and the frame rate says which physics step each shows: at ``fps`` frames per
second frame ``k`` (0-based) shows the state after ``round((k + 1) * 60 / fps)`` steps, the renderer's rule
(:func:`craft_dsl.render.raster.frame_steps`); at 60 fps, ``k + 1``. :func:`frame_rate` measures the rate:

* raw MPEG-1/2 (``.mpg``): the frame rate code of the sequence header. Their timestamps are not trustworthy (PyAV
  and ffmpeg report 25 fps for craft_dsl's and the original's 60-fps files), the header is: 60 in both.
* containers (``.mp4``, ``.mkv``, ``.avi``, ``.webm``, ``.mov``): the stream's average rate (PyAV), else its base
  rate.
* nothing stated: the number of frames over a CRAFT run of :data:`RUN_STEPS` steps (10 s), rounded up to the next
  common rate (:data:`COMMON_RATES`), so that a video missing some frames at the end keeps its rate (590 frames:
  60 fps; 97 frames: 10 fps). More frames than a 60-fps run holds: 60 fps (a longer run).

Frames that are not square hold the square picture boxed between bars or stretched: it is found in the first
frames (:mod:`craft_dsl.reader.picture`) and cut out and rescaled by FFmpeg's ``crop`` and ``scale`` filters (a PyAV
filter graph; the ``ffmpeg`` decoder's ``-vf``). Where a container's frame times leave gaps (frames dropped or cut
out), each frame is read at the step its time shows (:func:`timed_steps`); PyAV gives the times, the ``ffmpeg``
decoder and raw MPEG streams none.

A probe of the file that fails (a container that cannot be opened again to state its frame count or rate) does
not stop the reading: it says what could not be checked (:func:`not_checked`), into the innermost
:func:`collect_unchecked` (the reader's perceived scene keeps them, ``meta["unchecked"]``, and every answer says
them), else as a :class:`VideoCheckWarning`.

Rates within 0.2 % of a whole number are that number (NTSC's 59.94 is 60). A rate that does not divide 60 (25,
24 fps) maps each frame time to the nearest step, as the renderer does. Rates above 60 fps are refused
(:class:`~craft_dsl.errors.ReaderError`): the simulation has 60 states per second, so such a video repeats frames;
re-encode it at 60 fps or less.
"""

from __future__ import annotations

import itertools
import math
import numbers
import os
import re
import subprocess
import warnings
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..errors import ReaderError
from ..render.raster import SIM_FPS
from ..render.video import MPEG_FRAME_RATES
from .picture import PICTURE_FRAMES, Picture, find_picture

Decoder = Literal["auto", "pyav", "ffmpeg"]
DECODERS: tuple[str, ...] = ("auto", "pyav", "ffmpeg")


class VideoCheckWarning(UserWarning):
    """A check of a video that could not be made: what was not checked, and why (the reading goes on)."""


_UNCHECKED: ContextVar[list[str] | None] = ContextVar("craft_dsl_reader_unchecked", default=None)


def not_checked(message: str) -> None:
    """Say that something about a video could not be checked: into the innermost :func:`collect_unchecked`, else
    as a :class:`VideoCheckWarning`."""
    found = _UNCHECKED.get()
    if found is None:
        warnings.warn(message, VideoCheckWarning, stacklevel=3)
    else:
        found.append(message)


@contextmanager
def collect_unchecked() -> Iterator[list[str]]:
    """The messages :func:`not_checked` is given inside the block, in order (none shown as warnings)."""
    found: list[str] = []
    token = _UNCHECKED.set(found)
    try:
        yield found
    finally:
        _UNCHECKED.reset(token)


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


def _decode_pyav(path: Path, size: int | None = None, limit: int | None = None) -> Decoded:
    import av

    raw_mpeg = path.suffix.lower() == ".mpg"
    try:
        container = av.open(str(path), format="mpegvideo" if raw_mpeg else None)
    except Exception as err:  # noqa: BLE001 - PyAV raises its own error classes
        raise ReaderError(f"{path}: cannot be decoded ({err})") from None
    times: list[float | None] = []
    try:
        stream = container.streams.video[0]
        stream.thread_type = "NONE"
        width, height = int(stream.width), int(stream.height)
        decoded = _timed(itertools.islice(container.decode(stream), limit), times)
        expected = _expected_frames(stream) if limit is None else min(_expected_frames(stream), limit)
        if width == height:
            picture = Picture.whole(width, height)
            frames = _FrameBuffer(expected, size or width)
            to_rgb = rgb_converter(**_scaling(width, height, size))
            for f in decoded:
                frames.append(to_rgb(f))
        else:  # the picture is measured in the first frames at their own size, then cut out and made square
            first = []
            for f in decoded:
                first.append(f)
                if len(first) == PICTURE_FRAMES:
                    break
            if not first:
                raise ReaderError(f"{path}: the video has no frames")
            native = rgb_converter()
            picture = find_picture(np.stack([native(f) for f in first]))
            frames = _FrameBuffer(expected, size or picture.side)
            _square_pictures(stream, picture, size or picture.side, itertools.chain(first, decoded), frames.append)
    except ReaderError:
        raise
    except Exception as err:  # noqa: BLE001
        raise ReaderError(f"{path}: cannot be decoded ({err})") from None
    finally:
        container.close()
    if not frames.count:
        raise ReaderError(f"{path}: the video has no frames")
    # a raw MPEG stream's timestamps are not its frames' (see the module docstring)
    known = None if raw_mpeg or any(t is None for t in times) else np.array(times, dtype=np.float64)
    return Decoded(frames.array(), picture, known)


def _timed(frames: Iterable[Any], times: list[float | None]) -> Iterator[Any]:
    """``frames`` (PyAV frames), each one's time (seconds, None where it has none) appended to ``times``."""
    for f in frames:
        times.append(None if f.time is None else float(f.time))
        yield f


def _scaling(width: int, height: int, size: int | None) -> dict[str, Any]:
    """The rescaling options of a ``width`` x ``height`` picture to ``size`` x ``size`` (none where it is that)."""
    if size is None or (width, height) == (size, size):
        return {}
    return {"width": size, "height": size, "interpolation": "AREA" if min(width, height) > size else "BILINEAR"}


def _picture_filters(picture: Picture, side: int) -> list[tuple[str, str]]:
    """FFmpeg filters (name, arguments) that cut ``picture`` out of a frame and rescale it to ``side`` x ``side``."""
    filters = []
    if picture.how != "whole":
        filters.append(("crop", f"{picture.width}:{picture.height}:{picture.x}:{picture.y}"))
    scale = _scaling(picture.width, picture.height, side)
    if scale:
        filters.append(("scale", f"{side}:{side}:flags={scale['interpolation'].lower()}"))
    return filters


def _square_pictures(stream: Any, picture: Picture, side: int, decoded: Iterable[Any],
                     append: Callable[[np.ndarray], None]) -> None:
    """Each decoded frame's picture, ``side`` x ``side`` RGB, passed to ``append``: FFmpeg's crop and scale filters
    in one PyAV filter graph (as the ``ffmpeg`` decoder runs them)."""
    import av

    graph = av.filter.Graph()
    chain = [graph.add_buffer(template=stream)]
    chain += [graph.add(name, args) for name, args in (*_picture_filters(picture, side), ("format", "rgb24"))]
    chain.append(graph.add("buffersink"))
    for a, b in zip(chain, chain[1:]):
        a.link_to(b)
    graph.configure()

    def drain() -> None:
        while True:
            try:
                out = graph.vpull()
            except (av.error.BlockingIOError, av.error.EOFError):
                return
            append(out.to_ndarray())

    for f in decoded:
        graph.vpush(f)
        drain()
    graph.vpush(None)
    drain()


def rgb_converter(width: int | None = None, height: int | None = None, interpolation: str | None = None
                  ) -> Callable[[Any], np.ndarray]:
    """A function from a decoded PyAV frame to its RGB array uint8 [H, W, 3] (rescaled to ``width`` x ``height``
    where given), for all the frames of a video: one scaler, run on the calling thread. (``frame.to_ndarray(format=
    "rgb24")`` makes a new scaler for every frame, and recent PyAV versions (18 here) start one thread per CPU for
    each: that was most of a decode's time, and on a machine whose cores were all busy, three times its CPU time.
    The pixels are the same.)"""
    from av.video.reformatter import VideoReformatter

    reformatter = VideoReformatter()
    options: dict[str, Any] = {"format": "rgb24", "threads": 1}
    options.update((k, v) for k, v in (("width", width), ("height", height), ("interpolation", interpolation))
                   if v is not None)

    def convert(frame: Any) -> np.ndarray:
        nonlocal options
        try:
            rgb = reformatter.reformat(frame, **options)
        except TypeError:
            if "threads" not in options:
                raise
            options = {k: v for k, v in options.items() if k != "threads"}  # an older PyAV: no such option
            rgb = reformatter.reformat(frame, **options)
        return rgb.to_ndarray()

    return convert


#: Frames a CRAFT video holds (10 s at 60 fps): the first guess of the decoder's buffer where the file does not say.
_CRAFT_FRAMES = 600


def _expected_frames(stream: Any) -> int:
    """How many frames the stream says it holds (a raw MPEG stream says none: a CRAFT video's count)."""
    stated = int(stream.frames or 0)
    return stated if stated > 0 else _CRAFT_FRAMES


class _FrameBuffer:
    """Decoded frames written into one array as they come, grown by half when full: a video's frames are one
    allocation, not one per frame and a stacked copy (half the peak memory, and one copy fewer)."""

    def __init__(self, capacity: int, side: int) -> None:
        self.data = np.empty((max(capacity, 1), side, side, 3), dtype=np.uint8)
        self.count = 0

    def append(self, frame: np.ndarray) -> None:
        if self.count == len(self.data):
            grown = np.empty((len(self.data) + len(self.data) // 2 + 1, *self.data.shape[1:]), dtype=np.uint8)
            grown[:self.count] = self.data
            self.data = grown
        self.data[self.count] = frame
        self.count += 1

    def array(self) -> np.ndarray:
        """The frames decoded, [count, side, side, 3] (a copy only where the buffer was over-sized by more than
        a few frames, so that a short video does not hold a long one's memory)."""
        if len(self.data) - self.count > 8:
            return self.data[:self.count].copy()
        return self.data[:self.count]


def _probe_size(path: Path, exe: str) -> tuple[int, int]:
    """(width, height) from ffmpeg's stream description."""
    import re

    proc = subprocess.run([exe, "-hide_banner", "-i", str(path)], capture_output=True, text=True, check=False)
    match = re.search(r"Video:.*?(\d{2,5})x(\d{2,5})", proc.stderr)
    if match is None:
        raise ReaderError(f"{path}: not a video ffmpeg can read")
    return int(match.group(1)), int(match.group(2))


def _ffmpeg_frames(exe: str, path: Path, width: int, height: int, options: list[str]) -> np.ndarray:
    """Frames [n, height, width, 3] that ffmpeg writes of ``path`` with ``options`` (filters, a frame limit)."""
    fmt = ["-f", "mpegvideo"] if path.suffix.lower() == ".mpg" else []
    # every decoded frame once (-fps_mode passthrough): no frames repeated or dropped to fill a constant rate
    cmd = [exe, "-loglevel", "error", "-threads", "1", *fmt, "-i", str(path), *options, "-fps_mode", "passthrough",
           "-f", "rawvideo", "-pix_fmt", "rgb24", "-"]
    proc = subprocess.run(cmd, capture_output=True, check=False)
    if proc.returncode != 0:
        message = proc.stderr.decode("utf-8", "replace").strip().splitlines()
        raise ReaderError(f"{path}: cannot be decoded ({message[-1] if message else 'ffmpeg failed'})")
    data = np.frombuffer(proc.stdout, dtype=np.uint8)
    frame_bytes = width * height * 3
    if data.size == 0 or data.size % frame_bytes:
        raise ReaderError(f"{path}: decoded {data.size} bytes, not a whole number of {width}x{height} frames")
    return data.reshape(-1, height, width, 3)


def _decode_ffmpeg(path: Path, size: int | None = None, limit: int | None = None) -> Decoded:
    import imageio_ffmpeg

    exe = imageio_ffmpeg.get_ffmpeg_exe()
    width, height = _probe_size(path, exe)
    first = PICTURE_FRAMES if limit is None else min(PICTURE_FRAMES, limit)
    if width == height:
        picture = Picture.whole(width, height)
    else:
        picture = find_picture(_ffmpeg_frames(exe, path, width, height, ["-frames:v", str(first)]))
    side = size or picture.side
    filters = ",".join(f"{name}={args}" for name, args in _picture_filters(picture, side))
    options = (["-frames:v", str(limit)] if limit is not None else []) + (["-vf", filters] if filters else [])
    return Decoded(_ffmpeg_frames(exe, path, side, side, options), picture)


@dataclass(frozen=True)
class Decoded:
    """A decoded video: its RGB frames uint8 [T, H, W, 3], where the picture lies in its own frames, and each frame's
    time (seconds, from the container; None where the decoder or the file does not give them: the ``ffmpeg``
    decoder, a raw MPEG stream)."""

    frames: np.ndarray
    picture: Picture
    times: np.ndarray | None = None


def decode(path: str | os.PathLike[str], decoder: Decoder = "auto", size: int | None = None) -> np.ndarray:
    """RGB frames of a video, uint8 [T, H, W, 3]; ``decoder``: ``auto`` (PyAV if installed), ``pyav``,
    ``ffmpeg`` (imageio-ffmpeg). ``size``: frames of another size are rescaled to ``size`` x ``size`` as they are
    decoded (area averaging when shrinking, bilinear when enlarging). Frames that are not square are read as the
    square picture they hold (:mod:`craft_dsl.reader.picture`: between bars, or stretched), at ``size`` or at the
    picture's side."""
    return decode_video(path, decoder, size).frames


def decode_sized(path: str | os.PathLike[str], decoder: Decoder = "auto", size: int | None = None
                 ) -> tuple[np.ndarray, int]:
    """:func:`decode`'s frames and the video's own picture size (pixels, before any rescaling)."""
    decoded = decode_video(path, decoder, size)
    return decoded.frames, decoded.picture.side


def decode_video(path: str | os.PathLike[str], decoder: Decoder = "auto", size: int | None = None,
                 limit: int | None = None) -> Decoded:
    """:func:`decode`'s frames, where the picture lies in the video's own frames, and the frames' times; ``limit``:
    only the first ``limit`` frames (the picture found in them where there are fewer than
    :data:`~craft_dsl.reader.picture.PICTURE_FRAMES`)."""
    target = Path(path)
    _check_file(target)
    if decoder not in DECODERS:
        raise ReaderError(f"unknown decoder {decoder!r}; allowed: {', '.join(DECODERS)}")
    if decoder == "pyav" or (decoder == "auto" and have_pyav()):
        if not have_pyav():
            raise ReaderError("the pyav decoder needs PyAV, a dependency of craft-dsl that is missing here: "
                              "pip install 'av>=12'")
        return _decode_pyav(target, size, limit)
    return _decode_ffmpeg(target, size, limit)


#: The MPEG sequence end code, the last four bytes of a whole MPEG-1 elementary stream (``.mpg``, as craft_dsl and
#: the original CRAFT renderer write them).
MPEG_END_CODE = b"\x00\x00\x01\xb7"
_MPEG_SEQUENCE_HEADER = b"\x00\x00\x01\xb3"


def incomplete(path: str | os.PathLike[str], frames: int) -> str | None:
    """Why the video file at ``path``, of which ``frames`` frames were decoded, is not whole (None when nothing says
    so): an MPEG-1 elementary stream that ends without its end code was cut short; a container that states its
    frame count and holds fewer decodable frames lost some. For a container of fewer than 60 fps a count above the
    stated one is taken as frames at 60 fps, i.e. the steps the decoded frames show (what a perceived scene's
    ``video.frames`` holds): the file lost frames when they show fewer steps than its stated frames do. A container
    that cannot be opened again to state its count is not evidence: :func:`not_checked` says so, and None."""
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
            stream = container.streams.video[0]
            stated = int(stream.frames or 0)
            rate = float(stream.average_rate) if stream.average_rate else float(SIM_FPS)
    except Exception as err:  # noqa: BLE001 - decoding already succeeded; a container that cannot say is not evidence
        not_checked(f"{target.name}: whether frames were lost could not be checked: its container could not be "
                    f"opened again to state its frame count ({type(err).__name__}: {err})")
        return None
    if stated and frames < stated:
        return f"{frames} of the {stated} frames its container states could be decoded"
    if stated and frames > stated and 0 < rate < SIM_FPS:
        whole = int(steps_shown(stated, min(rate, SIM_FPS))[-1])
        if frames < whole:
            return (f"its frames show {frames} of the {whole} steps its container's {stated} frames at {rate:g} fps "
                    f"show")
    return None


# -- frame rate: which physics step each frame shows ---------------------------------------------------------------

#: Steps of a CRAFT run (10 s at 60 steps per second): the run a frame count is measured against when no rate is
#: stated.
RUN_STEPS = 600
#: Rates a frame count is rounded up to when no rate is stated: the divisors of 60 and the usual video rates.
COMMON_RATES: tuple[int, ...] = (1, 2, 3, 4, 5, 6, 10, 12, 15, 20, 24, 25, 30, 50, 60)
#: Bytes searched for an MPEG sequence header.
_HEADER_SEARCH = 1 << 16


@dataclass(frozen=True)
class FrameRate:
    """The frame rate a video is read at, and where it comes from: ``given`` (the caller's), ``stated`` (the
    file's), ``count`` (inferred from the number of frames)."""

    fps: float
    source: Literal["given", "stated", "count"]
    detail: str = ""


def checked_rate(fps: float, what: str = "the frame rate") -> float:
    """``fps`` as the reader uses it: a positive number of at most 60, snapped to a whole number within 0.2 %;
    :class:`ReaderError` otherwise."""
    if isinstance(fps, bool) or not isinstance(fps, numbers.Real) or not math.isfinite(float(fps)) or fps <= 0:
        raise ReaderError(f"{what} must be a positive number of frames per second, got {fps!r}")
    value = float(fps)
    whole = round(value)
    if whole >= 1 and abs(value - whole) <= 2e-3 * whole:
        value = float(whole)
    if value > SIM_FPS:
        raise ReaderError(f"{what} is {value:g} fps, above the simulation's {SIM_FPS} steps per second: such a video "
                          f"repeats frames, which the reader does not read; re-encode it at {SIM_FPS} fps or less "
                          f"(e.g. ffmpeg -i IN -r {SIM_FPS} OUT.mp4)")
    return value


def steps_shown(frames: int, fps: float) -> np.ndarray:
    """int64 [frames]: the physics step shown by each frame at ``fps`` (frame ``k``, 0-based: ``round((k + 1) * 60 /
    fps)``, halves down, exactly as :func:`craft_dsl.render.raster.frame_steps`); strictly increasing."""
    rate = checked_rate(fps)
    k = np.arange(1, frames + 1, dtype=np.float64)
    return np.floor(k * SIM_FPS / rate + 0.5 - 1e-9).astype(np.int64)


#: Two frames whose times are further apart than this many of the video's frame intervals have frames missing
#: between them.
GAP_INTERVALS = 1.5


@dataclass(frozen=True)
class TimedSteps:
    """The step each frame shows, from the frames' times, where they show frames missing."""

    steps: np.ndarray  # int64 [frames], strictly increasing from 1
    missing: int  # frames missing between the frames decoded
    fps: float  # the rate of the frames that are there (one over their mean interval)
    first_gap: float  # seconds into the video where the first frames are missing


def timed_steps(times: np.ndarray | None) -> TimedSteps | None:
    """The steps frames at ``times`` (seconds) show where their times show frames missing inside the video (an
    interval over :data:`GAP_INTERVALS` times the median one): frame ``k`` shows step ``round((t_k - t_0 + i) *
    60)``, ``i`` the mean interval between frames that are not missing, so that at 60 fps the first frame shows step 1
    as :func:`steps_shown` has it.
    None where the times are evenly spaced (the rate says the steps), missing, or not those of one frame a step at
    most (not increasing, or two frames within a step)."""
    if times is None or times.size < 3:
        return None
    intervals = np.diff(times)
    if np.any(intervals <= 0):
        return None
    gaps = intervals > GAP_INTERVALS * float(np.median(intervals))
    if not gaps.any():
        return None
    interval = float(np.mean(intervals[~gaps]))  # a container's rounded times (1 ms in .mkv) average out
    steps = np.rint((times - times[0] + interval) * SIM_FPS).astype(np.int64)
    if steps[0] < 1 or np.any(np.diff(steps) <= 0):
        return None
    missing = int(np.sum(np.rint(intervals[gaps] / interval) - 1))
    first = int(np.argmax(gaps))
    return TimedSteps(steps, missing, checked_rate(1.0 / interval), float(times[first] - times[0] + interval))


def infer_rate(frames: int, steps: int = RUN_STEPS) -> float:
    """The rate of ``frames`` frames over a run of ``steps`` steps when nothing states it: the smallest of
    :data:`COMMON_RATES` whose whole run holds at least that many frames (60 when none does)."""
    for rate in COMMON_RATES:
        if frames <= math.floor(steps * rate / SIM_FPS + 1e-9):
            return float(rate)
    return float(SIM_FPS)


def mpeg_header_rate(path: str | os.PathLike[str]) -> Fraction | None:
    """The frame rate of the first MPEG-1/2 sequence header in the file's first 64 KiB (None: no header or an
    unknown code)."""
    with Path(path).open("rb") as f:
        head = f.read(_HEADER_SEARCH)
    at = head.find(_MPEG_SEQUENCE_HEADER)
    if at < 0 or at + 8 > len(head):
        return None
    return MPEG_FRAME_RATES.get(head[at + 7] & 0x0F)


def _container_rate(path: Path) -> Fraction | None:
    """The video stream's stated rate: PyAV's average rate, else its base rate; ffmpeg's report without PyAV. A file
    PyAV cannot open to probe states none (:func:`not_checked` says so)."""
    if have_pyav():
        import av

        try:
            with av.open(str(path)) as container:
                stream = container.streams.video[0]
                for rate in (stream.average_rate, stream.base_rate):
                    if rate is not None and rate > 0:
                        return Fraction(rate.numerator, rate.denominator)
        except Exception as err:  # noqa: BLE001 - a file PyAV cannot probe states nothing
            not_checked(f"{path.name}: the frame rate its container states could not be read ({type(err).__name__}: "
                        f"{err}): the rate is inferred from the frame count")
            return None
        return None
    import imageio_ffmpeg

    proc = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path)], capture_output=True,
                          text=True, check=False)
    match = re.search(r"Video:.*?(\d+(?:\.\d+)?)(k?) fps", proc.stderr)
    if match is None:
        return None
    return Fraction(match.group(1)) * (1000 if match.group(2) else 1)


def is_raw_mpeg(path: str | os.PathLike[str]) -> bool:
    """Whether the file is an MPEG-1/2 stream without a container of timestamps worth reading: a ``.mpg``/``.mpeg``
    file, or one that starts with a sequence header or an MPEG program stream pack."""
    target = Path(path)
    if target.suffix.lower() in (".mpg", ".mpeg", ".m1v", ".m2v"):
        return True
    with target.open("rb") as f:
        head = f.read(4)
    return head in (_MPEG_SEQUENCE_HEADER, b"\x00\x00\x01\xba")


def stated_rate(path: str | os.PathLike[str]) -> tuple[Fraction, str] | None:
    """The rate the file states and where it says it (None: it states none)."""
    target = Path(path)
    if is_raw_mpeg(target):
        rate = mpeg_header_rate(target)
        return None if rate is None else (rate, "the MPEG sequence header")
    rate = _container_rate(target)
    return None if rate is None else (rate, "the container")


def frame_rate(path: str | os.PathLike[str], frames: int) -> FrameRate:
    """The rate the video at ``path``, of which ``frames`` frames were decoded, is read at (see the module
    docstring); :class:`ReaderError` for a stated rate above 60 fps."""
    stated = stated_rate(path)
    if stated is not None:
        rate, where = stated
        fps = checked_rate(float(rate), f"{Path(path).name}: the frame rate {where} states")
        return FrameRate(fps, "stated", f"{where} states {float(rate):g} fps")
    fps = infer_rate(frames)
    return FrameRate(fps, "count", f"{frames} frames over a {RUN_STEPS}-step run")
