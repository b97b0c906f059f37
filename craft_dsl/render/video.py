"""Writing frames to files: MPEG-1 (.mpg) and MP4 (H.264) through PyAV, GIF through imageio-ffmpeg, PNG with zlib.

Every write is atomic: the file is encoded under a temporary name in the target's folder and renamed
into place only when complete, so an interrupted or failed run leaves no half-written output.

Videos are encoded in this process by PyAV from YUV 4:2:0 planes that :mod:`craft_dsl.render.yuv` converts
only where a frame changed: measured on the same 600 frames, this costs a third of the CPU time of piping RGB
frames to an FFmpeg process (which converts every pixel of every frame). imageio-ffmpeg's bundled FFmpeg
still makes the GIFs: well paletted (palettegen/paletteuse) in one pass.
"""

from __future__ import annotations

import itertools
import os
import struct
import zlib
from collections.abc import Callable, Iterable, Iterator
from fractions import Fraction
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..simulation import Simulation
from .raster import DEFAULT_SIZE, SIM_FPS, RenderError, frame, frame_count, iter_frames
from .yuv import Yuv420Canvas, changed_tiles, check_frame_size, iter_yuv420

#: File extensions -> container/codec settings.
VIDEO_FORMATS = (".mpg", ".mp4", ".gif")
#: MPEG-1 settings of the original CRAFT simulator: bit rate, GOP length, at most one B-frame between anchors.
MPEG1_BITRATE = 4_000_000
MPEG1_GOP = 25
MPEG1_MAX_B_FRAMES = 1
#: The MPEG sequence end code the original appended after the last frame.
MPEG_END_CODE = b"\x00\x00\x01\xb7"
#: H.264 quality (constant rate factor; 18 is visually lossless for these flat images).
MP4_CRF = 18
_GIF_FILTER = "split[a][b];[a]palettegen=max_colors=64:stats_mode=full[p];[b][p]paletteuse=dither=none"


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of an RGB uint8 image [H, W, 3] (8-bit truecolour, no filtering)."""
    img = np.ascontiguousarray(image)
    if img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] != 3:
        raise RenderError(f"a PNG needs a uint8 [H, W, 3] image, got {img.dtype} {img.shape}")
    h, w, _ = img.shape
    raw = np.concatenate([np.zeros((h, 1), np.uint8), img.reshape(h, w * 3)], axis=1).tobytes()

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")


def write_png(sim: Simulation, path: str | os.PathLike[str], step: int, size: int = DEFAULT_SIZE) -> Path:
    """Write the frame of the state after ``step`` steps as a PNG (atomically)."""
    data = encode_png(frame(sim, step, size))
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def _video_format(path: Path) -> str:
    ext = path.suffix.lower()
    if ext not in VIDEO_FORMATS:
        raise RenderError(f"{path}: unknown video format {ext or '(none)'!r}; allowed: {', '.join(VIDEO_FORMATS)}")
    return ext


def write_frames(frames: Iterable[np.ndarray], path: str | os.PathLike[str], fps: float = SIM_FPS,
                 size: int = DEFAULT_SIZE, progress: Callable[[int], None] | None = None) -> Path:
    """Encode RGB uint8 frames [size, size, 3] to ``path`` (format from the extension; see
    :func:`write_yuv420`). ``.mpg`` and ``.mp4`` convert each frame to YUV 4:2:0 tile by tile, only where it
    differs from the frame before; ``.gif`` keeps RGB."""
    target = Path(path)
    if _video_format(target) == ".gif":
        return _write_gif(frames, target, fps, size, progress)
    return write_yuv420(_frames_to_yuv420(frames, size), target, fps, size, progress)


def _checked(frames: Iterable[np.ndarray], size: int) -> Iterator[np.ndarray]:
    for count, img in enumerate(frames):
        if getattr(img, "shape", None) != (size, size, 3):
            raise RenderError(f"frame {count} has shape {getattr(img, 'shape', None)}; expected ({size}, {size}, 3)")
        yield np.ascontiguousarray(img, dtype=np.uint8)


def _frames_to_yuv420(frames: Iterable[np.ndarray], size: int, chunk: int = 60) -> Iterator[np.ndarray]:
    """The frames as yuv420p buffers, ``chunk`` frames compared and converted at a time."""
    canvas = Yuv420Canvas(size, size)
    previous: np.ndarray | None = None
    checked = _checked(frames, size)
    while batch := list(itertools.islice(checked, chunk)):
        rgb = np.stack(batch)
        yield from canvas.frames(rgb, changed_tiles(rgb, previous, canvas.tile))
        previous = rgb[-1]


#: MPEG-1/2 sequence header frame rate codes (ISO 11172-2, and the extra codes 9-13 FFmpeg writes when asked for a
#: rate the standard lacks).
MPEG_FRAME_RATES: dict[int, Fraction] = {
    1: Fraction(24000, 1001), 2: Fraction(24), 3: Fraction(25), 4: Fraction(30000, 1001), 5: Fraction(30),
    6: Fraction(50), 7: Fraction(60000, 1001), 8: Fraction(60), 9: Fraction(15), 10: Fraction(5), 11: Fraction(10),
    12: Fraction(12), 13: Fraction(15)}
#: The frame rates an MPEG-1 stream can state (the standard's codes 1-8).
MPEG1_RATES: frozenset[Fraction] = frozenset(rate for code, rate in MPEG_FRAME_RATES.items() if code <= 8)


def write_yuv420(planes: Iterable[np.ndarray], path: str | os.PathLike[str], fps: float = SIM_FPS,
                 size: int = DEFAULT_SIZE, progress: Callable[[int], None] | None = None) -> Path:
    """Encode yuv420p frames (uint8 [size * 3 / 2, size]: Y, then U, then V) to ``path`` with PyAV, in this
    process, on one thread (so the same frames give the same bytes on any machine).

    ``.mpg``: a raw MPEG-1 video elementary stream (no container), 4 Mb/s, GOP 25, at most 1 B-frame,
    ending with the MPEG end code: the file the original CRAFT simulator wrote. ``.mp4``: H.264, CRF 18,
    with the index at the front (``faststart``).
    """
    import av

    target = Path(path)
    ext = _video_format(target)
    if ext == ".gif":
        raise RenderError(f"{target}: a GIF is written from RGB frames (write_frames), not from YUV planes")
    check_frame_size(size, size)
    rate = Fraction(fps).limit_denominator(10_000)
    if ext == ".mpg" and rate not in MPEG1_RATES:
        allowed = ", ".join(f"{float(r):.5g}" for r in sorted(MPEG1_RATES))
        raise RenderError(f"{target}: MPEG-1 (.mpg) cannot store {fps:g} frames per second (it allows {allowed}); "
                          "write an .mp4 (H.264, any rate) or a .gif instead")
    with atomic_path(target) as tmp:
        if ext == ".mpg":
            container = av.open(str(tmp), "w", format="mpeg1video")
            stream = container.add_stream("mpeg1video", rate=rate)
            stream.bit_rate = MPEG1_BITRATE
            stream.codec_context.gop_size = MPEG1_GOP
            stream.codec_context.max_b_frames = MPEG1_MAX_B_FRAMES
        else:
            container = av.open(str(tmp), "w", format="mp4", options={"movflags": "+faststart"})
            stream = container.add_stream("libx264", rate=rate, options={"crf": str(MP4_CRF)})
        stream.width = stream.height = size
        stream.pix_fmt = "yuv420p"
        stream.codec_context.thread_count = 1
        count = 0
        luma, chroma = size * size, size * size // 4
        try:
            for buffer in planes:
                if buffer.shape != (size * 3 // 2, size):
                    raise RenderError(f"frame {count} has planes of shape {buffer.shape}; "
                                      f"expected ({size * 3 // 2}, {size})")
                frame = av.VideoFrame(size, size, "yuv420p")
                y, u, v = frame.planes
                if (y.line_size, u.line_size, v.line_size) == (size, size // 2, size // 2):
                    # unpadded planes: copied in (a sixth of from_ndarray's cost); update() reads any buffer,
                    # though PyAV's stubs say bytes
                    flat = buffer.reshape(-1)
                    y.update(flat[:luma])  # type: ignore[arg-type]
                    u.update(flat[luma:luma + chroma])  # type: ignore[arg-type]
                    v.update(flat[luma + chroma:])  # type: ignore[arg-type]
                else:
                    frame = av.VideoFrame.from_ndarray(buffer, format="yuv420p")
                frame.pts = count
                container.mux(stream.encode(frame))
                count += 1
                if progress is not None:
                    progress(1)
            if count:
                container.mux(stream.encode(None))
        finally:
            container.close()
        if count == 0:
            raise RenderError(f"{target}: no frames to write (the simulation has no steps at this frame rate)")
        if ext == ".mpg":
            with tmp.open("ab") as fh:
                fh.write(MPEG_END_CODE)
    return target


def _write_gif(frames: Iterable[np.ndarray], target: Path, fps: float, size: int,
               progress: Callable[[int], None] | None) -> Path:
    """A paletted GIF through imageio-ffmpeg's FFmpeg (palettegen/paletteuse in one pass)."""
    import imageio_ffmpeg

    with atomic_path(target) as tmp:
        writer = imageio_ffmpeg.write_frames(str(tmp), (size, size), fps=fps, macro_block_size=1,
                                             ffmpeg_log_level="error", codec="gif", pix_fmt_out="pal8",
                                             output_params=["-filter_complex", _GIF_FILTER])
        writer.send(None)
        count = 0
        try:
            for img in _checked(frames, size):
                writer.send(img)
                count += 1
                if progress is not None:
                    progress(1)
        finally:
            writer.close()
        if count == 0:
            raise RenderError(f"{target}: no frames to write (the simulation has no steps at this frame rate)")
    return target


def write_video(sim: Simulation, path: str | os.PathLike[str], fps: float = SIM_FPS, size: int = DEFAULT_SIZE,
                progress: bool = False) -> Path:
    """Render ``sim`` and write it as a video (format from the extension), with an optional progress bar."""
    target = Path(path)
    gif = _video_format(target) == ".gif"
    total = frame_count(sim, fps)

    def write(update: Callable[[int], None] | None) -> Path:
        if gif:
            return _write_gif(iter_frames(sim, fps, size), target, fps, size, update)
        return write_yuv420(iter_yuv420(sim, fps, size), target, fps, size, update)

    if not progress:
        return write(None)
    from tqdm import tqdm

    with tqdm(total=total, unit="frame", desc=target.name, leave=False) as bar:
        return write(bar.update)
