"""From blobs to objects: how many bodies of each colour, which blob is which body in each frame, and what each
body is (shape and size, with probabilities).

Every dynamic object of a CRAFT scene has a unique (shape, colour, size), so a colour holds one body or a few of
different shapes or sizes. Per colour, the number of bodies is the largest number of separate, substantial blobs
seen in at least :data:`MIN_FRAMES` frames (bodies of one colour touch, hide in the basket's corner or leave the
picture for a while, but not for the whole video), blobs close together counting as pieces of one body
(:data:`PIECE_DISTANCE`). In each frame, blobs are given to the colour's bodies by a
nearest-neighbour assignment from their last positions, with the blob's area as a second cue; a blob covering two
bodies of one colour (its area about their sum) is given to neither, and that frame is left out for both: the
physics fills it in. Two such bodies that bounce off each other come out of the merge on the wrong tracks by
position alone: :func:`relink_merges` keeps or swaps the tracks' parts after each merge, whichever lets each track
be one (shape, size). A track that jumps further than a body moves in the steps between holds sightings that are not
its body's (a piece of another body of its colour, a speck of the colour a lossy video shows while the body is
hidden): its short runs between such jumps are dropped (:func:`drop_strays`), as are its sightings inside a larger
body of another colour (:func:`drop_riding`). In a video of fewer than 60 frames per second (``steps``: the step
each frame shows) a body moves up to 12 times further between frames: its last position is carried forward by its
velocity over the steps between (from its last two sightings) before the assignment; at 60 fps the last position is
used as it is.

Shape and size come from the full-resolution measurement (:mod:`craft_dsl.reader.measure`) of the frames where the
body is complete: the median area, the largest radius over the square root of the area, and the normalised second
moment, against the values each (shape, size) gives (calibrated on generated videos, :data:`SHAPE_FEATURES`; for a
video drawn smaller and rescaled as it was decoded, :func:`shape_features`, whose bodies measure smaller and whose
drawing render-and-compare blurs, :func:`source_blur`). The per-frame likelihoods make the probabilities (a Student-t
model, so that one bad frame cannot decide).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..render.raster import DEFAULT_SIZE
from ..vocabulary import COLORS, SHAPES, SIZES
from .detect import GRAY, PALETTE, SOFT_RESIDUAL, Blob, cb_cr, mix_residual
from .measure import Measurement, measure_many
from .refine import SOFT_ANGLE_STARTS, refine

#: A colour counts n bodies when at least this many frames show n separate substantial blobs of it.
MIN_FRAMES = 6
#: Blobs smaller than this (full-resolution pixels of body colour) do not count as a body (pupil rims read as gray).
SUBSTANTIAL_AREA = 16.0
#: Two blobs of one colour in a frame are pieces of one body when their centres are nearer than this times the
#: square root of their summed area. Measured: the apex and base of a large triangle cut by the original renderer's
#: eyes, 0.74-0.83; over 167 held-out videos of both renderers no colour's count fell under its number of bodies
#: (bodies of one colour are further apart than this in enough frames), and 64 -> 79 were counted exactly.
PIECE_DISTANCE = 1.0
#: Window (pixels) of the full-resolution measurement.
WINDOW = 48
#: (shape, size) -> (centre, spread) of the three shape features.
FeatureTable = dict[tuple[str, str], tuple[tuple[float, float, float], tuple[float, float, float]]]
#: (shape, size) -> median and spread of the measured (area px^2, radius / sqrt(area), second moment / area) of a
#: complete body, from generated MPEG-1 videos (dev seeds).
SHAPE_FEATURES: FeatureTable = {
    ("circle", "large"): ((329.8, 0.552, 0.1599), (1.3, 0.007, 0.0002)),
    ("circle", "small"): ((44.8, 0.682, 0.2006), (4.1, 0.079, 0.0118)),
    ("cube", "large"): ((419.0, 0.707, 0.1667), (6.0, 0.02, 0.003)),
    ("cube", "small"): ((56.5, 0.669, 0.2002), (4.0, 0.028, 0.0070)),
    ("triangle", "large"): ((306.7, 0.808, 0.1930), (2.0, 0.005, 0.0005)),
    ("triangle", "small"): ((127.5, 0.820, 0.2140), (13.8, 0.056, 0.0128)),
}
#: The same for a video drawn at 128 px and read at :data:`DEFAULT_SIZE` (rescaled as it is decoded), its colours
#: read softly (:func:`soft_source`): bodies measure a little larger than drawn at 256 px, small ones most (a small
#: circle 56 px^2 instead of 45), and rounder. Medians and robust spreads (1.4826 x median absolute deviation, at least
#: the native spread) of 573 bodies of the 214 test videos of two generated datasets (seeds 9494, 9696) copied at
#: 128 px by ffmpeg's ``scale`` (bicubic), lossless H.264: ``python benchmarks/shape_features.py --dataset DIR
#: --dataset DIR2 --size 128``.
SHAPE_FEATURES_128: FeatureTable = {
    ("circle", "large"): ((336.5, 0.5969, 0.1625), (5.4, 0.0092, 0.0004)),
    ("circle", "small"): ((56.3, 0.6438, 0.1862), (4.1, 0.0790, 0.0118)),
    ("cube", "large"): ((427.1, 0.6740, 0.1680), (8.7, 0.0200, 0.0030)),
    ("cube", "small"): ((75.3, 0.6489, 0.1831), (6.5, 0.0303, 0.0070)),
    ("triangle", "large"): ((312.7, 0.7909, 0.1909), (11.0, 0.0244, 0.0022)),
    ("triangle", "small"): ((126.2, 0.7991, 0.2052), (13.8, 0.0560, 0.0128)),
}
#: Blur (pixels, Gaussian sigma at :data:`DEFAULT_SIZE`) that a video drawn at 128 px has once rescaled: the drawing
#: that render-and-compare fits is blurred as much (see :func:`source_blur`). On the copies above, the residual picks
#: the right shape of 53 of 78 small bodies drawn sharp, 67-71 blurred by 0.9-1.5 (lowest median residual at 1.3).
BLUR_128 = 1.2
#: Spreads are widened by this factor (compression noise varies between videos).
SPREAD_FACTOR = 3.0


def _upscaling(source_size: int | None) -> float:
    """0 for a video read at its own size (or larger), 1 for one drawn at half the read size (128 px) or less,
    in between for the sizes between (linear in the scale factor)."""
    if source_size is None or source_size >= DEFAULT_SIZE:
        return 0.0
    return min(DEFAULT_SIZE / source_size - 1.0, 1.0)


def shape_features(source_size: int | None = None) -> FeatureTable:
    """The (shape, size) feature table for frames drawn at ``source_size`` px and read at :data:`DEFAULT_SIZE`: the
    native table, the 128-px one, or between the two (centres and spreads interpolated)."""
    t = _upscaling(source_size)
    if t == 0.0:
        return SHAPE_FEATURES
    if t == 1.0:
        return SHAPE_FEATURES_128

    def mix(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float, float]:
        return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2]))

    return {key: (mix(SHAPE_FEATURES[key][0], SHAPE_FEATURES_128[key][0]),
                  mix(SHAPE_FEATURES[key][1], SHAPE_FEATURES_128[key][1])) for key in SHAPE_FEATURES}


def soft_source(source_size: int | None = None) -> bool:
    """Whether frames drawn at ``source_size`` px are softer than the renderer draws them once read at
    :data:`DEFAULT_SIZE` (drawn smaller): their colours are read by
    :func:`~craft_dsl.reader.detect.soft_color_table`."""
    return _upscaling(source_size) > 0.0


def source_blur(source_size: int | None = None) -> float:
    """The blur (Gaussian sigma, pixels at :data:`DEFAULT_SIZE`) that rescaling from ``source_size`` px adds."""
    return BLUR_128 * _upscaling(source_size)
#: Measured centroid minus the body's centre, in the body's frame (pixels, x right and y up at angle 0): the colour
#: mask misses what the eyes cover (calibrated on generated MPEG-1 videos; large bodies have none to speak of).
EYE_BIAS: dict[tuple[str, str], tuple[float, float]] = {
    ("circle", "large"): (0.0, 0.0),
    ("circle", "small"): (0.0, 1.88),
    ("cube", "large"): (0.0, 0.0),
    ("cube", "small"): (0.0, 2.26),
    ("triangle", "large"): (0.0, 0.0),
    ("triangle", "small"): (0.0, 0.32),
}
#: A render-and-compare fit worse than this (grey levels, RMS) is not a pose (another body in the way).
MAX_REFINE_RMS = 30.0
#: Residual difference (grey levels) that makes one (shape, size) e^(1/2) times less likely than the best.
RESIDUAL_SCALE = 1.5
#: The shape features' probability is not trusted below this when the drawing's residual is weighed in.
FEATURE_FLOOR = 1e-3


@dataclass
class TrackedObject:
    """One body: its colour, the blob it has in each frame (None: not seen alone), and what it is."""

    color: int
    blobs: list[Blob | None]
    shape_size: dict[tuple[str, str], float] = field(default_factory=dict)  # probability of each (shape, size)
    measurements: dict[int, Measurement] = field(default_factory=dict)  # full-resolution, by frame
    poses: dict[int, tuple[float, float, float]] = field(default_factory=dict)  # render-and-compare (x, y, angle)
    pose_shape: tuple[str, str] | None = None  # the (shape, size) the poses were fitted as
    #: Every render-and-compare fit made, by (shape, size) and frame (None: it failed): a frame's fit depends on that
    #: frame alone, so a shape tried again, or a frame whose fit failed, is not fitted twice.
    fitted: dict[tuple[str, str], dict[int, tuple[float, float, float] | None]] = field(
        default_factory=dict, repr=False, compare=False)
    source_size: int | None = None  # the video's frame size before it was rescaled to DEFAULT_SIZE (None: not rescaled)
    #: The other tracks of its colour (:func:`pair_twins`): a piece that reaches one of their blobs covers both.
    twins: list[TrackedObject] = field(default_factory=list, repr=False, compare=False)

    @property
    def color_name(self) -> str:
        return COLORS[self.color]

    def best(self) -> tuple[str, str]:
        return max(self.shape_size, key=lambda k: self.shape_size[k]) if self.shape_size else ("cube", "small")

    def seen(self) -> list[int]:
        return [k for k, b in enumerate(self.blobs) if b is not None]

    def seen_whole(self) -> list[int]:
        """The frames where the body is seen clear of the frame's border (not cut off)."""
        return [k for k, b in enumerate(self.blobs) if b is not None and not b.touches_edge]


def _near(a: Blob, b: Blob) -> bool:
    """Whether two blobs of one colour and frame are near enough to be pieces of one body (see
    :data:`PIECE_DISTANCE`)."""
    return math.hypot(a.x - b.x, a.y - b.y) < PIECE_DISTANCE * math.sqrt(a.area + b.area)


def _bodies_in_frame(pieces: Sequence[Blob]) -> int:
    """How many bodies one frame's substantial blobs of one colour show: blobs nearer each other than
    :data:`PIECE_DISTANCE` times the square root of their summed area are pieces of one body (the eyes cut a body's
    colour in two where their rims leave it only a pixel wide, as the original CRAFT renderer's do a large
    triangle's)."""
    if len(pieces) < 2:
        return len(pieces)
    group = list(range(len(pieces)))

    def root(i: int) -> int:
        while group[i] != i:
            i = group[i]
        return i

    for i, a in enumerate(pieces):
        for j in range(i + 1, len(pieces)):
            if _near(a, pieces[j]):
                group[root(j)] = root(i)
    return len({root(i) for i in range(len(pieces))})


def count_per_color(blobs: Sequence[Blob], frames: int) -> dict[int, int]:
    """Number of bodies of each colour (see the module docstring)."""
    pieces: dict[tuple[int, int], list[Blob]] = defaultdict(list)
    for b in blobs:
        if b.area >= SUBSTANTIAL_AREA:
            pieces[(b.color, b.frame)].append(b)
    per_frame: dict[int, np.ndarray] = defaultdict(lambda: np.zeros(frames, dtype=int))
    for (color, frame), found in pieces.items():
        per_frame[color][frame] = _bodies_in_frame(found)
    out = {}
    for color, counts in per_frame.items():
        n = 0
        while np.count_nonzero(counts >= n + 1) >= MIN_FRAMES:
            n += 1
        if n:
            out[color] = n
    return out


#: A blob this much smaller than a blob of its colour near it (see :data:`PIECE_DISTANCE`) is a piece of that body.
PIECE_AREA_SHARE = 0.35


def _pieces(candidates: Sequence[Blob]) -> set[int]:
    """Indexes of the blobs that are pieces of a larger blob of one frame and colour: smaller than
    :data:`PIECE_AREA_SHARE` of it and nearer than :data:`PIECE_DISTANCE` times the square root of their summed
    area (a lossy video cuts a large triangle along its eyes)."""
    out = set()
    for j, b in enumerate(candidates):
        for k, c in enumerate(candidates):
            if k != j and b.area < PIECE_AREA_SHARE * c.area and _near(b, c):
                out.add(j)
                break
    return out


def _assign(previous: list[tuple[float, float] | None], areas: list[float | None], candidates: list[Blob]
            ) -> tuple[list[Blob | None], dict[int, Blob]]:
    """Give each body (by its last position and area) one of the frame's blobs, or none; and the bodies that a
    blob covers together (:func:`_covered`), given to none of them, with that blob."""
    n = len(previous)
    out: list[Blob | None] = [None] * n
    inside: dict[int, Blob] = {}
    if not candidates:
        return out, inside
    if n == 1:
        out[0] = max(candidates, key=lambda b: b.area)
        return out, inside
    unplaced = any(p is None for p in previous)  # a body with no position yet to be near
    if unplaced and len(candidates) > n:
        # more blobs than bodies: the extra blobs are pieces (a lossy video cuts a body at the frame's edge or along
        # its eyes), so the smallest are not bodies
        keep = sorted(range(len(candidates)), key=lambda j: -candidates[j].area)[:n]
        candidates = [candidates[j] for j in sorted(keep)]
    pieces = _pieces(candidates) if unplaced else set()
    pairs = []
    for i in range(n):
        for j, b in enumerate(candidates):
            p = previous[i]
            if p is None and j in pieces:
                continue  # a body first seen is not a piece of another
            d = math.hypot(b.x - p[0], b.y - p[1]) if p is not None else 50.0
            a = areas[i]
            ratio = abs(math.log(b.area / a)) if a else 0.0
            pairs.append((d + 20.0 * ratio, i, j))
    pairs.sort()
    used_i: set[int] = set()
    used_j: set[int] = set()
    for _cost, i, j in pairs:
        if i in used_i or j in used_j:
            continue
        b = candidates[j]
        covered = _covered(b, previous, areas) if len(candidates) < n else []
        if covered:  # one blob as large as the colour's bodies near it together: they touch
            inside.update((t, b) for t in covered)
            continue
        out[i] = b
        used_i.add(i)
        used_j.add(j)
    return out, {t: b for t, b in inside.items() if out[t] is None}


def _covered(blob: Blob, previous: Sequence[tuple[float, float] | None], areas: Sequence[float | None]
             ) -> list[int]:
    """The bodies (indexes) that ``blob`` covers together, where it covers several of a colour's bodies that touch
    (given their last positions and areas), else none: it is about as large as the bodies last seen within its reach
    (its radius and :data:`JUMP_MARGIN_PX`) together, and larger than the largest of them by a good part of the
    smallest. Only bodies within reach count: a speck of the colour elsewhere (a lossy video's, or the original
    renderer's near another body's eyes), tracked as a body, does not make a body's own blob a pair."""
    if any(not a for a in areas):
        return []
    reach = math.sqrt(blob.area / math.pi) + JUMP_MARGIN_PX
    near = [i for i, p in enumerate(previous) if p is not None and math.hypot(blob.x - p[0], blob.y - p[1]) <= reach]
    if len(near) < 2:
        return []
    known = [a for i in near if (a := areas[i])]
    return near if blob.area > max(0.8 * sum(known), max(known) + 0.5 * min(known)) else []


#: Velocities (pixels per step) from sightings further apart than this many steps are not used for the prediction.
MAX_VELOCITY_GAP = 24


def _carried(last: tuple[int, float, float] | None, before: tuple[int, float, float] | None, step: int
             ) -> tuple[float, float] | None:
    """Where a body last seen at (step, x, y) ``last`` (and before that at ``before``) is expected at ``step``."""
    if last is None:
        return None
    if before is None or last[0] - before[0] > MAX_VELOCITY_GAP:
        return (last[1], last[2])
    span = last[0] - before[0]
    ahead = step - last[0]
    return (last[1] + (last[1] - before[1]) * ahead / span, last[2] + (last[2] - before[2]) * ahead / span)


def track(blobs: Sequence[Blob], frames: int, counts: dict[int, int] | None = None,
          steps: np.ndarray | Sequence[int] | None = None) -> list[TrackedObject]:
    """The bodies of every colour with their blob per frame; ``steps``: the step each frame shows (default: one
    frame per step, 60 fps)."""
    counts = counts if counts is not None else count_per_color(blobs, frames)
    rows = None if steps is None else [int(v) for v in steps]
    predict = rows is not None and len(rows) > 0 and rows[-1] > len(rows)  # frames skip steps
    by_frame: dict[tuple[int, int], list[Blob]] = defaultdict(list)
    for b in blobs:
        if b.area >= SUBSTANTIAL_AREA:
            by_frame[(b.color, b.frame)].append(b)
    objects: list[TrackedObject] = []
    for color in sorted(counts):
        n = counts[color]
        tracks: list[list[Blob | None]] = [[None] * frames for _ in range(n)]
        previous: list[tuple[float, float] | None] = [None] * n
        areas: list[float | None] = [None] * n
        sightings: list[list[tuple[int, float, float]]] = [[] for _ in range(n)]  # (step, x, y), the last two
        # seed the order of the bodies by area where all are first seen apart
        for k in range(frames):
            if predict and n > 1:
                assert rows is not None
                previous = [_carried(seen[-1] if seen else None, seen[-2] if len(seen) > 1 else None, rows[k])
                            for seen in sightings]
            chosen, inside = _assign(previous, areas, by_frame.get((color, k), []))
            for i, covering in inside.items():  # a body in a blob with others moves with that blob
                previous[i] = (covering.x, covering.y)
            for i, chosen_blob in enumerate(chosen):
                if chosen_blob is not None:
                    tracks[i][k] = chosen_blob
                    previous[i] = (chosen_blob.x, chosen_blob.y)
                    if predict:
                        assert rows is not None
                        sightings[i] = [*sightings[i][-1:], (rows[k], chosen_blob.x, chosen_blob.y)]
                    if not chosen_blob.touches_edge:
                        old = areas[i]
                        areas[i] = chosen_blob.area if old is None else 0.9 * old + 0.1 * chosen_blob.area
        objects += [TrackedObject(color, t) for t in tracks]
    return objects


#: A body moves at most this many pixels (256-px frame) per physics step (the fastest of 100 simulated scenes: 3.4)...
MAX_STEP_PX = 6.0
#: ... and its blob's centre may shift by this many pixels more (a body partly hidden, or seen with a piece of another).
JUMP_MARGIN_PX = 20.0
#: Sightings between two jumps no body makes, fewer than this many, are not the body's: a piece of another body of its
#: colour, or a speck of the colour a lossy video shows while the body itself is hidden.
STRAY_SIGHTINGS = MIN_FRAMES


def drop_strays(blobs: list[Blob | None], rows: Sequence[int] | np.ndarray | None = None) -> list[Blob | None]:
    """The track ``blobs`` without its stray sightings: split where it jumps further than a body moves in the steps
    between (:data:`MAX_STEP_PX`, :data:`JUMP_MARGIN_PX`), the runs of fewer than :data:`STRAY_SIGHTINGS` sightings
    are dropped, as long as a longer one is kept; repeated until no short run is left (dropping a speck between two
    runs of one body joins them). ``rows``: the step each frame shows (default ``k + 1``)."""
    out = list(blobs)
    while True:
        seen = [k for k, b in enumerate(out) if b is not None]
        runs: list[list[int]] = [seen[:1]] if seen else []
        for a, k in zip(seen, seen[1:]):
            ba, bk = out[a], out[k]
            assert ba is not None and bk is not None
            steps = (rows[k] - rows[a]) if rows is not None else k - a
            if math.hypot(bk.x - ba.x, bk.y - ba.y) > JUMP_MARGIN_PX + MAX_STEP_PX * steps:
                runs.append([k])
            else:
                runs[-1].append(k)
        short = [run for run in runs if len(run) < STRAY_SIGHTINGS]
        if not short or len(short) == len(runs):
            return out
        for run in short:
            for k in run:
                out[k] = None


def _position(obj: TrackedObject, k: int) -> tuple[float, float]:
    b = obj.blobs[k]
    assert b is not None
    return (b.x, b.y)


def same_body(a: TrackedObject, b: TrackedObject, steps: Sequence[int] | None = None) -> bool:
    """Whether two tracks of different colours are one body read in two colours (a small dark body loses its
    chroma to the compression and reads as gray in some frames): they are seen together in few frames, always at
    the same place when they are, and where one is seen the other was seen close by a few frames before or after
    (12 px within 3 steps; further apart in steps, ``steps`` being the step each frame shows, 4 px more per step)."""
    sa, sb = set(a.seen()), set(b.seen())
    if not sa or not sb:
        return False
    both = sa & sb
    if len(both) > 0.3 * min(len(sa), len(sb)):
        close = sum(1 for k in both if math.dist(_position(a, k), _position(b, k)) < 8.0)
        if close < 0.8 * len(both):
            return False
    near = 0
    checked = 0
    for k in sorted(sa - both)[::3]:
        for d in (1, -1, 2, -2, 3, -3):
            if k + d in sb:
                checked += 1
                apart = abs(steps[k + d] - steps[k]) if steps is not None else abs(d)
                near += int(math.dist(_position(a, k), _position(b, k + d)) < 12.0 + 4.0 * max(apart - 3, 0))
                break
    return checked >= 3 and near >= 0.8 * checked


def _evidence(obj: TrackedObject) -> float:
    """Pixels a track was seen with, over all its frames."""
    return sum(b.area for b in obj.blobs if b is not None)


def merge_colour_splits(objects: list[TrackedObject], steps: Sequence[int] | np.ndarray | None = None
                        ) -> list[TrackedObject]:
    """Join the tracks of a body read in two colours (:func:`same_body`); the chromatic colour wins over gray, else
    the colour seen over more pixels in all (a large red cube in a grey basket reads brown there, in many frames but
    over few pixels)."""
    out = list(objects)
    merged = True
    while merged:
        merged = False
        for i, a in enumerate(out):
            for b in out[i + 1:]:
                if a.color == b.color or not same_body(a, b, None if steps is None else [int(v) for v in steps]):
                    continue
                keep, drop = (a, b) if (b.color == GRAY or (a.color != GRAY and _evidence(a) >= _evidence(b))) \
                    else (b, a)
                blobs = [kb if kb is not None else db for kb, db in zip(keep.blobs, drop.blobs)]
                out = [o for o in out if o is not a and o is not b] + [TrackedObject(keep.color, blobs)]
                merged = True
                break
            if merged:
                break
    return out


#: Relinking across a merge: frames of each side measured, the fewest complete ones that count, and how much more
#: likely (log) the swapped linking must be.
RELINK_SAMPLES = 12
RELINK_MIN_FRAMES = 4
RELINK_MARGIN = 10.0
#: Frames in a row where two tracks are both seen that part one merge from the next.
MIN_APART = 5


def _merges(a: TrackedObject, b: TrackedObject) -> list[tuple[tuple[int, int], int, tuple[int, int]]]:
    """Where two tracks merged: (frames before, the first frame both are found again, frames after) for
    each stretch between two runs of at least :data:`MIN_APART` frames where both are seen, in which both are lost
    in some frame (short partings inside a merge belong to it)."""
    n = len(a.blobs)
    runs: list[tuple[int, int]] = []
    k = 0
    while k < n:
        if a.blobs[k] is None or b.blobs[k] is None:
            k += 1
            continue
        start = k
        while k < n and a.blobs[k] is not None and b.blobs[k] is not None:
            k += 1
        if k - start >= MIN_APART:
            runs.append((start, k))
    gaps = [(e0, s1) for (_s0, e0), (s1, _e1) in zip(runs, runs[1:])
            if any(a.blobs[g] is None and b.blobs[g] is None for g in range(e0, s1))]
    starts = [0] + [found for _lost, found in gaps]
    ends = [lost for lost, _found in gaps] + [n]
    return [((starts[i], lost), found, (found, ends[i + 1])) for i, (lost, found) in enumerate(gaps)]


def _side(obj: TrackedObject, start: int, stop: int) -> list[int]:
    """Frames in [start, stop) where ``obj`` is seen whole (not cut by the border)."""
    return [k for k in range(start, stop) if (b := obj.blobs[k]) is not None and not b.touches_edge]


def _side_log_likelihoods(obj: TrackedObject, frames: np.ndarray, background: np.ndarray, which: list[int]
                          ) -> np.ndarray | None:
    """Log-likelihood of each (shape, size) (in :data:`SHAPE_FEATURES` order) from up to :data:`RELINK_SAMPLES` of
    ``which``; None with fewer than :data:`RELINK_MIN_FRAMES` complete measurements."""
    pick = spread_frames(which, RELINK_SAMPLES)
    measure_frames(obj, frames, background, pick)
    features = _features(obj, pick)
    if len(features) < RELINK_MIN_FRAMES:
        return None
    return np.array(list(_log_likelihoods(features, shape_features(obj.source_size)).values()))


def relink_merges(objects: list[TrackedObject], frames: np.ndarray, background: np.ndarray) -> int:
    """Where two bodies of one colour touch (their blob is one, left to neither) and part again, the tracks are
    linked by position, and two bodies that bounce off each other come out swapped. For each such merge (both
    tracks lost in the same frame and found again), keep or swap the tracks' parts after it, whichever lets each
    track be one (shape, size) (the log-likelihoods of the parts' shape features, by :data:`RELINK_MARGIN`). Returns
    the number of swaps; measurements made are dropped (the blobs they belong to may have changed tracks)."""
    swaps = 0
    for tracks in _by_colour(objects):
        for i, a in enumerate(tracks):
            for b in tracks[i + 1:]:
                for before, found, after in _merges(a, b):
                    sides = [_side_log_likelihoods(o, frames, background, _side(o, lo, hi))
                             for o, (lo, hi) in ((a, before), (a, after), (b, before), (b, after))]
                    a1, a2, b1, b2 = sides
                    if a1 is None or a2 is None or b1 is None or b2 is None:
                        continue
                    keep = float(np.max(a1 + a2) + np.max(b1 + b2))
                    swap = float(np.max(a1 + b2) + np.max(b1 + a2))
                    if swap > keep + RELINK_MARGIN:
                        a.blobs[found:], b.blobs[found:] = b.blobs[found:], a.blobs[found:]
                        swaps += 1
    for obj in objects:
        obj.measurements.clear()
    return swaps


#: A track whose median blob is at least this large (pixels) is a large body: its centre holds the eyes, so its core
#: colour says nothing about its purity.
LARGE_BLOB_AREA = 100.0
#: A small track is pure when the luma and chroma of its core (the median colour of 3x3 pixels at the blob's centroid)
#: are near those of its palette colour (:func:`colour_distance`): pieces of compression colour riding along another
#: body (a dark body's rim read as gray, a ring around it) have the other body's colour, or a blend, at their centre.
#: Lossy codecs keep a small body's luma (H.264 at crf 28: within 3.4 of its colour's for 95% of 612 small bodies) and
#: shrink its chroma toward gray, keeping its hue (to 42-80% of the colour's: a small brown circle's core is 39 RGB
#: units from brown, its luma 2.6 off); a gray body has no chroma (95%: 2.2), a piece of a green body read gray has
#: the green's (10-20). This is the luma difference that counts as one radius.
LUMA_RADIUS = 20.0
#: The chroma difference that counts as one radius for a chromatic colour, measured from the palette chroma shrunk by
#: the factor (in [:data:`CHROMA_KEPT_MIN`, 1]) that brings it nearest.
CHROMA_RADIUS = 20.0
#: The chroma that counts as one radius for gray, which has none to shrink: a small gray body next to a green one
#: picks up a little of its chroma (up to 4.5 on MPEG-4 copies), a piece of the green body read gray much more.
GRAY_CHROMA_RADIUS = 6.0
#: The least share of its colour's chroma that a compressed small body keeps (measured: 0.42).
CHROMA_KEPT_MIN = 0.3
#: The evidence of a track that is not pure is weighed down by this factor, and further the further its core colour
#: is from its palette colour (see :func:`purity`): a track just out of reach keeps a tenth of its evidence, the ring
#: that a softened eye's pupil leaves in gray (luma 64 above gray's, a green's chroma) none to speak of.
IMPURE_WEIGHT = 0.1
#: Frames sampled for a track's core colour.
CORE_SAMPLES = 40


def core_colour(obj: TrackedObject, frames: np.ndarray) -> np.ndarray | None:
    """Median RGB (float [3]) of the 3x3 pixels at the blob's centroid over up to :data:`CORE_SAMPLES` frames where
    the blob is not cut by the frame's border; None when there is none."""
    pick = spread_frames(obj.seen_whole(), CORE_SAMPLES)
    if not pick:
        return None
    size = frames.shape[1]
    values = []
    for k in pick:
        b = obj.blobs[k]
        assert b is not None
        x = min(max(int(b.x), 1), size - 2)
        y = min(max(int(b.y), 1), size - 2)
        values.append(frames[k, y - 1:y + 2, x - 1:x + 2].reshape(-1, 3).mean(axis=0))
    return np.median(np.array(values, dtype=np.float64), axis=0)


def luma_chroma(rgb: np.ndarray) -> tuple[float, np.ndarray]:
    """The luma Y and chroma (Cb, Cr) of one RGB colour (ITU-R BT.601, full range; float)."""
    r, g, b = (float(v) for v in rgb)
    return 0.299 * r + 0.587 * g + 0.114 * b, cb_cr(np.array([r, g, b]))


def colour_distance(core: np.ndarray, color: int) -> float:
    """How far a small body's core colour is from palette colour ``color``, in radii (below 1: pure): its luma
    difference over :data:`LUMA_RADIUS` and the distance of its chroma from the palette chroma shrunk by the best
    factor in [:data:`CHROMA_KEPT_MIN`, 1] over :data:`CHROMA_RADIUS` (for gray: its chroma over
    :data:`GRAY_CHROMA_RADIUS`), combined as a Euclidean norm."""
    luma, chroma = luma_chroma(core)
    palette_luma, palette_chroma = luma_chroma(PALETTE[color])
    norm = float(palette_chroma @ palette_chroma)
    if color == GRAY or norm == 0.0:
        off, radius = float(np.linalg.norm(chroma)), GRAY_CHROMA_RADIUS
    else:
        kept = min(max(float(chroma @ palette_chroma) / norm, CHROMA_KEPT_MIN), 1.0)
        off, radius = float(np.linalg.norm(chroma - kept * palette_chroma)), CHROMA_RADIUS
    return math.hypot((luma - palette_luma) / LUMA_RADIUS, off / radius)


def purity(obj: TrackedObject, frames: np.ndarray) -> float:
    """1 where ``obj`` looks like a body of its colour, else :data:`IMPURE_WEIGHT` times exp(-(d - 1)^2) for a core
    colour d radii from its palette colour (:func:`colour_distance`; for a video drawn small and rescaled, whose
    bodies' cores are their colours mixed with white and black, the distance from the nearest such mix over
    :data:`SOFT_RESIDUAL`)."""
    areas = [b.area for b in obj.blobs if b is not None]
    if not areas or float(np.median(areas)) >= LARGE_BLOB_AREA:
        return 1.0
    core = core_colour(obj, frames)
    if core is None:
        return IMPURE_WEIGHT
    if soft_source(obj.source_size):  # a soft body's core is its colour mixed with white and black (its eyes)
        distance = float(mix_residual(core[None], obj.color)[1][0]) / SOFT_RESIDUAL
    else:
        distance = colour_distance(core, obj.color)
    if distance < 1.0:
        return 1.0
    return IMPURE_WEIGHT * math.exp(-((distance - 1.0) ** 2))


#: A blob rides on another colour's blob at least this many times its area (a faded body read in two colours in
#: one frame shows two blobs of similar areas at one place, which is neither's host).
RIDING_HOST_RATIO = 2.0


def riding_frames(obj: TrackedObject, objects: Sequence[TrackedObject]) -> list[int]:
    """The frames in which a track's centre lies inside a body of another colour :data:`RIDING_HOST_RATIO` times its
    area or more (within the radius of a disk of that body's blob area): a body cannot be there (bodies do not
    overlap), but the colours of another body's eyes and edges, blurred together by compression, can ride along
    with it."""
    hosts = [o.blobs for o in objects if o.color != obj.color]
    out = []
    for k, b in enumerate(obj.blobs):
        if b is None:
            continue
        for blobs in hosts:
            h = blobs[k]
            if h is not None and h.area >= RIDING_HOST_RATIO * b.area and (h.x - b.x) ** 2 + (h.y - b.y) ** 2 < (
                    h.area / math.pi):
                out.append(k)
                break
    return out


def riding_share(obj: TrackedObject, objects: Sequence[TrackedObject]) -> float:
    """The share of a track's frames that ride on another body (:func:`riding_frames`). On a H.264 copy (crf 28) a
    small blue circle faded to 20 px² lost its place to a gray track of 40 px² that hopped along the other bodies'
    eyes for 231 frames."""
    seen = len(obj.seen())
    return len(riding_frames(obj, objects)) / seen if seen else 0.0


def drop_riding(objects: Sequence[TrackedObject], rows: Sequence[int] | np.ndarray | None = None) -> None:
    """Take from each track the sightings that ride on another of ``objects`` (:func:`riding_frames`), then its
    stray runs (:func:`drop_strays`; ``rows``: the step each frame shows): before a small body enters the picture,
    its colour's track may have picked up specks of that colour on a larger body's edges (H.264 at crf 28: a green
    track on a brown body's rim for 46 frames, placing the green body's start there)."""
    riding = [riding_frames(obj, objects) for obj in objects]  # all found before any track changes
    for obj, frames in zip(objects, riding):
        if frames:
            for k in frames:
                obj.blobs[k] = None
            obj.blobs = drop_strays(obj.blobs, rows)


def select_objects(objects: list[TrackedObject], count: int | None, frames: np.ndarray) -> list[TrackedObject]:
    """The ``count`` most substantial bodies (all when None): by the evidence of each track (frames seen times median
    blob area), weighed down where the track is not pure (:func:`purity`) and by the share of frames it rides on
    another body (:func:`riding_share`)."""
    if count is None or len(objects) <= count:
        return objects

    def evidence(o: TrackedObject) -> float:
        areas = [b.area for b in o.blobs if b is not None]
        if not areas:
            return 0.0
        return len(areas) * float(np.median(areas)) * purity(o, frames) * (1.0 - riding_share(o, objects))

    ranked = sorted(objects, key=evidence, reverse=True)
    keep = set(map(id, ranked[:count]))
    return [o for o in objects if id(o) in keep]


def pair_twins(objects: Sequence[TrackedObject]) -> None:
    """Give each track the other tracks of its colour (:attr:`TrackedObject.twins`). Two bodies of one colour at rest
    against each other (in the basket, say) stay two blobs on the half-resolution grid but one closed piece at full
    resolution: their union, measured as if it were either body, reads as neither (two yellow circles, large and
    small, both read as small triangles)."""
    for tracks in _by_colour(objects):
        for obj in tracks:
            obj.twins = [t for t in tracks if t is not obj]


def _by_colour(objects: Sequence[TrackedObject]) -> list[list[TrackedObject]]:
    """The tracks grouped by colour, each group in the order of ``objects``."""
    groups: dict[int, list[TrackedObject]] = defaultdict(list)
    for obj in objects:
        groups[obj.color].append(obj)
    return list(groups.values())


def measure_frames(obj: TrackedObject, frames: np.ndarray, background: np.ndarray, which: Sequence[int]) -> None:
    """Full-resolution measurements of ``obj`` in the frames ``which`` (where it has a blob); cached on it. A
    measurement whose piece reaches the blob centre of a twin (:func:`pair_twins`) in that frame covers both bodies:
    it is kept, marked not complete."""
    size = frames.shape[1]
    half = WINDOW // 2
    todo: list[int] = []
    origins: list[tuple[int, int]] = []
    seeds: list[tuple[int, int]] = []
    for k in dict.fromkeys(which):
        b = obj.blobs[k]
        if k in obj.measurements or b is None:
            continue
        x0 = min(max(int(b.x) - half, 0), size - WINDOW)
        y0 = min(max(int(b.y) - half, 0), size - WINDOW)
        todo.append(k)
        origins.append((y0, x0))
        seeds.append((int(b.y) - y0, int(b.x) - x0))
    if not todo:
        return
    windows = np.stack([frames[k, y0:y0 + WINDOW, x0:x0 + WINDOW] for k, (y0, x0) in zip(todo, origins)])
    backgrounds = np.stack([background[y0:y0 + WINDOW, x0:x0 + WINDOW] for y0, x0 in origins])
    measured = measure_many(windows, backgrounds, obj.color, origins, seeds=seeds, soft=soft_source(obj.source_size))
    for k, m in zip(todo, measured):
        if m is None:
            continue
        if m.complete and any((t := twin.blobs[k]) is not None and math.hypot(t.x - m.x, t.y - m.y) <= m.radius
                              for twin in obj.twins):
            m = replace(m, complete=False)
        obj.measurements[k] = m


def _measured_poses(obj: TrackedObject, which: Sequence[int], shape: str, size: str
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre x, y and angle of ``obj`` in the measured frames ``which`` as (shape, size): the colour centroid less
    the eye bias (body frame, y up; pixel rows go down), the angle from the eyes (pi where they are not seen)."""
    bx, by = EYE_BIAS.get((shape, size), (0.0, 0.0))
    xs, ys, angles = [], [], []
    for k in which:
        m = obj.measurements[k]
        a = m.eye_angle()
        a = math.pi if a is None else a
        c, s = math.cos(a), math.sin(a)
        xs.append(m.x - (c * bx - s * by))
        ys.append(m.y + (s * bx + c * by))
        angles.append(a)
    return np.array(xs), np.array(ys), np.array(angles)


def refine_frames(obj: TrackedObject, frames: np.ndarray, background: np.ndarray, which: Sequence[int],
                  shape: str, size: str) -> None:
    """Exact poses (render and compare, :mod:`craft_dsl.reader.refine`) of ``obj`` in the frames ``which`` where it
    was measured complete, as the body (shape, size); held on it as its poses (until the shape changes), and each
    fit made only once (:attr:`TrackedObject.fitted`)."""
    if obj.pose_shape != (shape, size):
        obj.poses.clear()
        obj.pose_shape = (shape, size)
    todo = [k for k in which if k not in obj.poses and k in obj.measurements and obj.measurements[k].complete]
    if not todo:
        return
    made = obj.fitted.setdefault((shape, size), {})
    fresh = list(dict.fromkeys(k for k in todo if k not in made))
    if fresh:
        # a soft video's small circles and cubes: their blurred eyes, all that fixes their angle, mislead one start
        starts = SOFT_ANGLE_STARTS if soft_source(obj.source_size) and size == "small" and shape != "triangle" else 1
        x, y, angle, rms = refine(frames, background, shape, size, obj.color, fresh,
                                  *_measured_poses(obj, fresh, shape, size), blur=source_blur(obj.source_size),
                                  starts=starts)
        for i, k in enumerate(fresh):
            ok = np.isfinite(rms[i]) and rms[i] < MAX_REFINE_RMS
            made[k] = (float(x[i]), float(y[i]), float(angle[i])) if ok else None
    for k in todo:
        if (pose := made[k]) is not None:
            obj.poses[k] = pose


#: The shape check's frames: this many spread over the run where the body is seen whole (more where the frames are
#: further apart than a step), and the quantile of their residuals taken. A rolling body's eyes give a poor first
#: angle, and the fit from it a residual as large for the right shape as for the wrong ones; the best tenth of frames
#: spread over the run holds fits of the body at rest and rolling alike. Measured on the training videos of two
#: datasets (the 205 of original-sampled seed 20261205, 190 of Box2D seed 20261206; ``tests`` hold the check),
#: bodies read right: 558 -> 567 of 594 and 488 -> 491 of 518 against the median of 8 frames mostly from the start
#: window (where a body at rest on a ledge touches it).
SHAPE_SAMPLES = 16
SPARSE_SHAPE_SAMPLES = 24
SHAPE_QUANTILE = 0.1


def spread_frames(frames: Sequence[int], samples: int) -> list[int]:
    """Up to ``samples`` of ``frames``, evenly spread over them (the first and the last among them)."""
    return [frames[int(i)] for i in np.unique(np.linspace(0, len(frames) - 1, min(samples, len(frames))).round())] \
        if frames else []


def shape_residuals(obj: TrackedObject, frames: np.ndarray, background: np.ndarray, shape: str, size: str,
                    which: Sequence[int]) -> np.ndarray:
    """Render-and-compare residuals (grey levels) of ``obj`` drawn as (shape, size) in those of the frames ``which``
    where it was measured complete (the same frames for every shape): the wrong shape leaves its corners or its
    missing corners in the residual. A drawing whose window leaves the picture is compared on its part inside it
    (a small circle at rest on the ground fits a square's wider window only so: compared on the frames where all
    windows fit, its first frames alone once decided it a cube); infinite only where the body's centre is outside."""
    done = [k for k in which if k in obj.measurements and obj.measurements[k].complete]
    if not done:
        return np.zeros(0)
    return refine(frames, background, shape, size, obj.color, done, *_measured_poses(obj, done, shape, size),
                  blur=source_blur(obj.source_size), clipped=True)[3]


def _quantile(residuals: np.ndarray, quantile: float) -> float:
    finite = residuals[np.isfinite(residuals)]
    if not finite.size:
        return math.inf
    return float(np.median(finite)) if quantile == 0.5 else float(np.quantile(finite, quantile))


def compared_residuals(per_frame: Mapping[tuple[str, str], np.ndarray], quantile: float = 0.5
                       ) -> dict[tuple[str, str], float]:
    """Each candidate's residual (the ``quantile`` of its per-frame residuals), taken over the frames where every
    candidate that could be fitted anywhere was fitted (a frame where a body's centre is out of the picture is not),
    and a median over other frames compares other moments (a body cut by compression in some of them). Where no frame
    holds them all, each over its own."""
    fitted = {key for key, v in per_frame.items() if np.any(np.isfinite(v))}
    common = np.logical_and.reduce([np.isfinite(per_frame[key]) for key in fitted]) if fitted else None
    if common is None or not np.any(common):
        return {key: _quantile(v, quantile) for key, v in per_frame.items()}
    return {key: _quantile(v[common], quantile) if key in fitted else math.inf for key, v in per_frame.items()}


def verify_shape(obj: TrackedObject, frames: np.ndarray, background: np.ndarray, sparse: bool = False) -> None:
    """Where the features leave a second (shape, size) possible, let the drawing decide: each candidate's
    probability is weighted by exp(-residual^2 / (2 * RESIDUAL_SCALE^2)) relative to the best, the residual being
    the :data:`SHAPE_QUANTILE` of its frames (:data:`SHAPE_SAMPLES` spread over the run; ``sparse``: the frames are
    further apart than a step, :data:`SPARSE_SHAPE_SAMPLES`)."""
    ranked = sorted(obj.shape_size.items(), key=lambda kv: -kv[1])
    # the three shapes of the likeliest size (the features tell sizes apart far better than small shapes), and the
    # likeliest shape at the other size: a lossy video cuts a large triangle's tip, and its features then read small,
    # but drawn small it leaves most of itself in the residual. A large body's features decide alone unless a second
    # reading is possible.
    (shape_0, size), _p = ranked[0]
    if size == "large" and ranked[1][1] < 1e-4:
        return
    candidates = [(shape, size) for shape in SHAPES] + [(shape_0, "large" if size == "small" else "small")]
    pick = spread_frames(obj.seen_whole(), SPARSE_SHAPE_SAMPLES if sparse else SHAPE_SAMPLES)
    measure_frames(obj, frames, background, pick)
    residual = compared_residuals({key: shape_residuals(obj, frames, background, *key, pick) for key in candidates},
                                  SHAPE_QUANTILE)
    best = min(residual.values())
    if not math.isfinite(best):
        return
    weights = {key: max(obj.shape_size[key], FEATURE_FLOOR) * math.exp(
        -((residual[key] - best) / RESIDUAL_SCALE) ** 2 / 2) if key in residual else 0.0 for key in obj.shape_size}
    total = sum(weights.values())
    obj.shape_size = {key: w / total for key, w in weights.items()}


def _features(obj: TrackedObject, pick: Sequence[int], complete: bool = True) -> np.ndarray:
    """[n, 3] shape features (see the module docstring) of the measured frames of ``pick`` (complete ones only)."""
    chosen = set(pick)
    return np.array([(m.area, m.radius / math.sqrt(m.area), (m.mxx + m.myy) / m.area)
                     for k, m in obj.measurements.items() if k in chosen and (m.complete or not complete)])


def _log_likelihoods(features: np.ndarray, table: FeatureTable = SHAPE_FEATURES) -> dict[tuple[str, str], float]:
    """Per (shape, size), the log-likelihood of the features of every frame (Student-t, 3 degrees of freedom, per
    feature and frame) under ``table`` (see :func:`shape_features`)."""
    out = {}
    for key, (centre, spread) in table.items():
        floor = np.array([0.06 * centre[0], 0.03, 0.006])
        z = (features - np.array(centre)) / np.maximum(np.array(spread) * SPREAD_FACTOR, floor)
        out[key] = float(np.sum(-2.0 * np.log1p(z * z / 3.0)))
    return out


def perimeter(shape: str, area: float) -> float:
    """Perimeter (pixels) of a circle, square or equilateral triangle of ``area`` (pixels²)."""
    if shape == "circle":
        return 2.0 * math.sqrt(math.pi * area)
    if shape == "cube":
        return 4.0 * math.sqrt(area)
    return 3.0 * math.sqrt(4.0 * area / math.sqrt(3.0))


def eroded(table: FeatureTable, depth: float) -> FeatureTable:
    """``table`` for bodies whose outline a video moves inwards by ``depth`` pixels (outwards where negative): each
    (shape, size)'s area less its perimeter times the depth."""
    return {key: ((centre[0] - perimeter(key[0], centre[0]) * depth, centre[1], centre[2]), spread)
            for key, (centre, spread) in table.items()}


def erosion(objects: Sequence[TrackedObject]) -> float | None:
    """How far (pixels) the video's compression has moved the outlines of its bodies inwards: the median, over the
    large bodies read surely, of their measured area's shortfall from their (shape, size)'s over its perimeter
    (None where there is no such body)."""
    depths = []
    for obj in objects:
        if not obj.shape_size:
            continue
        key = obj.best()
        if key[1] != "large" or obj.shape_size[key] < 0.99:
            continue
        areas = [m.area for m in obj.measurements.values() if m.complete]
        if len(areas) < 3:
            continue
        nominal = shape_features(obj.source_size)[key][0][0]
        depths.append((nominal - float(np.median(areas))) / perimeter(key[0], nominal))
    return float(np.median(depths)) if depths else None


#: The erosion (:func:`erosion`) of the generated MPEG-1 videos the feature tables were calibrated on: the median of
#: 275 videos of one seed is 0.031 px (5-95%: 0.00-0.10 px); their H.264 copies at crf 28 0.16 px (0.05-0.30), MPEG-4
#: copies at q 8 0.13 px (0.03-0.25): a small cube faded to a small circle's area.
TABLE_EROSION = 0.03
#: Where a video's erosion exceeds this, its bodies are read against the tables eroded by the difference.
ERODED_ABOVE = 0.08


def compression_depth(objects: Sequence[TrackedObject]) -> float:
    """The depth (pixels) to erode the feature tables by for these bodies (:func:`eroded`): their erosion beyond the
    tables' own where it exceeds :data:`ERODED_ABOVE`, else 0."""
    depth = erosion(objects)
    return depth - TABLE_EROSION if depth is not None and depth > ERODED_ABOVE else 0.0


def classify_shape(obj: TrackedObject, frames: np.ndarray, background: np.ndarray, samples: int = SHAPE_SAMPLES,
                   depth: float = 0.0) -> None:
    """Probabilities of each (shape, size) from up to ``samples`` complete frames (see the module docstring), against
    the tables eroded by ``depth`` pixels (:func:`compression_depth`: how much further the video's compression moved
    its bodies' outlines inwards than the tables' own videos did)."""
    pick = spread_frames(obj.seen_whole() or obj.seen(), samples)
    measure_frames(obj, frames, background, pick)
    features = _features(obj, pick)
    if features.size == 0:
        features = _features(obj, pick, complete=False)
    if features.size == 0:
        obj.shape_size = {(s, z): 1.0 / 6 for s in SHAPES for z in SIZES}
        return
    table = shape_features(obj.source_size)
    log_like = _log_likelihoods(features, eroded(table, depth) if depth else table)
    top = max(log_like.values())
    weights = {k: math.exp(v - top) for k, v in log_like.items()}
    total = sum(weights.values())
    obj.shape_size = {k: w / total for k, w in weights.items()}
