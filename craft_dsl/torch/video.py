"""Decoding dataset videos and frame images into arrays with PyAV (the ``torch`` extra).

The published CRAFT videos are raw MPEG-1 streams without timestamps a player could trust, so frames are taken
by position: frame ``i`` of a 60 fps video shows the simulation after ``i + 1`` steps, and a lower rate ``fps``
keeps the frames the renderer would have drawn at that rate (:func:`craft_dsl.render.frame_steps`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CraftError
from ..reader.video import rgb_converter
from ..render import frame_steps

Size = int | tuple[int, int] | None


def _av() -> Any:
    import av  # a core dependency (it also encodes the videos)

    return av


def _hw(size: Size) -> tuple[int, int] | None:
    if size is None:
        return None
    h, w = (size, size) if isinstance(size, int) else size
    if h < 1 or w < 1:
        raise CraftError(f"frame size must be positive, got {size!r}")
    return int(h), int(w)


def _open(path: Path) -> Any:
    av = _av()
    if not path.is_file():
        raise CraftError(f"{path}: no such video or frame file (generate the dataset with --videos)")
    try:
        return av.open(str(path))
    except Exception as err:  # noqa: BLE001 - PyAV raises its own error classes
        raise CraftError(f"{path}: cannot be decoded ({err})") from None


def decode_video(path: str | os.PathLike[str], fps: float | None = None, size: Size = None) -> np.ndarray:
    """Frames of a video as uint8 [T, H, W, 3] (RGB).

    ``fps`` (at most the video's rate; ``None`` keeps every frame) picks the frames the renderer draws at that
    rate; ``size`` (an int or (height, width)) resizes each kept frame with area averaging.
    """
    target = Path(path)
    container = _open(target)
    hw = _hw(size)
    try:
        stream = container.streams.video[0]
        rate = float(stream.guessed_rate or stream.average_rate or 60)
        decoded = list(container.decode(stream))
    except CraftError:
        raise
    except Exception as err:  # noqa: BLE001
        raise CraftError(f"{target}: cannot be decoded ({err})") from None
    finally:
        container.close()
    if not decoded:
        raise CraftError(f"{target}: the video has no frames")
    if fps is None or fps >= rate:
        keep = list(range(len(decoded)))
    else:
        keep = [int(r) - 1 for r in frame_steps(len(decoded), fps, int(round(rate)))]
    to_rgb = rgb_converter() if hw is None else rgb_converter(width=hw[1], height=hw[0], interpolation="AREA")
    return np.stack([to_rgb(decoded[i]) for i in keep])


def decode_image(path: str | os.PathLike[str], size: Size = None) -> np.ndarray:
    """A PNG frame image as uint8 [H, W, 3] (RGB), resized like :func:`decode_video`."""
    frames = decode_video(path, None, size)
    return frames[0]


__all__ = ["decode_image", "decode_video"]
