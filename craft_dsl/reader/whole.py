"""Whether a video shows a whole CRAFT run, and if not, why.

A video that is not whole is still read, but its answers say so (``Answer.warning``, a confidence no higher than a
guess's): answers about the end of the video, or about events the missing part held, are those of the part it
shows. Five things say a video is not whole:

* the file: an MPEG-1 stream without its end code, a container holding fewer frames than it states
  (:func:`craft_dsl.reader.video.incomplete`);
* frames missing inside it: its frames' times leave gaps (read each at its own time,
  :func:`craft_dsl.reader.video.timed_steps`);
* its length: its frames show fewer steps than the run has (:func:`cut_short`: ``steps``, 600 for CRAFT's 10 s;
  ``craft-dsl generate --steps N`` writes runs of N steps). A file re-encoded from a cut copy is whole as a file
  but not as a run;
* its start: no run from the layout's start positions reproduces its first frames (:func:`cut_at_start`): the
  video was cut at the start (its first frame shows bodies in flight), or it is not of a layout the reader knows;
* its picture: the picture is cropped (:func:`cropped`). Every CRAFT picture, craft_dsl's and the original
  renderer's, has its black wall lines along its left and right edges and the ground line along its bottom (the
  statics ``wall_l``, ``wall_r``, ``ground`` of every layout, about 1 px wide at 256 px); a crop cuts them off, and
  the reader, whose layouts place every static at a fixed scale and offset, reads the rest of it shifted and
  enlarged. A copy letterboxed or padded to another aspect is whole: the bars are removed before this is looked at
  (:mod:`craft_dsl.reader.picture`), and its picture keeps its lines.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping

import numpy as np

from ..errors import ReaderError
from ..render.raster import DEFAULT_SIZE, SIM_FPS
from .perceive import Perception
from .picture import PICTURE_FRAMES
from .video import RUN_STEPS, collect_unchecked, decode_video, incomplete, not_checked

#: Pixels: a body whose run, fitted from the start, is further than this from its track, on average over the first
#: fit's frames, does not start where the layout starts it.
START_PX = 5.0


def cut_short(frame_steps: np.ndarray, steps: int = RUN_STEPS) -> str | None:
    """Why frames showing steps ``frame_steps`` are not a whole run of ``steps`` steps (None: they are): the last
    frame shows a step more than a frame's gap before the run's end."""
    rows = np.asarray(frame_steps)
    if not rows.size:
        return None
    gap = math.ceil(float(np.median(np.diff(rows)))) if rows.size > 1 else 1  # the frames' cadence, in steps
    last = int(rows[-1])
    if last + gap >= steps:
        return None
    return (f"its frames end at step {last} ({last / SIM_FPS:.1f} s) of the run's {steps} ({steps / SIM_FPS:.1f} s): "
            f"the video was cut short (or shows a run of another length: --steps N)")


def cut_at_start(start_px: Mapping[int, float]) -> str | None:
    """Why a video is not the start of a run (None: it is), given each body's distance (pixels) from the run fitted
    from the layout's start over the first fit's frames (``start_px``, by uid; bodies seen there): more than half
    its bodies, and two at least, do not start where the layout starts them (further than :data:`START_PX`). One
    body that does not is a misreading (a slot taken by the wrong body, say); in a video cut at the start, bodies
    are in flight in its first frame. Measured on the 345 whole held-out test videos of seed 20261215 (1,289 bodies):
    7 with one body off, one with two of its four (two small circles launched at 24-26 m/s from the right edge), none
    with more than half; of four videos cut 1 s into their runs, three with 3 of 3 to 4 of 5 off (16-20 px), one with
    2 of 4 (its length says it is cut)."""
    far = sorted(d for d in start_px.values() if d > START_PX)
    if len(far) < 2 or 2 * len(far) <= len(start_px):
        return None
    return (f"{len(far)} of its {len(start_px)} bodies are not where the layout starts them in its first frames "
            f"(runs from the layout's start positions {min(far):.1f}-{max(far):.1f} px from them; a whole video's "
            f"within {START_PX:g} px): the video was cut at the start, or is not of this layout")


def frames_missing(missing: int, first_gap_s: float | None = None) -> str | None:
    """Why a video whose frames' times show ``missing`` frames missing inside it is not whole (None: none are)."""
    if missing <= 0:
        return None
    where = f", the first {first_gap_s:.2f} s into it" if first_gap_s is not None else ""
    return f"{missing} frames are missing inside it{where} (each frame is read at the step its time shows)"


#: Outer lines (columns at the left and right, rows at the bottom) of the reader's 256-px picture in which a border
#: line is looked for: the line is the outermost one, give or take the blur of compression and rescaling and a bar's
#: edge left by :func:`~craft_dsl.reader.picture.find_picture`.
BORDER_BAND = 3
#: A border line is there where the darkest of the :data:`BORDER_BAND` outer lines (each line's median, over the
#: first frames' median) is darker than the picture's background (its median) by at least this share of the
#: background's level, times the picture's own side over 256 where it is smaller (a 1-px line drawn at 128 px is
#: half a pixel, read at half its contrast). Measured (first 4 frames, share of the background): 0.996 at every
#: border of 317 original-renderer videos and 298 Box2D ones as written; copies re-encoded (H.264 crf 28: 0.96-0.99,
#: MPEG-4 q 8: 0.97-1.0), resampled to 5 fps (0.99-1.0), graded (gamma 1.5: 0.89; limited range: 0.93), rescaled to
#: 512 px (0.93), stretched to 320x240 (0.87), letterboxed to 16:9 or padded to 4:3, black or grey bars removed
#: (0.93-1.0); rescaled to 128 px 0.50-0.51 (its threshold 0.15), 96 px 0.38, 64 px 0.27; cropped by 2, 4 or 8 px
#: (lossless or H.264 crf 28, letterboxed after the crop too) 0.00-0.01.
BORDER_CONTRAST = 0.3


def border_contrast(frames: np.ndarray) -> dict[str, float]:
    """How much darker than the picture's background its outer lines are, frames uint8 [n, S, S, 3] (the reader's
    picture, :func:`first_pictures`): per border (``left``, ``right``, ``bottom``), the darkest of the
    :data:`BORDER_BAND` outer lines (each line's median luminance, the median over the frames) below the background
    (the frames' median luminance), as a share of the background's level (1: black lines on any background; 0: no
    line darker than the background)."""
    if frames.ndim != 4 or frames.shape[0] == 0 or frames.shape[3] != 3:
        raise ValueError(f"expected frames [n, S, S, 3], got shape {frames.shape}")
    lum = frames.astype(np.float32).mean(axis=-1)  # [n, S, S]
    band = max(1, round(BORDER_BAND * lum.shape[2] / DEFAULT_SIZE))
    background = float(np.median(lum))
    lines = {"left": np.median(lum[:, :, :band], axis=1),  # [n, band]: each column's median over the rows
             "right": np.median(lum[:, :, -band:], axis=1),
             "bottom": np.median(lum[:, -band:, :], axis=2)}
    out = {}
    for side, values in lines.items():
        darkest = float(np.min(np.median(values, axis=0)))
        out[side] = max(0.0, background - darkest) / max(background, 1.0)
    return out


#: What a border line missing at each border is called.
_LINES = {"left": "left wall line", "right": "right wall line", "bottom": "ground line"}


def cropped(frames: np.ndarray, source_side: int | None = None) -> str | None:
    """Why the picture in ``frames`` (the reader's, :func:`first_pictures`) looks cropped (None: it does not): a
    border line of every CRAFT picture is not at the frame's edge (:func:`border_contrast` under
    :data:`BORDER_CONTRAST`, scaled down for a picture drawn at ``source_side`` px under 256)."""
    contrast = border_contrast(frames)
    scale = min(1.0, (source_side or DEFAULT_SIZE) / DEFAULT_SIZE)
    least = BORDER_CONTRAST * scale
    missing = [side for side in ("left", "right", "bottom") if contrast[side] < least]
    if not missing:
        return None
    names = [_LINES[side] for side in missing]
    what = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    verb = "is" if len(names) == 1 else "are"
    found = ", ".join(f"{side} {contrast[side]:.0%}" for side in missing)
    return (f"the picture's {what} {verb} not at the frame's edge: the picture looks cropped (the darkest of its "
            f"{BORDER_BAND} outer lines there is {found} darker than its background; a border line, {least:.0%} at "
            f"least)")


def first_pictures(path: str | os.PathLike[str], count: int = PICTURE_FRAMES, size: int = DEFAULT_SIZE
                   ) -> tuple[np.ndarray, int]:
    """The first ``count`` frames of the video at ``path`` as the reader reads them (uint8 [n, size, size, 3]: the
    picture found in frames that are not square, :func:`~craft_dsl.reader.picture.find_picture`, rescaled to
    ``size``), and the picture's own side (pixels): :func:`~craft_dsl.reader.video.decode_video` limited to them.
    :class:`ReaderError` where it cannot be decoded."""
    decoded = decode_video(path, size=size, limit=count)
    return decoded.frames, decoded.picture.side


def cropped_video(path: str | os.PathLike[str]) -> str | None:
    """Why the video at ``path`` looks cropped (:func:`cropped` of :func:`first_pictures`; None: it does not). A
    video whose first frames cannot be decoded again could not be checked (:func:`~craft_dsl.reader.video.
    not_checked`)."""
    try:
        frames, side = first_pictures(path)
    except ReaderError as err:
        not_checked(f"whether its picture is cropped could not be checked ({err})")
        return None
    return cropped(frames, side)


def why_not_whole(path: str, perception: Perception, steps: int = RUN_STEPS) -> str | None:
    """The reasons (joined) why the video at ``path``, read as ``perception``, is not a whole run of ``steps``
    steps; None when nothing says so. Whether the file lost frames, or whether its picture is cropped, where it
    cannot be checked (:func:`~craft_dsl.reader.video.not_checked`), is a reason too: the answers' confidences can
    only fall."""
    # a file cut short is cut short as a run too: the file's reason says which
    with collect_unchecked() as unchecked:  # a check that could not be made counts as failed: the worst case
        length = incomplete(path, perception.scene.video.frames) or cut_short(perception.frame_steps, steps)
        picture = cropped_video(path)
    found = [r for r in (length, frames_missing(perception.frames_missing, perception.scene.meta.get("first_gap_s")),
                         cut_at_start(perception.reconstruction.start_px), picture) if r is not None]
    found += [f"it may not be ({message})" for message in unchecked]
    return "; ".join(found) if found else None
