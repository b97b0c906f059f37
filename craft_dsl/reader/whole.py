"""Whether a video shows a whole CRAFT run, and if not, why.

A video that is not whole is still read, but its answers say so (``Answer.warning``, a confidence no higher than a
guess's): answers about the end of the video, or about events the missing part held, are those of the part it
shows. Four things say a video is not whole:

* the file: an MPEG-1 stream without its end code, a container holding fewer frames than it states
  (:func:`craft_dsl.reader.video.incomplete`);
* frames missing inside it: its frames' times leave gaps (read each at its own time,
  :func:`craft_dsl.reader.video.timed_steps`);
* its length: its frames show fewer steps than the run has (:func:`cut_short`: ``steps``, 600 for CRAFT's 10 s;
  ``craft-dsl generate --steps N`` writes runs of N steps). A file re-encoded from a cut copy is whole as a file
  but not as a run;
* its start: no run from the layout's start positions reproduces its first frames (:func:`cut_at_start`): the
  video was cut at the start (its first frame shows bodies in flight), or it is not of a layout the reader knows.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..render.raster import SIM_FPS
from .perceive import Perception
from .video import RUN_STEPS, collect_unchecked, incomplete

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


def why_not_whole(path: str, perception: Perception, steps: int = RUN_STEPS) -> str | None:
    """The reasons (joined) why the video at ``path``, read as ``perception``, is not a whole run of ``steps``
    steps; None when nothing says so. Whether the file lost frames, where it cannot be checked
    (:func:`~craft_dsl.reader.video.not_checked`), is a reason too: the answers' confidences can only fall."""
    # a file cut short is cut short as a run too: the file's reason says which
    with collect_unchecked() as unchecked:  # a check that could not be made counts as failed: the worst case
        length = incomplete(path, perception.scene.video.frames) or cut_short(perception.frame_steps, steps)
    found = [r for r in (length, frames_missing(perception.frames_missing, perception.scene.meta.get("first_gap_s")),
                         cut_at_start(perception.reconstruction.start_px)) if r is not None]
    found += [f"it may not be ({message})" for message in unchecked]
    return "; ".join(found) if found else None
