"""Analysis by synthesis: the simulation whose rendering is the video.

A CRAFT video is a deterministic function of its layout's random draws and its objects' attributes. Once the layout
and its statics are known (:mod:`craft_dsl.reader.layout`) and the bodies tracked (:mod:`craft_dsl.reader.track`),
what is left is a handful of numbers per body: the draws of its slot's start (position, velocity). They are fitted
by running the physics engine itself:

1. **Slots.** Each tracked body is given one of the layout's dynamic slots (Hungarian assignment): the cost is how
   far its first sighting lies from the slot's start region (for a body first seen later, beyond how far it could
   have moved since), plus the log-probability that its (shape, size) is one the slot allows. The slot fixes the
   creation order, hence the uniqueIDs and the engine's body order.
2. **Start.** Gauss-Newton (finite differences, backtracking, each draw kept within its range) on the start draws
   (the slots' own, and variables only the slots read) against the exact poses (render and compare,
   :mod:`craft_dsl.reader.refine`) of the first :data:`START_FRAMES` frames, and colour centroids where there is no
   exact pose (their measurement model adds the eye bias rotated by the simulated angle, :data:`EYE_BIAS`). A choice
   draw (a launch speed out of a list) is tried option by option.
3. **Check.** The whole run is simulated from the fitted start and compared with the tracks in every frame; while a
   body strays by more than :data:`STRAY_PX`, the start is refitted on all frames up to just before it strays (the
   longer window pins the start down further), at most :data:`REFITS` times. If it still strays, the less likely
   (shape, size) readings are tried (a body of the wrong shape makes the others stray too).
4. **Re-anchoring.** Chaotic contacts amplify the last digits of any start: a body that still strays is restarted a
   few frames before, its state there (position, angle, velocity, spin, with those of the other bodies that stray)
   fitted to the next frames by Levenberg-Marquardt, and the run goes on from there (:func:`reanchor`,
   :func:`stitch`), as long as each restart pushes the first stray later. A restart stays physical: no body is
   restarted sunk into a static or another body (:func:`overlaps`), where the engine's push back out would be a
   collision the video never showed. A body the run has lost by tens of pixels (after a chaotic contact) starts its
   restart fit where the window's first frames show it (:meth:`_Restart.guess`).

Time: frame ``k`` of the video shows the state after ``rows[k]`` steps (``k + 1`` at 60 fps; every 6th step at
10 fps, :func:`craft_dsl.reader.video.steps_shown`); the runs are compared with the observations at those steps.
Windows and restarts are counted in frames, their constants being those of a 60-fps video (where a frame is a
step), converted to frames of the video's rate so that a window covers about the same time at any rate, with floors
in frames (:data:`START_MIN_FRAMES`, :data:`MIN_WINDOW_FRAMES`, :data:`MIN_REFIT_GROWTH`, :data:`MAX_WINDOW_FRAMES`)
where a few frames would hold too little. Where frames are further apart than a step ("sparse"), the first start fit
begins on the shortest window, and a run that strays within its window is refitted on a longer one (a body that
enters after the first frames is not in them); at 60 fps neither applies.

What comes out is a live simulation (:class:`~craft_dsl.physics.live.LiveSimulation`): events from the engine's
contact log, counterfactuals by clean re-simulation, exactly as for the ground truth. Where no restart helps, the run
is kept as it is and its stray is reported.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..perception.coords import to_metres
from ..perception.events import GeometryProbe
from ..perception.params import ANGLE, POSITION, SIZE, SPIN, VELOCITY, VX, VY, X, Y, block, per_component, pose
from ..physics.engine import ContactLog, PhysicsEngine, RawRun, splice
from ..physics.live import LiveSimulation, get_engine
from ..physics.reach import interaction_groups
from ..render.raster import SIM_FPS, Y_MAX, world_to_pixel
from ..scenes import Choice, Uniform
from ..simulation import Trajectory
from ..vocabulary import ORIGINAL_ENGINE
from ..world import GRAVITY, BodySpec, WorldSpec, bounding_radius
from .jacobian import forward_jacobian
from .layout_model import Attributes, LayoutModel
from .measure import Measurement
from .track import EYE_BIAS, TrackedObject

#: Frames of the first start fit (at 60 fps: steps; see the module docstring for other rates).
START_FRAMES = 40
#: A body first seen later (fallen in from above the picture) extends the first fit to this many frames (at 60 fps)
#: after its first sighting: without them its start height is not seen at all.
ENTRY_FRAMES = 20
#: A fit or restart window holds at least this many frames (at a low rate the steps of a 60-fps window hold few);
#: the first start fit at least START_MIN_FRAMES (a longer first window holds contacts its start guess cannot meet).
MIN_WINDOW_FRAMES = 8
START_MIN_FRAMES = 4
#: Gauss-Newton iterations of a start fit, at most; an iteration that lowers the misfit by less than FIT_TOLERANCE of
#: it ends the fit. On 55 test videos' 326 start fits the median iteration lowered it by 5e-2, 1e-3, 1e-4, 1e-5 and then
#: less: most fits had converged to the frames' noise by their fourth iteration. Ending them there read seed
#: 20261204's 110 test videos 8% faster with one answer of 782 changed (to the right one).
FIT_ITERATIONS = 8
FIT_TOLERANCE = 1e-5
#: A body straying further than this from its track (pixels, in a frame where it is seen alone) triggers a refit.
STRAY_PX = 3.0
#: Refits on longer windows before the run is accepted as it is.
REFITS = 2
#: Another engine's reconstruction is made only when the kept run is further than this from the tracks (mean pixels,
#: capped as in the score). The engine that made a craft_dsl video reproduces it within 0.4-2.0 px (35 of 38
#: held-out videos; the other three, 9-13 px, hold a misread object); on the original CRAFT videos pymunk's median is
#: 1.5 px, with a quarter over 4.5 px.
SECOND_ENGINE_PX = 2.0
#: A later engine's reconstruction is the record (the run the factual events come from) only when it is nearer the
#: tracks by more than this; a later engine is the physics only when its first run (fitted from the start, before
#: other shape readings or restarts) is nearer by more than this ...
ENGINE_MARGIN_PX = 0.2
#: ... and follows them this many frames longer (at 60 fps) before a body first strays. Restarts pull any engine's
#: run back to the tracks (the kept runs of the wrong engine were as near as the right one's), so the runs are
#: compared before them: on 99 videos made with Box2D its first run was nearer than pymunk's in 95, nearer and longer
#: in 92; on 272 made with pymunk, Box2D's was nearer in 24 (a misfitted start), nearer and longer in 3.
ENGINE_LATER_FRAMES = 30
#: Longest window (frames) of a refit: beyond it the engine runs cost more than they pin down. At lower rates it may
#: hold MAX_WINDOW_FRAMES frames whatever their steps (the frames of 150 steps at 10 fps, 25, do not pin the start
#: down as far as 150 frames do).
MAX_WINDOW = 150
MAX_WINDOW_FRAMES = 40
#: A refit's window grows by at least this many frames (at 60 fps), and at least MIN_REFIT_GROWTH frames at any
#: rate: a body that enters the picture after the window is fitted once the window holds a few frames of it.
REFIT_GROWTH = 10
MIN_REFIT_GROWTH = 4
#: Frames measured exactly in a fit window: every one of the first DENSE_FRAMES, then about FIT_SAMPLES spread over
#: the rest (the blob centroids fill in between).
DENSE_FRAMES = 16
FIT_SAMPLES = 24
#: Re-anchoring: restart this many frames before the first stray, fit the next ANCHOR_WINDOW frames, restart the
#: bodies straying more than ANCHOR_MOVER_PX there; at most MAX_ANCHORS restarts per video.
ANCHOR_BACK = 6
ANCHOR_WINDOW = 36
#: (frames back, window) of each restart tried in turn: the default, then one further back on a shorter window
#: (the stray may have begun at a bounce some frames before it shows); where neither brings the run back, restarts
#: after the stray (negative: frames forward), which give up the frames between and keep the rest of the video.
ANCHOR_TRIES: tuple[tuple[int, int], ...] = ((ANCHOR_BACK, ANCHOR_WINDOW), (16, 24), (-12, 36), (-36, 36))
#: A restarted body may overlap the others (statics and bodies) by this much (metres) beyond where the run it
#: replaces had it (resting contacts sink a few millimetres into their skins); a fitted restart that sinks it deeper
#: is drawn back towards the old pose until it does not (:func:`_physical`, OVERLAP_BISECTIONS halvings): the engine
#: would push the body out in its first step, a collision the video never showed (a body resting on the basket's
#: floor, restarted 0.1 m low, hits the ground below it).
OVERLAP_SLACK = 0.02
OVERLAP_BISECTIONS = 6
ANCHOR_MOVER_PX = 1.0
ANCHOR_ITERATIONS = 5
#: A restart window shorter than this (frames) is not fitted.
ANCHOR_MIN_FRAMES = 4
#: A mover whose run lies further than this (pixels) from its first frames of a restart window starts its fit from
#: where those frames show it (:meth:`_Restart.guess`: position and velocity of a line through its first
#: GUESS_FRAMES observations) instead of from the run's state: the fit's steps (:data:`_ANCHOR_STEP_LIMIT`) cannot
#: cross the tens of pixels a run strays after a chaotic contact, so a restart after the stray could never catch up.
GUESS_PX = 5.0
GUESS_FRAMES = 6
#: Levenberg-Marquardt damping of a restart fit: this share of each diagonal term of J^T J plus this floor, so a
#: state the window does not pin down (a body at rest) keeps its value.
ANCHOR_DAMPING = 1e-3
ANCHOR_DAMPING_FLOOR = 1e-6
#: Step lengths tried, in turn, along a restart fit's step (the first that lowers the misfit is taken).
ANCHOR_STEP_SCALES = (1.0, 0.5, 0.25, 0.1)
#: Weight of a colour centroid's residual in a restart fit, against 1 for an exact pose.
CENTROID_WEIGHT = 0.2
#: Each restart must push the first stray later; this caps their number, and so the time a video's restarts take.
#: A lossy copy's noisier poses let runs stray sooner and need more restarts: at 6, 127 of a held-out seed's 346 H.264
#: (crf 28) test copies used every one (57 of the files); at 12 those runs strayed 4.7 px at most at the median
#: instead of 11.2 (the files' 57: 4.1 instead of 11.4), and of their 881 questions 18 answers turned right and 3
#: wrong (MPEG-4 q 8 copies: 6 and 4 of 501; the files: 0 and 1 of 346); 24 gained 3 of 177 more on the 29 copies
#: still using all 12.
MAX_ANCHORS = 12
_NO_OFFSET = np.zeros(SIZE)
#: The largest change of one restart-fit step (metres and radians for the pose, m/s and rad/s for the motion), for
#: up to 16 movers.
_ANCHOR_STEP_LIMIT = np.tile(per_component(0.5, 5.0), 16)
#: The finite-difference steps of a restart fit's Jacobian, per body (pose, motion).
_ANCHOR_FD_STEP = per_component(1e-4, 1e-3)
#: Distances above this (pixels) count as this much in the score of a run.
SCORE_CAP_PX = 20.0
#: Other (shape, size) readings tried per body when the run strays: at most this many, each at least this likely.
ALTERNATIVES = 2
ALTERNATIVE_P = 1e-4
#: A reading the detector found less likely replaces the current one only where its run follows the video closer by
#: this many pixels (mean, as in the score) per nat of the odds against it: how far a run strays also depends on
#: physics the reconstruction does not share with the video (measured on the original renderer's videos: a small
#: circle read at odds of 2,500 to 1, whose unanchored run strayed 6 px further than a cube's, read as a cube).
ALTERNATIVE_PX_PER_NAT = 1.0
_FD = 1e-5
#: A draw of one slot's own (its position, say): ``dynamic[<slot>].``.
_SLOT_PATH = re.compile(r"dynamic\[(\d+)\]\.")


def keeps_alternative(score: float, alternative_score: float, p_current: float, p_alternative: float) -> bool:
    """Whether a body's less likely (shape, size) reading (detector probability ``p_alternative``, against
    ``p_current`` for the one in use) replaces it: its run's score (mean capped distance from the tracks, pixels) must
    be lower by 0.2 px plus :data:`ALTERNATIVE_PX_PER_NAT` per nat of the odds against it."""
    odds = math.log(max(p_current, p_alternative) / p_alternative)
    return alternative_score < score - 0.2 - ALTERNATIVE_PX_PER_NAT * odds


@dataclass
class Reconstruction:
    """The fitted simulation and how well it follows the video."""

    simulation: LiveSimulation
    values: dict[str, float]
    slots: list[int]  # slot of each tracked object
    attributes: list[Attributes]  # per slot
    stray_px: dict[int, float] = field(default_factory=dict)  # uid -> largest distance from its track (pixels)
    first_stray: dict[int, int] = field(default_factory=dict)  # uid -> first frame (video frame) beyond STRAY_PX
    fit_frames: int = 0
    refits: int = 0
    anchors: int = 0  # restarts of straying bodies from the video
    final_px: float = 0.0  # mean distance (pixels, capped as in the score) of the kept run from the tracks
    # uid -> mean distance (pixels, capped) over the first fit's frames of the run fitted from the start (no restarts)
    start_px: dict[int, float] = field(default_factory=dict)
    tried: tuple[str, ...] = ()  # the engines run on the video (reconstruct_best: first or whole runs), the kept one
    # the engine counterfactuals are re-simulated with (reconstruct_best: the one whose first run follows the video
    # best; None: the run's own)
    physics: str | None = None


def _observations(obj: TrackedObject, frames: int) -> np.ndarray:
    """[frames, 3] per frame: x, y (pixels) and 1 where that is the colour centroid (with its eye bias), 0 where it
    is the exact centre (render and compare); NaN where the body is not seen alone or is cut by the border."""
    out = np.full((frames, 3), np.nan)
    for k, b in enumerate(obj.blobs[:frames]):
        if k in obj.poses:
            out[k] = (obj.poses[k][0], obj.poses[k][1], 0.0)
        elif b is not None and not b.touches_edge and not b.touches_static:
            m = obj.measurements.get(k)
            if m is not None and m.complete:
                out[k] = (m.x, m.y, 1.0)
            elif m is None:
                out[k] = (b.x, b.y, 1.0)
    return out


def _slot_starts(model: LayoutModel, values: Mapping[str, float]) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Per slot, given the static draws: the low and high corner (metres) of its start position, and its start
    vertical velocity (m/s; zero where the layout gives none)."""
    fields = model.evaluate(values)
    bounds = model.bounds(values)
    out = []
    for slot in range(len(model.layout.dynamic)):
        lo = np.zeros(2)
        hi = np.zeros(2)
        for axis in range(2):
            path = f"dynamic[{slot}].position[{axis}]"
            if path in bounds:
                lo[axis], hi[axis] = bounds[path]
            else:
                lo[axis] = hi[axis] = fields[path]
        out.append((lo, hi, float(fields.get(f"dynamic[{slot}].velocity[1]", 0.0))))
    return out


#: m/s: a body first seen only after the first frame (hidden, or its colour not read at first) may have moved this
#: fast meanwhile: its first sighting's distance from a slot counts only beyond that travel, and at least
#: HIDDEN_SHARE of it (a slot whose start the sighting fits, such as one above the picture it fell from, still
#: wins). A small brown circle that a H.264 copy showed in gray for 170 frames was first seen 150 px from its start,
#: inside another body's slot, and took that slot from the body seen there from the first frame.
HIDDEN_SPEED = 20.0
HIDDEN_SHARE = 0.1
#: A body first seen by this step counts as seen from the start (its position compared in x and y): a small cube in
#: a stack of touching cubes (scene 2) is often first read a frame or three late, and by x alone it took the slot of
#: the cube below it.
SEEN_AT_START_STEPS = 4
#: The first position of a body is read off a line through its sightings of its first FIRST_SPAN_STEPS steps (at
#: most FIRST_SIGHTINGS of them, at least FIRST_MIN_SIGHTINGS), a median line (Theil-Sen) that one stray sighting does
#: not move: in the first frame of a stack of cubes, specks of the others' outlines join a gray cube's piece and put
#: its centroid 8 px above the cube (in the row of the slots above it).
FIRST_SPAN_STEPS = 12
FIRST_SIGHTINGS = 8
FIRST_MIN_SIGHTINGS = 4
#: The least probability a slot's allowed readings count with in the assignment (a cost of -3 ln of it): the shape
#: features of a cube in a stack of touching cubes can read another shape with probability 1.0, and at a floor of
#: 1e-6 (41 m of distance) a stack's cube read as a circle took a circle's slot 15 m away.
ALLOWED_FLOOR = 1e-3


def first_sighting(obj: TrackedObject, rows: np.ndarray, step: int | None = None) -> tuple[float, float] | None:
    """Where ``obj`` is (pixels) at its first sighting, or at ``step`` where given, on a median line (Theil-Sen, per
    axis) through its sightings of the :data:`FIRST_SPAN_STEPS` steps from its first (``rows``: the step each frame
    shows); its first blob's centroid where fewer than :data:`FIRST_MIN_SIGHTINGS` lie there. None: never seen."""
    seen = obj.seen()
    if not seen:
        return None
    first = seen[0]
    near = [k for k in seen[:FIRST_SIGHTINGS] if int(rows[k]) - int(rows[first]) <= FIRST_SPAN_STEPS]
    blob = obj.blobs[first]
    assert blob is not None
    if len(near) < FIRST_MIN_SIGHTINGS:
        return blob.x, blob.y
    t = np.array([float(rows[k]) for k in near])
    xy = np.array([(b.x, b.y) for b in (obj.blobs[k] for k in near) if b is not None])
    i, j = np.triu_indices(len(near), 1)
    at = float(rows[first]) if step is None else float(step)
    slopes = (xy[j] - xy[i]) / (t[j] - t[i])[:, None]
    slope = np.median(slopes, axis=0)
    line = np.median(xy - slope * (t - at)[:, None], axis=0)
    return float(line[0]), float(line[1])


def assign_slots(model: LayoutModel, values: Mapping[str, float], objects: Sequence[TrackedObject],
                 rows: np.ndarray | Sequence[int] | None = None) -> list[int]:
    """The slot of each object (see the module docstring); objects beyond the slots get -1. ``rows``: the step
    each frame shows (default ``k + 1``). A body first seen after the first frame, from a slot that starts above
    the picture, is compared with where that slot's body has fallen to by then (the slots' heights order the
    entries); one hidden at first, by its x alone (one first seen by step :data:`SEEN_AT_START_STEPS` counts as seen
    from the start, its position carried back to the first frame's step). Positions are read robustly
    (:func:`first_sighting`)."""
    starts = _slot_starts(model, values)
    shown = _frame_rows(rows, max((len(obj.blobs) for obj in objects), default=0))
    cost = np.zeros((len(objects), len(starts)))
    for i, obj in enumerate(objects):
        seen = obj.seen()
        first = seen[0] if seen else 0
        at_start = first == 0 or int(shown[first]) <= SEEN_AT_START_STEPS
        sighting = first_sighting(obj, shown)
        pos = np.array(to_metres(*sighting, 256), dtype=float) if sighting is not None else np.array([0.0, 60.0])
        if at_start and first > 0:  # carried back to the first frame's step
            sighting = first_sighting(obj, shown, int(shown[0]))
            assert sighting is not None
        start_pos = np.array(to_metres(*sighting, 256), dtype=float) if sighting is not None else pos
        t = int(shown[first]) / SIM_FPS  # seconds until its first sighting
        for s, (lo, hi, vy) in enumerate(starts):
            if first > 0 and lo[1] > Y_MAX:  # fell in from above the picture: fallen from its start since
                fall = np.array([0.0, vy * t + 0.5 * GRAVITY[1] * t * t])
                gap = np.maximum(np.maximum(lo + fall - pos, 0.0), pos - hi - fall)
            elif not at_start:  # hidden at first: only x is comparable, less so the longer it was hidden
                off = max(lo[0] - pos[0], 0.0, pos[0] - hi[0])
                gap = np.array([max(off - HIDDEN_SPEED * t, HIDDEN_SHARE * off), 0.0])
            else:
                gap = np.maximum(np.maximum(lo - start_pos, 0.0), start_pos - hi)
            allowed = sum(p for (shape, size), p in obj.shape_size.items()
                          if model.slot_allows(s, (shape, obj.color_name, size)))
            cost[i, s] = float(np.hypot(*gap)) - 3.0 * math.log(max(allowed, ALLOWED_FLOOR))
    chosen, cols = linear_sum_assignment(cost)
    out = [-1] * len(objects)
    for r, c in zip(chosen, cols):
        out[int(r)] = int(c)
    return out


def slot_attributes(model: LayoutModel, objects: Sequence[TrackedObject], slots: Sequence[int]) -> list[Attributes]:
    """(shape, colour, size) per slot: each object's most likely (shape, size) that its slot allows and no other
    object of the scene has (the triples are unique)."""
    n_slots = len(model.layout.dynamic)
    out: list[Attributes | None] = [None] * n_slots
    used: set[Attributes] = set()
    order = sorted(range(len(objects)), key=lambda i: -max(objects[i].shape_size.values(), default=0.0))
    for i in order:
        s = slots[i]
        if s < 0:
            continue
        obj = objects[i]
        ranked = sorted(obj.shape_size.items(), key=lambda kv: -kv[1])
        for (shape, size), _p in ranked:
            triple = (shape, obj.color_name, size)
            if triple not in used and model.slot_allows(s, triple):
                out[s] = triple
                used.add(triple)
                break
        else:
            shape, size = obj.best()
            out[s] = (shape, obj.color_name, size)
    for s in range(n_slots):  # a slot no object was seen for: any allowed triple (the body never showed up)
        if out[s] is None:
            slot = model.layout.dynamic[s]
            out[s] = (slot.shape if slot.shape != "random" else "cube", slot.color if slot.color != "random" else
                      "gray", slot.size if slot.size != "random" else "small")
    return [t for t in out if t is not None]


def slot_uid(slot: int, slots: int) -> int:
    """The object id a layout's dynamic slot gets in the reconstructed world of ``slots`` slots (the last slot is
    uid 0)."""
    return slots - 1 - slot


class StartFit:
    """Least-squares fit of the start draws against the measured centroids."""

    def __init__(self, model: LayoutModel, static_values: Mapping[str, float], attributes: Sequence[Attributes],
                 observed: dict[int, np.ndarray], engine: PhysicsEngine, size: int = 256,
                 rows: np.ndarray | None = None) -> None:
        self.model = model
        self.static_values = dict(static_values)
        self.attributes = list(attributes)
        self.observed = observed  # slot -> [frames, 3] pixels and centroid flag (NaN: unseen)
        frames = max((o.shape[0] for o in observed.values()), default=0)
        self.rows = _frame_rows(rows, frames)  # the step each frame shows
        self.engine = engine
        self.size = size
        n = len(model.layout.dynamic)
        self.uids = [slot_uid(s, n) for s in range(n)]
        self._static_bounds = model.bounds(self.static_values)
        # every draw the statics do not read: the slots' own, and variables only the slots read (a launch speed)
        free = [d for d in model.draws if d.path not in model.static_paths]
        self.paths = [d.path for d in free if isinstance(d.quantity, Uniform)]
        self.choices = [d for d in free if isinstance(d.quantity, Choice)]

    def values(self, units: np.ndarray, choice: Mapping[str, float]) -> dict[str, float]:
        unit = {p: float(u) for p, u in zip(self.paths, units)}
        base = dict(self.static_values)
        out = self.model.from_unit({**{p: self._unit_of(p, v) for p, v in base.items()}, **unit})
        out.update(choice)
        return out

    def _unit_of(self, path: str, value: float) -> float:
        lo, hi = self._static_bounds[path]
        return 0.5 if hi == lo else (value - lo) / (hi - lo)

    def world(self, units: np.ndarray, choice: Mapping[str, float]) -> WorldSpec:
        return self.model.world(self.values(units, choice), self.attributes)

    def run(self, units: np.ndarray, choice: Mapping[str, float], frames: int) -> RawRun:
        """The run of these draws over the first ``frames`` frames."""
        shown = self.rows[:frames]
        return self.engine.run(self.world(units, choice), int(shown[-1]) if shown.size else 0)

    def predicted(self, raw: RawRun, frames: int) -> dict[int, np.ndarray]:
        """slot -> [frames, 2] predicted measured centroid (pixels) over the first ``frames`` frames of ``raw``."""
        shown = self.rows[:frames]
        traj = raw.trajectory
        out = {}
        for s, uid in enumerate(self.uids):
            col = traj.column(uid)
            pos = traj.positions[shown, col]
            ang = traj.angles[shown, col]
            shape, _color, size = self.attributes[s]
            bx, by = EYE_BIAS.get((shape, size), (0.0, 0.0))
            px, py = world_to_pixel(pos[:, 0], pos[:, 1], self.size)
            c, sn = np.cos(ang), np.sin(ang)
            # body-frame bias (y up) rotated by the angle, then to pixel axes (y down), where the observation is a
            # colour centroid
            biased = self.observed[s][:frames, 2] if s in self.observed else np.zeros(frames)
            biased = np.nan_to_num(biased)
            out[s] = np.stack([np.asarray(px) + biased * (c * bx - sn * by),
                               np.asarray(py) - biased * (sn * bx + c * by)], axis=1)
        return out

    def residual_of(self, raw: RawRun, frames: int) -> np.ndarray:
        """The weighted misfit (pixels) of ``raw`` against the observations of the first ``frames`` frames."""
        pred = self.predicted(raw, frames)
        parts = []
        for s, obs in self.observed.items():
            o = obs[:frames]
            ok = ~np.isnan(o[:, 0])
            # exact centres weigh as what they are: ten times more precise than colour centroids
            w = np.where(o[ok, 2] > 0, 1.0, 10.0)[:, None]
            parts.append(((pred[s][ok] - o[ok, :2]) * w).ravel())
        return np.concatenate(parts) if parts else np.zeros(0)

    def residual(self, units: np.ndarray, choice: Mapping[str, float], frames: int) -> np.ndarray:
        return self.residual_of(self.run(units, choice, frames), frames)

    def column_slots(self) -> list[int | None]:
        """The slot each fitted draw places (None for a draw several slots read, such as a shared speed)."""
        out: list[int | None] = []
        for path in self.paths:
            match = _SLOT_PATH.match(path)
            out.append(int(match.group(1)) if match else None)
        return out

    def fit(self, frames: int, start: np.ndarray | None = None) -> tuple[np.ndarray, dict[str, float], float]:
        """Best units, choice values and RMS residual (pixels) on the first ``frames`` frames."""
        options = [{}] if not self.choices else [
            {d.path: v for d, v in zip(self.choices, combo)}
            for combo in _product([d.quantity.options for d in self.choices])]  # type: ignore[union-attr]
        best: tuple[np.ndarray, dict[str, float], float] | None = None
        for choice in options:
            units = np.full(len(self.paths), 0.5) if start is None else start.copy()
            units, cost = self._gauss_newton(units, choice, frames)
            if best is None or cost < best[2]:
                best = (units, choice, cost)
        assert best is not None
        r = self.residual(best[0], best[1], frames)
        return best[0], best[1], float(np.sqrt(np.mean(r * r))) if r.size else 0.0

    def _gauss_newton(self, units: np.ndarray, choice: Mapping[str, float], frames: int) -> tuple[np.ndarray, float]:
        raw = self.run(units, choice, frames)
        r = self.residual_of(raw, frames)
        cost = float(r @ r)
        slot_rows = _row_slots(self.observed, frames)
        slot_columns = self.column_slots()
        dynamic = [b for b in self.world(units, choice).bodies if b.dynamic]
        for _ in range(FIT_ITERATIONS):
            if not self.paths:
                break
            # the draws of slots whose bodies stay apart in this run are nudged in the same run
            groups = _uid_groups(raw, dynamic)
            columns = [None if s is None else groups[self.uids[s]] for s in slot_columns]
            rows = np.array([groups[self.uids[s]] for s in slot_rows], dtype=int)
            steps = np.where(units + _FD <= 1.0, _FD, -_FD)
            jac = forward_jacobian(lambda u: self.residual(u, choice, frames), units, r, steps, columns, rows)
            # normal equations by einsum (a multithreaded BLAS is slow on a busy machine), lightly damped so that a
            # draw the window does not see keeps its value
            jtj = np.einsum("ij,ik->jk", jac, jac)
            step = np.linalg.solve(jtj + np.diag(1e-9 * np.diag(jtj) + 1e-12), -np.einsum("ij,i->j", jac, r))
            improved = False
            before = cost
            for alpha in (1.0, 0.5, 0.25, 0.1, 0.03):
                trial = np.clip(units + alpha * step, 0.0, 1.0)
                raw_t = self.run(trial, choice, frames)
                rt = self.residual_of(raw_t, frames)
                ct = float(rt @ rt)
                if ct < cost:
                    units, r, cost, raw, improved = trial, rt, ct, raw_t, True
                    break
            if not improved or fit_converged(before, cost, step):
                break
        return units, cost


def fit_converged(before: float, after: float, step: np.ndarray) -> bool:
    """Whether a Gauss-Newton iteration that took the misfit from ``before`` to ``after`` with ``step`` ends a fit:
    the step was negligible or it lowered the misfit by less than :data:`FIT_TOLERANCE` of it."""
    return float(np.max(np.abs(step))) < 1e-7 or before - after < FIT_TOLERANCE * before


def _uid_groups(raw: RawRun, dynamic: Sequence[BodySpec]) -> dict[int, int]:
    """uid -> interaction group over ``raw`` of each body of ``dynamic`` (the world's dynamic bodies; see
    :mod:`craft_dsl.reader.jacobian`)."""
    traj = raw.trajectory
    cols = [traj.column(b.uid) for b in dynamic]
    labels = interaction_groups(traj.positions[:, cols], [bounding_radius(b.geometry) for b in dynamic])
    return {b.uid: g for b, g in zip(dynamic, labels)}


def _row_slots(observed: Mapping[int, np.ndarray], frames: int) -> np.ndarray:
    """The slot each entry of a fit's residual measures: two entries (x, y) per seen frame among the first
    ``frames``, slot by slot in the order of ``observed``."""
    parts = [np.full(2 * int(np.count_nonzero(~np.isnan(obs[:frames, 0]))), s) for s, obs in observed.items()]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=int)


def _frame_rows(rows: np.ndarray | Sequence[int] | None, frames: int) -> np.ndarray:
    """The step each frame shows: ``rows``, or ``k + 1`` (60 fps) when None."""
    return np.arange(1, frames + 1, dtype=np.int64) if rows is None else np.asarray(rows, dtype=np.int64)


def frames_for(rows: np.ndarray, steps: int, least: int = 1) -> int:
    """Frames covering about ``steps`` steps at the rate of ``rows`` (``steps`` itself at 60 fps), at least
    ``least``; negative ``steps`` give the negative count."""
    if steps < 0:
        return -frames_for(rows, -steps, least)
    per_frame = float(rows[-1]) / len(rows) if len(rows) else 1.0
    return max(int(round(steps / per_frame)), least)


def start_frames(rows: np.ndarray) -> int:
    """Frames of the first start fit: :data:`START_FRAMES` at 60 fps, the frames of as many steps at other rates
    (at least :data:`START_MIN_FRAMES`), never more than the video holds."""
    return min(len(rows), frames_for(rows, START_FRAMES, START_MIN_FRAMES))


def first_window(observed: Mapping[int, np.ndarray], rows: np.ndarray) -> int:
    """Frames of the first start fit: :func:`start_frames`, longer when a body is first seen later: then until
    :data:`ENTRY_FRAMES` frames' worth of steps after its first sighting (at most the longest refit window)."""
    window = start_frames(rows)
    for obs in observed.values():
        seen = np.nonzero(~np.isnan(obs[:, 0]))[0]
        if seen.size and seen[0] > 0:
            window = max(window, int(seen[0]) + frames_for(rows, ENTRY_FRAMES, MIN_REFIT_GROWTH))
    return min(window, frames_for(rows, MAX_WINDOW, MAX_WINDOW_FRAMES), len(rows))


def fit_frames(window: int) -> list[int]:
    """The frames of a fit window that are measured exactly (see :data:`DENSE_FRAMES`)."""
    dense = list(range(min(DENSE_FRAMES, window)))
    if window <= DENSE_FRAMES:
        return dense
    stride = max(1, (window - DENSE_FRAMES) // FIT_SAMPLES)
    return dense + list(range(DENSE_FRAMES, window, stride))


def _product(options: Sequence[Sequence[float]]) -> list[tuple[float, ...]]:
    out: list[tuple[float, ...]] = [()]
    for opts in options:
        out = [o + (v,) for o in out for v in opts]
    return out


def _initial_units(fit: StartFit) -> np.ndarray:
    """Start positions from the first sightings (the middle of the range for the rest); where the first frame shows
    a later step than the first (a video of fewer than 60 fps), carried back to the start by the velocity of the
    first two sightings."""
    units = np.full(len(fit.paths), 0.5)
    bounds = fit.model.bounds(fit.static_values)
    for j, path in enumerate(fit.paths):
        if ".position[" not in path:
            continue
        slot = int(path.split("[", 1)[1].split("]", 1)[0])
        axis = int(path.rsplit("[", 1)[1][0])
        obs = fit.observed.get(slot)
        if obs is None:
            continue
        seen = np.nonzero(~np.isnan(obs[:, 0]))[0]
        if seen.size == 0:
            continue
        if seen[0] > 0 and axis == 1:
            # first seen later, fallen in from above the picture: dropped from rest, its height at the start
            _x, y = to_metres(obs[seen[0], 0], obs[seen[0], 1], fit.size)
            t = float(fit.rows[seen[0]]) / SIM_FPS
            lo, hi = bounds[path]
            value = float(y - 0.5 * GRAVITY[1] * t * t)
            units[j] = 0.5 if hi == lo else float(np.clip((value - lo) / (hi - lo), 0.0, 1.0))
            continue
        px, py = obs[seen[0], 0], obs[seen[0], 1]
        if seen[0] == 0 and fit.rows[0] > 1 and seen.size > 1 and seen[1] <= 2:
            back = float(fit.rows[0]) / float(fit.rows[seen[1]] - fit.rows[0])
            px, py = px - back * (obs[seen[1], 0] - px), py - back * (obs[seen[1], 1] - py)
        x, y = to_metres(px, py, fit.size)
        y = y if obs[seen[0], 2] == 0 else y - 0.3  # the colour centroid of a small body sits above its centre
        value = float(x if axis == 0 else y)
        lo, hi = bounds[path]
        units[j] = 0.5 if hi == lo else float(np.clip((value - lo) / (hi - lo), 0.0, 1.0))
    return units


def _as_observed(pos: np.ndarray, ang: np.ndarray, shape_size: tuple[str, str], biased: np.ndarray,
                 size: int) -> np.ndarray:
    """[n, 2] pixels: where body centres ``pos`` (metres) at angles ``ang`` are observed: the centre, plus the eye
    bias rotated by the angle where the observation is a colour centroid (``biased`` 1)."""
    bx, by = EYE_BIAS.get(shape_size, (0.0, 0.0))
    px, py = world_to_pixel(pos[:, 0], pos[:, 1], size)  # type: ignore[arg-type]
    c, sn = np.cos(ang), np.sin(ang)
    biased = np.nan_to_num(biased)
    return np.stack([np.asarray(px) + biased * (c * bx - sn * by), np.asarray(py) - biased * (sn * bx + c * by)],
                    axis=1)


def _predicted(sim: LiveSimulation, fit: StartFit, frames: int) -> dict[int, np.ndarray]:
    """slot -> [frames, 2]: where the run puts each observation."""
    traj = sim.raw.trajectory
    shown = fit.rows[:frames]
    out = {}
    for s in fit.observed:
        col = traj.column(fit.uids[s])
        shape, _color, size = fit.attributes[s]
        out[s] = _as_observed(traj.positions[shown, col], traj.angles[shown, col], (shape, size),
                              fit.observed[s][:frames, 2], fit.size)
    return out


def _distances(sim: LiveSimulation, fit: StartFit, frames: int) -> dict[int, np.ndarray]:
    """slot -> [frames] distance (pixels) between the run and the observations (NaN where none)."""
    pred = _predicted(sim, fit, frames)
    return {s: np.hypot(*(pred[s] - obs[:frames, :2]).T) for s, obs in fit.observed.items()}


def stray(sim: LiveSimulation, fit: StartFit, frames: int, start: int = 0
          ) -> tuple[dict[int, float], dict[int, int]]:
    """Per uid: the largest distance (pixels) between the run and its track, and the first frame from ``start`` on
    beyond STRAY_PX (two frames in a row: a single one is a blob merged with a neighbour's rim)."""
    worst: dict[int, float] = {}
    first: dict[int, int] = {}
    for s, d in _distances(sim, fit, frames).items():
        uid = fit.uids[s]
        ok = ~np.isnan(d)
        worst[uid] = float(np.max(d[ok])) if ok.any() else 0.0
        ok[:start] = False
        over = np.nonzero(ok & (np.nan_to_num(d) > STRAY_PX))[0]
        runs = over[1:][np.diff(over) == 1] if over.size > 1 else np.zeros(0, dtype=int)
        if runs.size:
            first[uid] = int(runs[0] - 1)
    return worst, first


def body_scores(sim: LiveSimulation, fit: StartFit, frames: int) -> dict[int, float]:
    """Per uid seen in the first ``frames`` frames: the mean distance (pixels, capped as in :func:`_score`) of the run
    from its track there."""
    out = {}
    for s, d in _distances(sim, fit, frames).items():
        ok = ~np.isnan(d)
        if ok.any():
            out[fit.uids[s]] = float(np.minimum(d[ok], SCORE_CAP_PX).mean())
    return out


def _score(sim: LiveSimulation, fit: StartFit, frames: int, start: int = 0) -> float:
    """How far the run strays from the tracks from frame ``start`` on: mean over bodies and frames seen of the
    distance, capped at :data:`SCORE_CAP_PX` (a body lost for good costs the cap, not its whole flight)."""
    total, count = 0.0, 0
    for d in _distances(sim, fit, frames).values():
        d = d[start:]
        ok = ~np.isnan(d)
        total += float(np.minimum(d[ok], SCORE_CAP_PX).sum())
        count += int(ok.sum())
    return total / max(count, 1)


@dataclass
class _Attempt:
    units: np.ndarray
    choice: dict[str, float]
    simulation: LiveSimulation
    worst: dict[int, float]
    first: dict[int, int]
    window: int
    refits: int
    score: float


def first_start_fit(model: LayoutModel, static_values: Mapping[str, float], objects: Sequence[TrackedObject],
                    slots: Sequence[int], attributes: Sequence[Attributes], frames: int, eng: PhysicsEngine,
                    measure: Callable[[TrackedObject, Sequence[int], str, str], None] | None, rows: np.ndarray
                    ) -> tuple[StartFit, int]:
    """The start fit of a video's first frames (``rows``: the step each shows) and their number: the objects in
    their slots, measured exactly in those frames by ``measure`` (as their slot's shape and size)."""
    window = start_frames(rows)
    if measure is not None:
        for obj, s in zip(objects, slots):
            if s >= 0:
                measure(obj, fit_frames(window), attributes[s][0], attributes[s][2])
    observed = {s: _observations(obj, frames) for obj, s in zip(objects, slots) if s >= 0}
    return StartFit(model, static_values, attributes, observed, eng, rows=rows), window


def fit_window(fit: StartFit, window: int, sparse: bool) -> tuple[np.ndarray, dict[str, float], float]:
    """``fit.fit`` on the first ``window`` frames from the start the first sightings give. ``sparse`` (frames
    further apart than a step): the start guess is further off and the window's few frames leave the fit local
    minima, so the shortest window is fitted first, its draws the guess of the whole window."""
    start = _initial_units(fit)
    if sparse and window > START_MIN_FRAMES:
        start = fit.fit(START_MIN_FRAMES, start)[0]
    return fit.fit(window, start)


def _attempt(model: LayoutModel, static_values: Mapping[str, float], objects: Sequence[TrackedObject],
             slots: Sequence[int], attributes: Sequence[Attributes], frames: int, steps: int, eng: PhysicsEngine,
             measure: Callable[[TrackedObject, Sequence[int], str, str], None] | None, refits_allowed: int,
             rows: np.ndarray) -> _Attempt:
    fit, window = first_start_fit(model, static_values, objects, slots, attributes, frames, eng, measure, rows)
    longer = first_window(fit.observed, rows)
    if longer > window:  # a body first seen later: the first fit sees it for a while
        window = longer
        if measure is not None:
            for obj, s in zip(objects, slots):
                if s >= 0:
                    measure(obj, fit_frames(window), attributes[s][0], attributes[s][2])
                    fit.observed[s] = _observations(obj, frames)
    sparse = bool(rows.size and rows[-1] > rows.size)
    units, choice, _rms = fit_window(fit, window, sparse)
    refits = 0
    while True:
        world = fit.world(units, choice)
        sim = LiveSimulation(world, eng.run(world, steps), eng, meta={"scene": model.scene_id,
                                                                     "source": "reconstructed from video"})
        worst, first = stray(sim, fit, frames)
        if not first or refits >= refits_allowed:
            break
        earliest = min(first.values())
        if earliest <= window and not sparse:
            break  # (sparse frames: a body first seen after the window may stray within it; a longer window helps)
        window = min(max(window + frames_for(rows, REFIT_GROWTH, MIN_REFIT_GROWTH), earliest - 2),
                     frames_for(rows, MAX_WINDOW, MAX_WINDOW_FRAMES), frames)
        if measure is not None:
            for obj, s in zip(objects, slots):
                if s >= 0:
                    measure(obj, fit_frames(window), attributes[s][0], attributes[s][2])
                    fit.observed[s] = _observations(obj, frames)
        units, choice, _rms = fit.fit(window, units)
        refits += 1
    return _Attempt(units, choice, sim, worst, first, window, refits, _score(sim, fit, frames))


# -- re-anchoring: where chaotic contacts make the run stray, restart the straying bodies from the video ----------


def _state_world(world: WorldSpec, traj: Trajectory, row: int, offsets: Mapping[int, np.ndarray]) -> WorldSpec:
    """``world`` with every dynamic body at its state of ``row`` (plus ``offsets[uid]``: dx, dy, dangle, dvx, dvy,
    dspin)."""
    bodies = []
    for b in world.bodies:
        if not b.dynamic:
            bodies.append(b)
            continue
        c = traj.column(b.uid)
        d = offsets.get(b.uid, _NO_OFFSET)
        bodies.append(replace(
            b, position=(float(traj.positions[row, c, 0] + d[X]), float(traj.positions[row, c, 1] + d[Y])),
            angle=float(traj.angles[row, c] + d[ANGLE]),
            velocity=(float(traj.velocities[row, c, 0] + d[VX]), float(traj.velocities[row, c, 1] + d[VY])),
            angular_velocity=float(traj.angular_velocities[row, c] + d[SPIN])))
    return replace(world, bodies=tuple(bodies))


def overlaps(world: WorldSpec, uids: Sequence[int]) -> np.ndarray:
    """How deep (metres, 0 where apart or touching) each body of ``uids`` overlaps any other body of ``world``
    (statics and dynamic bodies at their positions there; sensors do not count)."""
    return GeometryProbe(world).overlap_depths(uids)


def _place(probe: GeometryProbe, traj: Trajectory, row: int, offsets: Mapping[int, np.ndarray]) -> None:
    """The probe's dynamic bodies at their pose of ``row`` plus ``offsets[uid]`` (as :func:`_state_world`)."""
    columns = {uid: traj.column(uid) for uid in probe.dynamic}
    positions = traj.positions[row].copy()
    angles = traj.angles[row].copy()
    for uid, d in offsets.items():
        positions[columns[uid]] += d[POSITION]
        angles[columns[uid]] += d[ANGLE]
    probe.place(positions, angles, columns)


def _shift_log(log: ContactLog, row: int, steps: int) -> ContactLog:
    """A log of a run started at ``row``, in the frames of the whole run."""
    return ContactLog(steps, {k: tuple((s + row, e + row) for s, e in v) for k, v in log.contacts.items()},
                      {k: tuple((s + row, e + row) for s, e in v) for k, v in log.sensors.items()})


def stitch(base: RawRun, tail: RawRun, row: int) -> RawRun:
    """``base`` up to ``row`` and ``tail`` (a run started from row ``row``'s state) from it on."""
    steps = base.log.steps
    b, t = base.trajectory, tail.trajectory
    traj = replace(b, positions=np.concatenate([b.positions[:row], t.positions]),
                   angles=np.concatenate([b.angles[:row], t.angles]),
                   velocities=np.concatenate([b.velocities[:row], t.velocities]),
                   angular_velocities=np.concatenate([b.angular_velocities[:row], t.angular_velocities]))
    awake = np.concatenate([base.awake[:row], tail.awake])
    shifted = _shift_log(tail.log, row, steps)
    contacts = {k: splice(base.log.contacts.get(k, ()), shifted.contacts.get(k, ()), row, steps)
                for k in set(base.log.contacts) | set(shifted.contacts)}
    sensors = {k: splice(base.log.sensors.get(k, ()), shifted.sensors.get(k, ()), row, steps)
               for k in set(base.log.sensors) | set(shifted.sensors)}
    return RawRun(traj, awake, ContactLog(steps, {k: v for k, v in contacts.items() if v},
                                          {k: v for k, v in sensors.items() if v}))


def reanchor(sim: LiveSimulation, fit: StartFit, frames: int, first_stray: int, eng: PhysicsEngine,
             refresh: Callable[[Sequence[int]], None] | None, back: int = ANCHOR_BACK, window: int = ANCHOR_WINDOW
             ) -> LiveSimulation | None:
    """Restart the bodies that stray from the video a few frames before ``first_stray``, their state there fitted
    to the next :data:`ANCHOR_WINDOW` frames (Levenberg-Marquardt on position, angle, velocity and spin of each), and
    run on to the end. ``back`` and ``window`` are frames at 60 fps (:func:`anchor_frames` converts them). Each trial
    state is made physical first (:func:`_physical`: no body sunk into another beyond :data:`OVERLAP_SLACK` more than
    the replaced run had it). None when the fit does not follow the window better than the run it replaces."""
    steps = sim.raw.log.steps
    back, window = anchor_frames(fit.rows, back, window)
    row = max(1, first_stray - back)
    end = min(frames, row + window)
    if end - row < ANCHOR_MIN_FRAMES:
        return None
    # the restart is the state just before frame ``row``'s step; the window's frames show ``rows[row:end] - start``
    # steps of the restarted run (at 60 fps: start = row, and frames row .. end - 1 are its steps 1 .. end - row)
    start = int(fit.rows[row]) - 1
    if refresh is not None:
        refresh(list(range(row, end)))
    dist = _distances(sim, fit, frames)
    movers = [fit.uids[s] for s, d in dist.items()
              if np.nanmax(np.concatenate([d[row:end], [0.0]])) > ANCHOR_MOVER_PX]
    if not movers:
        return None
    restart = _Restart(sim, fit, eng, start, fit.rows[row:end] - start, movers,
                       {s: o[row:end] for s, o in fit.observed.items()})
    offsets = restart.fit()
    if offsets is None:
        return None
    tail = eng.run(_state_world(restart.world, restart.traj, start, offsets), steps - start)
    raw = stitch(sim.raw, tail, start)
    return LiveSimulation(restart.world, raw, eng, meta=dict(sim.meta, anchors=sim.meta.get("anchors", 0) + 1))


def _offsets(movers: Sequence[int], params: np.ndarray) -> dict[int, np.ndarray]:
    """Each mover's restart offset (dx, dy, dangle, dvx, dvy, dspin) in ``params``."""
    return {uid: block(params, i) for i, uid in enumerate(movers)}


class _Restart:
    """The fit of a restart's state: the movers' offsets from the run's state at ``start`` that make the restarted
    run follow the ``observed`` window (``shown``: the steps of the restarted run each frame of it shows)."""

    def __init__(self, sim: LiveSimulation, fit: StartFit, eng: PhysicsEngine, start: int, shown: np.ndarray,
                 movers: list[int], observed: dict[int, np.ndarray]) -> None:
        self.start_fit = fit
        self.eng = eng
        self.start = start
        self.shown = shown
        self.movers = movers
        self.observed = observed
        self.traj = sim.raw.trajectory
        self.world = sim.world_spec
        self.probe = GeometryProbe(self.world)
        _place(self.probe, self.traj, start, {})
        self.allowed = self.probe.overlap_depths(movers) + OVERLAP_SLACK

    def run_at(self, params: np.ndarray) -> RawRun:
        """The restarted run over the window, the movers offset by ``params``."""
        return self.eng.run(_state_world(self.world, self.traj, self.start, _offsets(self.movers, params)),
                            int(self.shown[-1]))

    def residual_of(self, run: RawRun) -> np.ndarray:
        """Weighted distances (pixels) between ``run`` and the window's observed positions."""
        fit, shown = self.start_fit, self.shown
        t = run.trajectory
        parts = []
        for s, o in self.observed.items():
            uid = fit.uids[s]
            c = t.column(uid)
            n = shown.size
            shape, _color, size = fit.attributes[s]
            pred = _as_observed(t.positions[shown, c], t.angles[shown, c], (shape, size), o[:n, 2], fit.size)
            ok = ~np.isnan(o[:n, 0])
            w = np.where(o[:n, 2] > 0, CENTROID_WEIGHT, 1.0)  # colour centroids weigh less than exact poses
            parts.append(((pred - o[:n, :2])[ok] * w[ok, None]).ravel())
        return np.concatenate(parts) if parts else np.zeros(0)

    def jacobian(self, params: np.ndarray, run: RawRun, r: np.ndarray) -> np.ndarray:
        """Forward differences of the residual at ``params``: the states of movers that stay apart in ``run`` are
        nudged in the same run."""
        groups = _uid_groups(run, [b for b in self.world.bodies if b.dynamic])
        columns = [groups[uid] for uid in self.movers for _k in range(SIZE)]
        rows = np.array([groups[self.start_fit.uids[s]] for s in _row_slots(self.observed, self.shown.size)], dtype=int)
        steps_fd = np.tile(_ANCHOR_FD_STEP, len(self.movers))
        return forward_jacobian(lambda p: self.residual_of(self.run_at(p)), params, r, steps_fd, columns, rows)

    def guess(self) -> np.ndarray:
        """Offsets that put each mover the run has lost (further than :data:`GUESS_PX` from its first frame seen in
        the window) where the window shows it: position and velocity of a least-squares line through its first
        :data:`GUESS_FRAMES` observations (a colour centroid less its eye bias at the run's angle); its angle and spin,
        and every mover the run has not lost, keep the run's. Zero where nothing is lost."""
        params = np.zeros(SIZE * len(self.movers))
        fit, start, last = self.start_fit, self.start, self.traj.positions.shape[0] - 1
        slot_of = {uid: s for s, uid in enumerate(fit.uids)}
        for i, uid in enumerate(self.movers):
            obs = self.observed.get(slot_of.get(uid, -1))
            if obs is None:
                continue
            seen = np.nonzero(~np.isnan(obs[:self.shown.size, 0]))[0][:GUESS_FRAMES]
            if seen.size < 2:
                continue
            col = self.traj.column(uid)
            shape, _color, size = fit.attributes[slot_of[uid]]
            rows = np.minimum(start + self.shown[seen], last)
            angle = self.traj.angles[start, col]
            run_seen = _as_observed(self.traj.positions[rows[:1], col], self.traj.angles[rows[:1], col],
                                    (shape, size), obs[seen[:1], 2], fit.size)[0]
            if float(np.hypot(*(run_seen - obs[seen[0], :2]))) <= GUESS_PX:
                continue
            bias = _as_observed(np.zeros((seen.size, 2)), np.full(seen.size, angle), (shape, size), obs[seen, 2],
                                fit.size) - np.array(world_to_pixel(0.0, 0.0, fit.size))
            x, y = to_metres(obs[seen, 0] - bias[:, 0], obs[seen, 1] - bias[:, 1], fit.size)
            t = self.shown[seen] / SIM_FPS
            design = np.stack([np.ones_like(t), t], axis=1)
            (x0, vx), (y0, vy) = np.linalg.lstsq(design, np.stack([x, y], axis=1), rcond=None)[0].T
            b = block(params, i)
            b[POSITION] = (x0, y0) - self.traj.positions[start, col]
            if seen.size >= 3:
                b[VELOCITY] = (vx, vy) - self.traj.velocities[start, col]
        return params

    def fit(self) -> dict[int, np.ndarray] | None:
        """The fitted offsets of each mover; None when they follow the window no better than no offset. The fit
        starts from :meth:`guess` where that follows the window better than the run's own state."""
        params = np.zeros(SIZE * len(self.movers))
        run = self.run_at(params)
        r = self.residual_of(run)
        cost = float(r @ r)
        before = cost
        base = params
        guessed = self.guess()
        if np.any(guessed):
            guessed = _physical(self.probe, self.traj, self.start, self.movers, guessed, self.allowed)
            run_g = self.run_at(guessed)
            r_g = self.residual_of(run_g)
            if float(r_g @ r_g) < cost:
                params, run, r, cost, base = guessed, run_g, r_g, float(r_g @ r_g), guessed
        for _ in range(ANCHOR_ITERATIONS):
            step = _damped_step(self.jacobian(params, run, r), r, _ANCHOR_STEP_LIMIT[:params.size])
            improved = False
            for alpha in ANCHOR_STEP_SCALES:
                trial = _physical(self.probe, self.traj, self.start, self.movers, params + alpha * step, self.allowed,
                                  base)
                run_t = self.run_at(trial)
                rt = self.residual_of(run_t)
                ct = float(rt @ rt)
                if ct < cost:
                    params, r, cost, run, improved = trial, rt, ct, run_t, True
                    break
            if not improved:
                break
        if cost >= before:
            return None
        return _offsets(self.movers, params)


def _damped_step(jac: np.ndarray, r: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """The Levenberg-Marquardt step lowering ``r`` (damped by :data:`ANCHOR_DAMPING`), each component within
    ``limit``."""
    jtj = np.einsum("ij,ik->jk", jac, jac)
    damped = jtj + np.diag(ANCHOR_DAMPING * np.diag(jtj) + ANCHOR_DAMPING_FLOOR)
    return np.clip(np.linalg.solve(damped, -np.einsum("ij,i->j", jac, r)), -limit, limit)


def _physical(probe: GeometryProbe, traj: Trajectory, start: int, movers: Sequence[int], params: np.ndarray,
              allowed: np.ndarray, base: np.ndarray | None = None) -> np.ndarray:
    """``params`` (restart offsets of ``movers``, :data:`SIZE` each) with the pose offset (position, angle) of each
    mover that would overlap the others deeper than ``allowed`` drawn back towards ``base`` (default zero: the run's
    own pose; a physical starting point of the fit) until it does not (bisection)."""
    params = params.copy()
    origin = np.zeros_like(params) if base is None else base

    def depth(i: int, scale: float) -> float:
        trial = params.copy()
        pose(trial, i)[:] = pose(origin, i) + scale * (pose(params, i) - pose(origin, i))
        _place(probe, traj, start, _offsets(movers, trial))
        return float(probe.overlap_depths([movers[i]])[0])

    for i in range(len(movers)):
        if depth(i, 1.0) <= allowed[i]:
            continue
        lo, hi = 0.0, 1.0  # lo: within the allowance (the old pose is), hi: beyond it
        for _ in range(OVERLAP_BISECTIONS):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if depth(i, mid) <= allowed[i] else (lo, mid)
        pose(params, i)[:] = pose(origin, i) + lo * (pose(params, i) - pose(origin, i))
    return params


def anchor_frames(rows: np.ndarray, back: int, window: int) -> tuple[int, int]:
    """A restart's (frames back, window) at the rate of ``rows``, from those of a 60-fps video (the same there)."""
    return frames_for(rows, back), frames_for(rows, window, MIN_WINDOW_FRAMES)


@dataclass
class FirstRun:
    """An engine's first run of a video (:func:`first_run`): the slots, their attributes and the run fitted from the
    start, before other shape readings or restarts."""

    engine: PhysicsEngine
    rows: np.ndarray
    slots: list[int]
    attributes: list[Attributes]
    attempt: _Attempt

    @property
    def strays_at(self) -> int:
        """The first frame where a body strays (the frame count where none does)."""
        return min(self.attempt.first.values()) if self.attempt.first else len(self.rows)


def first_run(model: LayoutModel, static_values: Mapping[str, float], objects: Sequence[TrackedObject],
              frames: int, steps: int = 600, engine: str | PhysicsEngine = "pymunk",
              measure: Callable[[TrackedObject, Sequence[int], str, str], None] | None = None,
              rows: np.ndarray | Sequence[int] | None = None) -> FirstRun:
    """The first steps of :func:`reconstruct`: slots, attributes and the start fit with its refits (arguments as
    there)."""
    eng = get_engine(engine)
    shown = _frame_rows(rows, frames)
    if shown.size != frames or (frames and (shown[0] < 1 or shown[-1] > steps or np.any(np.diff(shown) <= 0))):
        raise ValueError(f"rows must be {frames} increasing steps within 1..{steps}")
    slots = assign_slots(model, static_values, objects, shown)
    attributes = slot_attributes(model, objects, slots)
    attempt = _attempt(model, static_values, objects, slots, attributes, frames, steps, eng, measure, REFITS, shown)
    return FirstRun(eng, shown, list(slots), list(attributes), attempt)


def reconstruct(model: LayoutModel, static_values: Mapping[str, float], objects: Sequence[TrackedObject],
                frames: int, steps: int = 600, engine: str | PhysicsEngine = "pymunk",
                measure: Callable[[TrackedObject, Sequence[int], str, str], None] | None = None,
                rows: np.ndarray | Sequence[int] | None = None, opening: FirstRun | None = None) -> Reconstruction:
    """The simulation of a video (see the module docstring). ``measure(obj, frames)`` adds full-resolution
    measurements and exact poses of those frames to ``obj`` as (shape, size) (the fit windows use them; elsewhere
    the blob centroids do). ``rows``: the step each frame shows (default ``k + 1``, 60 fps); ``steps``: the run's
    length, at least the last of ``rows``. ``opening``: this engine's :func:`first_run` of the video, if made.

    When the run strays, the (shape, size) readings the detector found less likely are tried in turn (a body of the
    wrong shape makes the others stray too): the attributes whose run follows the video best are kept, where it follows
    it better by a margin that grows with the odds against the reading (:func:`keeps_alternative`)."""
    if opening is None:
        opening = first_run(model, static_values, objects, frames, steps, engine, measure, rows)
    eng, shown, slots, best = opening.engine, opening.rows, opening.slots, opening.attempt
    attributes = list(opening.attributes)
    if best.first:
        order = sorted(range(len(objects)), key=lambda i: max(objects[i].shape_size.values(), default=1.0))
        for i in order:
            s = slots[i]
            if s < 0:
                continue
            obj = objects[i]
            ranked = sorted(obj.shape_size.items(), key=lambda kv: -kv[1])
            tried = 0
            for (shape, size), p in ranked:
                triple = (shape, obj.color_name, size)
                if p < ALTERNATIVE_P or tried >= ALTERNATIVES or triple == attributes[s]:
                    continue
                if triple in attributes or not model.slot_allows(s, triple):
                    continue
                tried += 1
                trial = list(attributes)
                trial[s] = triple
                attempt = _attempt(model, static_values, objects, slots, trial, frames, steps, eng, measure, 0, shown)
                current = obj.shape_size.get((attributes[s][0], attributes[s][2]), p)
                if keeps_alternative(best.score, attempt.score, current, p):
                    best, attributes = attempt, trial
    sim, worst, first = best.simulation, best.worst, best.first
    fit = StartFit(model, static_values, attributes,
                   {s: _observations(obj, frames) for obj, s in zip(objects, slots) if s >= 0}, eng, rows=shown)
    start_px = body_scores(sim, fit, start_frames(shown))
    anchors = 0

    def refresh(which: Sequence[int]) -> None:
        if measure is None:
            return
        for obj, s in zip(objects, slots):
            if s >= 0:
                measure(obj, which, attributes[s][0], attributes[s][2])
                fit.observed[s] = _observations(obj, frames)

    while first and anchors < MAX_ANCHORS:
        earliest = min(first.values())
        progressed = False
        for back, window in ANCHOR_TRIES:
            restarted = reanchor(sim, fit, frames, earliest, eng, refresh, back, window)
            if restarted is None:
                continue
            # progress: from the restart on, the run follows the video longer than before (earlier frames are the
            # old run's, whatever outliers they hold)
            row = max(1, earliest - anchor_frames(shown, back, window)[0])
            new_worst, new_first = stray(restarted, fit, frames, start=row)
            if back >= 0:
                old_at = earliest
            else:  # a restart after the stray: compared with the old run from the same frame on
                old_first = stray(sim, fit, frames, start=row)[1]
                old_at = min(old_first.values()) if old_first else frames
            if new_first and min(new_first.values()) <= old_at:
                continue
            sim, worst, first = restarted, new_worst, new_first
            anchors += 1
            progressed = True
            break
        if not progressed:
            break
    return Reconstruction(sim, fit.values(best.units, best.choice), list(slots), list(attributes), worst, first,
                          best.window, best.refits, anchors, _score(sim, fit, frames), start_px)


# -- which physics: the engine whose runs follow the video best ------------------------------------------------

#: The engines the reader reconstructs with, in order of preference: the default engine's first (the engine a video
#: of unknown origin most likely comes from), then the other.
READER_ENGINES: tuple[str, ...] = ("box2d", "pymunk")


def reader_engines(aliased: bool = False, first: str | None = None) -> tuple[str, ...]:
    """:data:`READER_ENGINES` that are installed, in the order they are tried. ``first``: the engine the video is
    known to come from (its dataset's ``generation_config.json``), tried first; ``"original"`` counts as the look
    below. A video whose statics have aliased edges (``aliased``: the original CRAFT renderer's look, measured by
    :func:`~craft_dsl.reader.layout.edge_share`) is reconstructed with Box2D alone: the original simulator is Box2D,
    and where Box2D's run strays, pymunk's nearer run still answers less like the original (13 held-out original
    videos where pymunk's run was kept: 14 wrong answers of 93, 11 with Box2D alone)."""
    try:
        import Box2D  # noqa: F401
    except ImportError:
        return ("pymunk",)
    if aliased or first == ORIGINAL_ENGINE:
        return ("box2d",)
    if first in READER_ENGINES:
        return (first, *(e for e in READER_ENGINES if e != first))
    return READER_ENGINES


def _strays_no_sooner(earlier: FirstRun) -> int:
    """The first frame a later engine's first run may stray at and still win against ``earlier``: at least
    :data:`ENGINE_LATER_FRAMES` frames (at 60 fps) after ``earlier``'s."""
    return earlier.strays_at + frames_for(earlier.rows, ENGINE_LATER_FRAMES)


def later_engine_wins(earlier: FirstRun, later: FirstRun) -> bool:
    """A later engine's first run follows the video better than an earlier one's: nearer the tracks by more than
    :data:`ENGINE_MARGIN_PX` and for :data:`ENGINE_LATER_FRAMES` frames (at 60 fps) longer before a body strays."""
    return (later.attempt.score < earlier.attempt.score - ENGINE_MARGIN_PX
            and later.strays_at >= _strays_no_sooner(earlier))


def can_win_later(earlier: FirstRun) -> bool:
    """Whether any later first run could win against ``earlier`` (:func:`later_engine_wins`): one that follows the
    whole video (strays at its frame count) follows it long enough longer."""
    return _strays_no_sooner(earlier) <= len(earlier.rows)


_Measured = list[tuple[dict[int, Measurement], dict[int, tuple[float, float, float]], tuple[str, str] | None]]


def _measured(objects: Sequence[TrackedObject]) -> _Measured:
    """What ``measure`` has cached on each object so far (measurements, exact poses and the shape they are of)."""
    return [(dict(o.measurements), dict(o.poses), o.pose_shape) for o in objects]


def _restore(objects: Sequence[TrackedObject], measured: _Measured) -> None:
    for o, (measurements, poses, pose_shape) in zip(objects, measured):
        o.measurements.clear()
        o.measurements.update(measurements)
        o.poses.clear()
        o.poses.update(poses)
        o.pose_shape = pose_shape


def _reusing(measure: Callable[[TrackedObject, Sequence[int], str, str], None], objects: Sequence[TrackedObject],
             made: _Measured) -> Callable[[TrackedObject, Sequence[int], str, str], None]:
    """``measure``, taking the measurements and exact poses it already made (``made``: :func:`_measured` after an
    earlier engine's first run) instead of making them again: each frame's measurement and pose is made from that
    frame alone, so they are the values it would make, and the objects hold what they would hold."""
    known = {id(obj): m for obj, m in zip(objects, made)}

    def again(obj: TrackedObject, which: Sequence[int], shape: str, size: str) -> None:
        if id(obj) in known:
            measurements, poses, pose_shape = known[id(obj)]
            for k in which:
                if k not in obj.measurements and k in measurements:
                    obj.measurements[k] = measurements[k]
            if pose_shape == (shape, size):
                if obj.pose_shape != pose_shape:  # as refine_frames does: another shape's poses go
                    obj.poses.clear()
                    obj.pose_shape = pose_shape
                for k in which:
                    if k not in obj.poses and k in poses:
                        obj.poses[k] = poses[k]
        measure(obj, which, shape, size)
    return again


def follows_closely(rec: Reconstruction) -> bool:
    """The kept run is within :data:`SECOND_ENGINE_PX` of the tracks: no other engine's reconstruction is needed."""
    return rec.final_px <= SECOND_ENGINE_PX


def reconstruct_best(model: LayoutModel, static_values: Mapping[str, float], objects: Sequence[TrackedObject],
                     frames: int, steps: int = 600, engines: Sequence[str] | None = None,
                     measure: Callable[[TrackedObject, Sequence[int], str, str], None] | None = None,
                     rows: np.ndarray | Sequence[int] | None = None) -> Reconstruction:
    """The reconstruction of a video with ``engines`` (default :func:`reader_engines`), and the physics it came from.

    *The physics* (``physics``: the engine counterfactuals are re-simulated with) is the engine whose first run
    (:func:`first_run`) follows the video best: where a body strays from the first engine's, the others' first
    runs are made too, each from the measurements made before the first one's, and a later one is kept where
    :func:`later_engine_wins`. *The record* (the run, its tracks and events) is each engine's whole reconstruction
    in turn until one follows the video closely (:func:`follows_closely`), the nearest kept, an earlier one unless a
    later one is nearer by more than :data:`ENGINE_MARGIN_PX`: the first engine goes on from its first run as it
    would alone, a later one reconstructs with every measurement made by then. Restarts pull either engine's run
    back to the tracks, so the record may be the other engine's: its run is still the one nearest the frames, and
    the physics re-simulates what they did not show.

    Different renderers' videos come from different physics (craft_dsl's own from pymunk or Box2D, the original
    CRAFT videos from its Box2D)."""
    names = list(engines) if engines is not None else list(reader_engines())
    if not names:
        raise ValueError("reconstruct_best needs at least one engine")
    before = _measured(objects) if len(names) > 1 else []
    runs = {0: first_run(model, static_values, objects, frames, steps, names[0], measure, rows)}
    physics = 0
    if runs[0].attempt.first and len(names) > 1:  # a body strays: the others' first runs say which physics it is
        after_first = _measured(objects)
        again = None if measure is None else _reusing(measure, objects, after_first)
        for i in range(1, len(names)):
            if not can_win_later(runs[physics]):
                break  # no later first run can follow the video long enough longer: none is made
            _restore(objects, before)
            runs[i] = first_run(model, static_values, objects, frames, steps, names[i], again, rows)
            if later_engine_wins(runs[physics], runs[i]):
                physics = i
            if not runs[i].attempt.first:
                break
        _restore(objects, after_first)
    # the record: the first engine goes on from its first run as it would alone; a later one reconstructs with
    # every measurement made so far (more exact poses fit its runs closer)
    best = reconstruct(model, static_values, objects, frames, steps, names[0], measure, rows, opening=runs[0])
    reconstructed = 1
    for name in names[1:]:
        if follows_closely(best):
            break
        rec = reconstruct(model, static_values, objects, frames, steps, name, measure, rows)
        reconstructed += 1
        if rec.final_px < best.final_px - ENGINE_MARGIN_PX:
            best = rec
    tried = tuple(n for i, n in enumerate(names) if i in runs or i < reconstructed)
    return replace(best, tried=tried, physics=names[physics])
