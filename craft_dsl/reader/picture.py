"""Where the square CRAFT picture lies in a frame that is not square.

A CRAFT picture is square. A video whose frames are not square holds it in one of two ways:

* **boxed**: padded with bars of one colour on two opposite sides (letterboxed or pillarboxed, as an editor or a
  player pads a square video to 16:9 or 4:3). The picture is the square between the bars;
* **stretched**: rescaled to the frame's shape (320x240, say), or boxed into bars that leave a region of another
  shape. The picture is the whole region, to be rescaled back to a square.

:func:`find_picture` measures which, from the video's first frames. A bar is an outer line of the frame (a column
for bars on the left and right, a row for bars above and below) whose pixels are all one colour, within
:data:`BAR_TOLERANCE`, in every frame looked at, and that colour is the outermost line's. No line of a CRAFT picture
is one colour but its border lines: the walls at its left and right edges and the ground along its bottom (every
other row and column holds the background and a wall or the ground). A black bar therefore takes in the black wall
line beside it, a bar of another colour stops at it; the region between the bars is a boxed square's side less up to
those two lines, and within :func:`slack` of the frame's short side it is taken as that square, centred on the
region. Bars no wider in all than that slack are the picture's own wall lines: the whole frame is the picture,
stretched. Square frames are never searched: their picture is the whole frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

#: A bar's pixels differ from its colour by at most this much in every channel (compression leaves a flat bar nearly
#: flat; a CRAFT picture's lines hold the white background beside black walls or bodies).
BAR_TOLERANCE = 24
#: Frames :func:`find_picture` looks at, from the first.
PICTURE_FRAMES = 4


def slack(short_side: int) -> int:
    """Pixels by which the region between two bars may differ from the frame's short side and still be that square:
    the two wall lines a black bar takes in (a 256-px picture's walls are 1 px wide; wider in a larger copy) and the
    compression's blur of the bars' inner edges."""
    return max(4, math.ceil(0.03 * short_side))


@dataclass(frozen=True)
class Picture:
    """The picture's region of the frame (pixels: left column, top row, width, height) and how it was found."""

    x: int
    y: int
    width: int
    height: int
    frame_width: int
    frame_height: int
    how: Literal["whole", "boxed", "stretched"]

    @classmethod
    def whole(cls, width: int, height: int) -> Picture:
        """The whole ``width`` x ``height`` frame (a square frame's picture)."""
        return cls(0, 0, width, height, width, height, "whole")

    @property
    def side(self) -> int:
        """The size (pixels) the picture is drawn at: its shorter side."""
        return min(self.width, self.height)

    def to_json(self) -> dict[str, object]:
        return {"how": self.how, "box": [self.x, self.y, self.width, self.height],
                "frame": [self.frame_width, self.frame_height]}


def _uniform_lines(frames: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """bool per line along ``axis`` (1: columns, 0: rows) of frames [n, H, W, 3]: the line is one colour, within
    :data:`BAR_TOLERANCE`, in every frame; and int16 [lines, 3] its colour (the first frame's median)."""
    lines = np.moveaxis(frames.astype(np.int16), axis + 1, 0)  # [lines, n, other, 3]
    colour = np.median(lines[:, 0], axis=1)  # [lines, 3]
    spread = np.abs(lines - colour[:, None, None, :]).max(axis=(1, 2, 3))
    return spread <= BAR_TOLERANCE, colour


def _bar(uniform: np.ndarray, colour: np.ndarray, reverse: bool) -> int:
    """How many outer lines (from the end where ``reverse``) are a bar: uniform, of the outermost line's colour."""
    order = range(len(uniform) - 1, -1, -1) if reverse else range(len(uniform))
    count = 0
    first: np.ndarray | None = None
    for i in order:
        if not uniform[i]:
            break
        if first is None:
            first = colour[i]
        elif np.abs(colour[i] - first).max() > BAR_TOLERANCE:
            break
        count += 1
    return count


def find_picture(frames: np.ndarray) -> Picture:
    """The picture's region in frames uint8 [n, H, W, 3] (the video's first frames at its own size; see the module
    docstring)."""
    if frames.ndim != 4 or frames.shape[0] == 0 or frames.shape[3] != 3:
        raise ValueError(f"expected frames [n, H, W, 3], got shape {frames.shape}")
    height, width = int(frames.shape[1]), int(frames.shape[2])
    if width == height:
        return Picture.whole(width, height)
    wide = width > height
    long_side, short_side = max(width, height), min(width, height)
    uniform, colour = _uniform_lines(frames, 1 if wide else 0)
    lead = _bar(uniform, colour, reverse=False)
    trail = _bar(uniform, colour, reverse=True) if lead < long_side else 0
    inner = long_side - lead - trail
    if lead + trail <= slack(short_side) or inner <= 0:  # no bars but the walls (or one colour): stretched
        start, extent, how = 0, long_side, "stretched"
    elif abs(inner - short_side) <= slack(short_side):  # the square between the bars
        start = min(max(round(lead + (inner - short_side) / 2), 0), long_side - short_side)
        extent, how = short_side, "boxed"
    else:  # bars leaving a region of another shape: that region, stretched
        start, extent, how = lead, inner, "stretched"
    if wide:
        return Picture(start, 0, extent, height, width, height, how)  # type: ignore[arg-type]
    return Picture(0, start, width, extent, width, height, how)  # type: ignore[arg-type]
