"""Whether a body is moving when the video ends, as its frames show it.

"Moving when the video ends" (the paper's D/2Q questions: ``FilterMoving(..., EndSceneStep())``) is a velocity
above 0.001 m/s in the last step. A body that comes to rest stops at once (and both engines put it to sleep after
30 steps of rest), while a reconstructed run that follows the video to within a pixel can still end otherwise: a
body left jittering on a ledge the true body came to rest on, one stopped some frames early, or one the run has
flying off where the video shows it lying still. What the frames show of one body
(:func:`seen_moving_at_end`):

* moving: the body's position, averaged over :data:`MEAN_STEPS` (which also averages out the compression's
  periodic flicker of a still body's edges), is :data:`MOVE_PX` (and twice the centroid's own jitter) from the last
  one :data:`MOVING_STEPS` before the end, and at least as far twice as long before;
* at rest: seen still (within the same distance) in most frames of the last :data:`RESTING_STEPS` steps;
* nothing (a body hidden at the end or cut off by the frame's border, one that stopped 10-40 steps before it, a
  passing jump of the centroid).

Body by body this corrects the run more often than it breaks it (879 bodies of two development seeds: 37 ended
wrongly by the run, 24 corrected, 3 broken), but D/2Q questions count bodies, and a count is right only when every
body it counts is: taken body by body it lost 5 of 69 answers on a fresh seed. So the frames decide a scene as a whole
(:func:`scene_moving_at_end`: every body decided), and only where the run cannot also be right: a body seen still
whose run moves fast enough to have shown (a slower one may be creeping, as true bodies do), or one seen moving that
the run stopped before the frames' last window (a body stopping in the last steps is seen moving). In a scene they
decide only in part, they overrule the run only where the two flatly disagree: a body seen still that the run has
flying on.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..simulation import Trajectory
from ..vocabulary import MOVING_THRESHOLD
from .detect import Blob

#: Steps over which a body's blob centroid is averaged (at 60 fps, two periods of the 4-frame flicker that an
#: MPEG group gives a still body's edges).
MEAN_STEPS = 8
#: Pixels (at the reader's frame size) by which the averaged position must move to count as motion, at least.
MOVE_PX = 0.2
#: ... and at least this many times the video's own jitter of that body's centroid (a lossy copy's is larger).
JITTER_FACTOR = 2.0
#: A body is moving at the end when its averaged position this many steps before the end is :data:`MOVE_PX` from
#: the last one, and twice as many steps before :data:`STEADY_RATIO` times as far (a steady motion, not a passing
#: artefact).
MOVING_STEPS = 10
#: A moving body is further from its last position twice as many steps before: twice as far at a steady speed, 1.2
#: times (averaged positions) for one that started falling from rest 20 steps before the end. A still body whose
#: centroid a lossy copy shifts once, where a group of pictures begins (MPEG-4 at q 8: 1.6 px), is as far at both.
STEADY_RATIO = 1.1
#: A body still for this many steps before the last frame is at rest at the end (sleeping takes 30).
RESTING_STEPS = 40
#: Share of the frames of the last :data:`RESTING_STEPS` steps in which a resting body must be seen alone.
RESTING_COVER = 0.8
#: m/s: a run that moves a body this fast over the last :data:`RESTING_STEPS` steps moves it by 0.8 px at the
#: reader's frame size, which the frames would show: below it a body seen still may be creeping in the truth too.
VISIBLE_SPEED = 0.23
#: m/s: in a scene the frames do not decide as a whole, a body seen still whose run ends at least this fast (1.7 px
#: over the last :data:`RESTING_STEPS` steps) is at rest all the same: the frames and the run flatly disagree.
CONTRADICTED_SPEED = 0.5


def seen_moving_at_end(blobs: Sequence[Blob | None], rows: np.ndarray) -> bool | None:
    """True (moving), False (at rest) or None (the frames do not say) for a body with ``blobs`` (one per frame,
    None where it is not seen alone) in frames showing steps ``rows``. A blob that touches the frame's border counts
    as not seen for motion (it moves with the cut, not with the body), but a body cut by the border whose blob stays
    put is at rest (a body moving in or out of the picture changes its cut). A blob that reaches the border only
    along the ground line (:attr:`Blob.on_floor`: a body lying on the ground, blurred into the line) is seen: the
    ground does not move."""
    seen = _seen_moving_at_end(blobs, rows, cut=False)
    if seen is None and _seen_moving_at_end(blobs, rows, cut=True) is False:
        return False
    return seen


def _seen_moving_at_end(blobs: Sequence[Blob | None], rows: np.ndarray, cut: bool) -> bool | None:
    """:func:`seen_moving_at_end`, counting blobs that touch the frame's border as seen where ``cut``."""
    rows = np.asarray(rows)
    if len(blobs) != rows.size or not rows.size:
        return None
    last_step = int(rows[-1])
    first = int(np.searchsorted(rows, last_step - 2 * MOVING_STEPS - RESTING_STEPS, side="right"))
    # a blob cut off by the frame border moves with the cut, not with the body: such frames are not looked at
    seen = [(int(rows[k]), b.x, b.y) for k, b in enumerate(blobs[first:], first)
            if b is not None and (cut or not b.touches_edge or b.on_floor)]
    if not seen or seen[-1][0] != last_step:  # not seen in the last frame
        return None
    steps = np.array([s for s, _x, _y in seen])
    xy = np.array([(x, y) for _s, x, y in seen])
    # trailing means (frame i: the seen frames of steps (steps[i] - MEAN_STEPS, steps[i]]) and centred ones
    sums = np.vstack([np.zeros((1, 2)), np.cumsum(xy, axis=0)])

    def means(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        return (sums[hi] - sums[lo]) / np.maximum(hi - lo, 1)[:, None]

    half = MEAN_STEPS // 2
    trailing = means(np.searchsorted(steps, steps - MEAN_STEPS, side="right"), np.arange(1, steps.size + 1))
    centred = means(np.searchsorted(steps, steps - half), np.searchsorted(steps, steps + half))
    jitter = float(np.median(np.hypot(*(xy - centred).T)))
    threshold = max(MOVE_PX, JITTER_FACTOR * jitter)
    away = np.hypot(*(trailing - trailing[-1]).T)  # how far each averaged position is from the last one
    gap = max(2, int(np.max(np.diff(rows[-4:]), initial=1)))

    def away_at(step: int) -> float | None:
        """The distance at the last seen frame at or before ``step`` (None: none within a frame's gap of it)."""
        i = int(np.searchsorted(steps, step, side="right")) - 1
        return float(away[i]) if i >= 0 and steps[i] >= step - gap else None

    near, far = away_at(last_step - MOVING_STEPS), away_at(last_step - 2 * MOVING_STEPS)
    if near is not None and far is not None and near > threshold and far >= STEADY_RATIO * near:
        return True
    window = steps >= last_step - RESTING_STEPS
    if steps[0] > last_step - RESTING_STEPS or np.count_nonzero(window) < RESTING_COVER * np.count_nonzero(
            rows >= last_step - RESTING_STEPS):
        return None
    return False if float(away[window].max()) <= threshold else None


@dataclass(frozen=True)
class RunEnd:
    """How the reconstructed run ends for one body."""

    moving: bool  # faster than the moving threshold in the last step
    speed: float  # m/s in the last step
    last_moving: int  # the last step in which it moved (-1: never)


def run_end(trajectory: Trajectory, uid: int) -> RunEnd:
    """:class:`RunEnd` of body ``uid`` in a run's trajectory (velocities per step)."""
    v = trajectory.velocities[:, trajectory.column(uid)]
    moving = np.nonzero(np.abs(v).max(axis=1) > MOVING_THRESHOLD)[0]
    return RunEnd(bool(moving.size and moving[-1] == v.shape[0] - 1), float(np.hypot(*v[-1])),
                  int(moving[-1]) if moving.size else -1)


def scene_moving_at_end(blobs_by_slot: Mapping[int, Sequence[Blob | None]], runs: Mapping[int, RunEnd], slots: int,
                        rows: np.ndarray) -> dict[int, bool]:
    """Whether each body of a scene (by slot) is moving at the end, where the frames decide it for every one of the
    ``slots`` dynamic bodies (``blobs_by_slot``: the tracked body of each slot; ``runs``: how the run ends for it).
    The frames overrule the run only where the two cannot both be right: a body seen still whose run moves fast
    enough to have shown (:data:`VISIBLE_SPEED`; a slower one may be creeping), or a body seen moving that the run
    stopped before the last :data:`MOVING_STEPS` steps.

    A scene the frames decide only in part is left to the run, but for the bodies on which the two flatly disagree:
    seen still (for the last :data:`RESTING_STEPS` steps) while the run ends at :data:`CONTRADICTED_SPEED` or faster.
    Subtler corrections wait for the whole scene: a count is right only when every body it counts is, and correcting
    one body of a pair the run swapped turns a right count wrong. A body seen moving that the run stopped long before
    is not corrected alone either: on MPEG-4 copies the frames saw still bodies move (2 of 10 such bodies)."""
    last_step = int(np.asarray(rows)[-1]) if len(rows) else 0
    found: dict[int, bool] = {}
    for slot, blobs in blobs_by_slot.items():
        seen = seen_moving_at_end(blobs, rows)
        if seen is None or slot not in runs:
            continue
        run = runs[slot]
        if seen and not run.moving and run.last_moving > last_step - MOVING_STEPS:
            seen = False  # the run stops it in the frames where they see it move: the stop may be right
        elif not seen and run.moving and run.speed < VISIBLE_SPEED:
            seen = True  # a run that creeps too slowly to show
        found[slot] = seen
    if len(found) == slots:
        return found
    return {slot: False for slot, seen in found.items()  # in part: the bodies seen still that the run has flying on
            if not seen and runs[slot].moving and runs[slot].speed >= CONTRADICTED_SPEED}
