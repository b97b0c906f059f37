"""Contacts and basket entries from tracks and scene geometry, and contact logs from perceived events.

When a model gives tracks but no events, the contact log of the run is rebuilt geometrically and turned into
events by the simulator's own rules (:func:`craft_dsl.physics.events_from_log`: a contact of at most 20 steps is
one Collision, a longer one a TouchStart and, if it ends, a TouchEnd; EnterBasket at the first frame of each
overlap with the basket's inner region).

Geometry. Every body gets its collision shapes (:mod:`craft_dsl.world`: cubes, truncated triangles, circles,
platforms, ramps, static balls, the basket's three edges; polygons and edges with the engine's 0.01 m skin).
Thresholds, in metres:

* two shapes *touch* when they are closer than :data:`CONTACT_TOLERANCE` (plus three times the position noise
  left in a smoothed noisy track): each shape is inflated by half of it;
* a body is *in the basket* when its (uninflated) shape overlaps the basket's sensor polygon;
* a pair touches *in frame k* (the step from row k to row k + 1, the engine's convention) when it touches in the
  state of row k, of row k + 1, or in the state each body would reach from row k in free flight
  (``x + v h + c g h^2``, the engine's sub-stepped free flight) if it is within :data:`NEAR_TOLERANCE` at row
  k + 1. The start state keeps a contact that ends inside the frame, as the engine does; the free-flight state
  catches bounces that begin and end inside one frame (the observed end state is already apart, the prediction
  runs into the other shape).

Static-static pairs never touch (as in the engine). Measured on exact tracks of 20 scenes x 5 seeds the derived
events match the simulator's (same type, objects and step) for the share reported in ``docs/perception.md``.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymunk
from pymunk._chipmunk import ffi as _ffi
from pymunk._chipmunk import lib as _lib

from ..physics.engine import ContactLog, Interval, PairKey, SensorKey, coalesce, pair_key
from ..vocabulary import COLLISION, COLLISION_MAX_STEPS, ENTER_BASKET, TOUCH_END, TOUCH_START
from ..world import STEPS_PER_SECOND, BodySpec, WorldSpec
from .tracks import INTEGRATOR_C

#: Shapes closer than this (metres) touch (the engine's contacts keep a 0.005 m slop; resting bodies overlap).
CONTACT_TOLERANCE = 0.0
#: A contact seen only in the free-flight prediction counts when the pair is this close (metres) at the frame's
#: end: a bounce leaves at a fifth of the impact speed, so at most this far within a frame below 18 m/s; farther
#: away, the prediction went through something else (e.g. a basket's floor into the ground below it).
NEAR_TOLERANCE = 0.06
#: The engine's skin on polygons and edges (metres).
SKIN = 0.01

_CONTACT = 0b01
_SENSOR = 0b10
_FILTER_CONTACT = pymunk.ShapeFilter(categories=_CONTACT, mask=_CONTACT)
_FILTER_SENSOR = pymunk.ShapeFilter(categories=_SENSOR, mask=_SENSOR)


@dataclass(frozen=True)
class RowStates:
    """Per-row states of the bodies of a world (columns in world order): positions [T+1, N, 2], angles [T+1, N],
    velocities [T+1, N, 2], angular velocities [T+1, N]."""

    positions: np.ndarray
    angles: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray

    @property
    def steps(self) -> int:
        return int(self.positions.shape[0]) - 1


class GeometryProbe:
    """The bodies of a world as pymunk shapes that can be placed anywhere and asked what they touch.

    Placing and querying call Chipmunk directly (the calls pymunk's ``body.position``, ``body.angle``,
    ``reindex_shapes_for_body`` and ``shape_query`` make, without building a Python object for every hit and its
    contact points): deriving a video's events places the bodies at every row and queries every shape there."""

    def __init__(self, world: WorldSpec, tolerance: float = CONTACT_TOLERANCE) -> None:
        self.world = world
        self.space = pymunk.Space()
        self.tags: dict[pymunk.Shape, tuple[int, int]] = {}
        self.contact_shapes: dict[int, list[pymunk.Shape]] = {}
        self.plain_shapes: dict[int, list[pymunk.Shape]] = {}
        self.bodies: dict[int, pymunk.Body] = {}
        self.sensor_owner: dict[pymunk.Shape, int] = {}
        self.dynamic = [b.uid for b in world.bodies if b.dynamic]
        inflate = tolerance / 2
        for spec in world.bodies:
            kind = pymunk.Body.KINEMATIC if spec.dynamic else pymunk.Body.STATIC
            body = pymunk.Body(body_type=kind)
            body.position = spec.position
            body.angle = spec.angle
            shapes = list(self._shapes(body, spec, inflate, _FILTER_CONTACT))
            self.space.add(body, *shapes)
            for part, shape in enumerate(shapes):
                self.tags[shape] = (spec.uid, part)
            self.contact_shapes[spec.uid] = shapes
            self.bodies[spec.uid] = body
            if spec.dynamic:
                plain = list(self._shapes(body, spec, 0.0, _FILTER_SENSOR))
                self.space.add(*plain)
                self.plain_shapes[spec.uid] = plain
            if spec.geometry.sensor is not None:
                sensor = pymunk.Poly(body, list(spec.geometry.sensor))
                sensor.filter = _FILTER_SENSOR
                self.space.add(sensor)
                self.sensor_owner[sensor] = spec.uid
        # the Chipmunk handles of the same objects, and each shape's tag and sensor owner by its address
        self._space = self.space._space
        self._placed = [(uid, self.bodies[uid]._body) for uid in self.dynamic]
        self._queries = {uid: [(s._shape, self.tags[s]) for s in shapes] for uid, shapes in self.contact_shapes.items()}
        self._plain = {uid: [s._shape for s in shapes] for uid, shapes in self.plain_shapes.items()}
        self._tag_at = {_address(s._shape): tag for s, tag in self.tags.items()}
        self._owner_at = {_address(s._shape): uid for s, uid in self.sensor_owner.items()}
        self._hits: list[tuple[int, float]] = []  # (address, deepest contact) of each shape the last query met
        self._collect = _ffi.callback("void(cpShape *, cpContactPointSet *, void *)", self._hit)

    def _hit(self, shape: Any, points: Any, _data: Any) -> None:
        depth = 0.0
        for i in range(points.count):
            depth = max(depth, abs(points.points[i].distance))
        self._hits.append((int(_ffi.cast("uintptr_t", shape)), depth))

    def _query(self, shape: Any) -> list[tuple[int, float]]:
        """(address, deepest contact, metres) of every shape overlapping ``shape`` (a Chipmunk handle)."""
        self._hits = []
        _lib.cpSpaceShapeQuery(self._space, shape, self._collect, _ffi.NULL)
        return self._hits

    @staticmethod
    def _shapes(body: pymunk.Body, spec: BodySpec, inflate: float, flt: pymunk.ShapeFilter) -> Iterator[pymunk.Shape]:
        geo = spec.geometry
        shape: pymunk.Shape
        for poly in geo.polygons:
            shape = pymunk.Poly(body, list(poly), radius=SKIN + inflate)
            shape.filter = flt
            yield shape
        if geo.circle_radius is not None:
            shape = pymunk.Circle(body, geo.circle_radius + inflate)
            shape.filter = flt
            yield shape
        for a, b in geo.segments:
            shape = pymunk.Segment(body, a, b, geo.segment_radius + inflate)
            shape.filter = flt
            yield shape

    def place(self, positions: np.ndarray, angles: np.ndarray, columns: Mapping[int, int],
              uids: Sequence[int] | None = None) -> None:
        """Move every dynamic body (or only the dynamic bodies ``uids``, the others staying where they were) to row
        values ``positions`` [N, 2], ``angles`` [N] (``columns``: uid -> col)."""
        set_position, set_angle, reindex, space = (_lib.cpBodySetPosition, _lib.cpBodySetAngle,
                                                   _lib.cpSpaceReindexShapesForBody, self._space)
        placed = self._placed if uids is None else [(uid, self.bodies[uid]._body) for uid in uids]
        for uid, body in placed:
            i = columns[uid]
            set_position(body, (float(positions[i, 0]), float(positions[i, 1])))
            set_angle(body, float(angles[i]))
            reindex(space, body)

    def touching(self, uids: Sequence[int] | None = None) -> set[PairKey]:
        """Every touching shape pair involving a dynamic body (or one of ``uids``), in the current placement."""
        out: set[PairKey] = set()
        tag_at = self._tag_at
        for uid in self.dynamic if uids is None else uids:
            for shape, (ua, pa) in self._queries[uid]:
                for address, _depth in self._query(shape):
                    ub, pb = tag_at[address]
                    if ub != ua:
                        out.add(pair_key(ua, pa, ub, pb))
        return out

    def overlap_depths(self, uids: Sequence[int]) -> np.ndarray:
        """How deep (metres, 0 where apart or touching) each body of ``uids`` overlaps any other body, in the
        current placement (the shapes as the probe's tolerance inflates them)."""
        depth = np.zeros(len(uids))
        tag_at = self._tag_at
        for i, uid in enumerate(uids):
            for shape, _tag in self._queries[uid]:
                for address, deepest in self._query(shape):  # a penetration (pymunk signs it by the pair's order)
                    if tag_at[address][0] != uid:
                        depth[i] = max(depth[i], deepest)
        return depth

    def in_sensor(self) -> set[SensorKey]:
        """Every (basket, body) overlap in the current placement."""
        out: set[SensorKey] = set()
        owner_at = self._owner_at
        for uid in self.dynamic:
            for shape in self._plain[uid]:
                for address, _depth in self._query(shape):
                    owner = owner_at.get(address)
                    if owner is not None:
                        out.add((owner, uid))
        return out


def _address(handle: Any) -> int:
    return int(_ffi.cast("uintptr_t", handle))


def _free_flight(states: RowStates, row: int, gravity: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    h = 1.0 / STEPS_PER_SECOND
    g = np.asarray(gravity)
    pos = states.positions[row] + states.velocities[row] * h + INTEGRATOR_C * g * h * h
    ang = states.angles[row] + states.angular_velocities[row] * h
    return pos, ang


def _row(states: RowStates, row: int) -> tuple[np.ndarray, np.ndarray]:
    return states.positions[row], states.angles[row]


def _intervals(frames_by_key: Mapping[object, list[int]]) -> dict[object, tuple[Interval, ...]]:
    return {key: coalesce((f, f + 1) for f in frames) for key, frames in sorted(frames_by_key.items()) if frames}


def _same_samples(states: RowStates, k: int, cols: list[int]) -> bool:
    """Whether frame k is sampled at exactly the states of frame k - 1 (nothing moved: rows k-1, k, k+1 equal)."""
    if k < 1:
        return False
    p, a, v, w = states.positions, states.angles, states.velocities, states.angular_velocities
    return (np.array_equal(p[k + 1, cols], p[k, cols]) and np.array_equal(p[k, cols], p[k - 1, cols])
            and np.array_equal(a[k + 1, cols], a[k, cols]) and np.array_equal(a[k, cols], a[k - 1, cols])
            and np.array_equal(v[k, cols], v[k - 1, cols]) and np.array_equal(w[k, cols], w[k - 1, cols]))


def derive_log(world: WorldSpec, states: RowStates, tolerance: float = CONTACT_TOLERANCE) -> ContactLog:
    """The contact log of a run rebuilt from its per-row states (see the module docstring)."""
    probe = GeometryProbe(world, tolerance)
    near = GeometryProbe(world, NEAR_TOLERANCE)
    columns = {b.uid: i for i, b in enumerate(world.bodies)}
    dyn_cols = [columns[u] for u in probe.dynamic]
    steps = states.steps
    contacts: dict[PairKey, list[int]] = {}
    sensors: dict[SensorKey, list[int]] = {}
    previous: tuple[set[PairKey], set[SensorKey]] | None = None
    at_row: tuple[int, set[PairKey]] | None = None  # the pairs touching at the last row placed: the next frame's start
    for k in range(steps):
        if previous is not None and _same_samples(states, k, dyn_cols):
            touching, inside = previous
        else:
            if at_row is not None and at_row[0] == k:
                touching = set(at_row[1])
            else:
                probe.place(*_row(states, k), columns)
                touching = probe.touching()
            probe.place(*_row(states, k + 1), columns)
            ends = probe.touching()
            at_row = (k + 1, ends)
            touching |= ends
            near.place(*_row(states, k + 1), columns)
            close = near.touching()
            probe.place(*_free_flight(states, k, world.gravity), columns)
            touching |= probe.touching() & close
            probe.place(*_row(states, k + 1), columns)
            inside = probe.in_sensor()
        for key in touching:
            contacts.setdefault(key, []).append(k)
        for skey in inside:
            sensors.setdefault(skey, []).append(k)
        previous = (touching, inside)
    return ContactLog(steps, _intervals(contacts), _intervals(sensors))  # type: ignore[arg-type]


# -- perceived events -> contact log ------------------------------------------------------------------------


@dataclass(frozen=True)
class StepEvent:
    """A perceived event on the step scale: canonical type, objects, step, and its index in the scene."""

    type: str
    objects: tuple[int, ...]
    step: int
    index: int


class _PairGeometry:
    """Touching / in-basket tests of one pair at one frame, when a world and row states are known."""

    def __init__(self, world: WorldSpec, states: RowStates, tolerance: float) -> None:
        self.probe = GeometryProbe(world, tolerance)
        self.states = states
        self.world = world
        self.columns = {b.uid: i for i, b in enumerate(world.bodies)}
        self._found: dict[tuple[int, int, int], frozenset[PairKey]] = {}

    def _parts(self, a: int, b: int, samples: Sequence[tuple[np.ndarray, np.ndarray]]) -> frozenset[PairKey]:
        mover = a if a in self.probe.plain_shapes else b
        moved = [uid for uid in (a, b) if uid in self.probe.plain_shapes]  # only the pair's own contacts are kept
        found: set[PairKey] = set()
        for pos, ang in samples:
            self.probe.place(pos, ang, self.columns, moved)
            found |= {key for key in self.probe.touching([mover]) if {key[0], key[2]} == {a, b}}
        return frozenset(found)

    def touching_parts(self, a: int, b: int, frame: int) -> frozenset[PairKey]:
        """The pair's touching parts in ``frame``: at its end, or in the free-flight prediction (a brief contact's
        end is estimated without the start-of-frame state: a bounce separates at once). Kept per (pair, frame): a
        pair's contacts are looked up again for each of its events near that frame."""
        if frame >= self.states.steps:
            return frozenset()
        key = (a, b, frame)
        found = self._found.get(key)
        if found is None:
            found = self._parts(a, b, [_row(self.states, frame + 1),
                                       _free_flight(self.states, frame, self.world.gravity)])
            self._found[key] = found
        return found

    def inside(self, basket: int, body: int, frame: int) -> bool:
        if frame >= self.states.steps:
            return False
        self.probe.place(self.states.positions[frame + 1], self.states.angles[frame + 1], self.columns)
        return (basket, body) in self.probe.in_sensor()


def log_from_events(events: Sequence[StepEvent], steps: int, basket_id: int, world: WorldSpec | None = None,
                    states: RowStates | None = None, tolerance: float = CONTACT_TOLERANCE) -> ContactLog:
    """The contact log that perceived events imply, for re-simulating counterfactuals against them.

    Collision at s: ``[s, e)`` where e is the first frame after s in which the pair no longer touches (geometry;
    at most s + 20, so that it stays one Collision), s + 1 without geometry. TouchStart at s: up to the pair's
    next TouchEnd, else to the end. A TouchEnd without a TouchStart: the 21 frames before it. EnterBasket at s:
    up to the first frame the body is out of the basket region (geometry), else to the pair's next EnterBasket
    or the end. The basket edge of a basket contact is the one touching at s (geometry), else edge 0.
    """
    geometry = _PairGeometry(world, states, tolerance) if world is not None and states is not None else None
    uids = {b.uid for b in world.bodies} if world is not None else None
    contacts: dict[PairKey, list[Interval]] = {}
    sensors: dict[SensorKey, list[Interval]] = {}
    ordered = sorted(events, key=lambda e: (e.step, e.index))
    open_touch: dict[tuple[int, int], list[tuple[int, PairKey]]] = {}

    def in_world(*objects: int) -> bool:
        """Whether the world has these objects (one left out of the physics has no body: no contact, no shape)."""
        return uids is None or all(o in uids for o in objects)

    def key_for(a: int, b: int, step: int) -> PairKey:
        if geometry is not None and uids is not None and a in uids and b in uids:
            parts = sorted(geometry.touching_parts(a, b, max(step, 0)))
            if parts:
                return parts[0]
        return pair_key(a, 0, b, 0)

    def next_begin(e: StepEvent) -> int:
        """The step of the pair's next contact event: a contact must end before the next one begins."""
        later = [f.step for f in ordered if f.step > e.step and set(f.objects) == set(e.objects)
                 and f.type in (COLLISION, TOUCH_START)]
        return min(later, default=steps + 1)

    for e in ordered:
        if len(e.objects) != 2 or not in_world(*e.objects):
            continue  # (a body left out of the physics has no contacts to replay)
        a, b = e.objects
        pair = (max(a, b), min(a, b))
        if e.type == COLLISION:
            key = key_for(a, b, e.step)
            end = e.step + 1
            if geometry is not None:
                end = e.step + COLLISION_MAX_STEPS
                for f in range(e.step + 1, e.step + COLLISION_MAX_STEPS):
                    if key not in geometry.touching_parts(a, b, f):
                        end = f
                        break
            end = max(e.step + 1, min(end, next_begin(e) - 1, steps))
            contacts.setdefault(key, []).append((e.step, end))
        elif e.type == TOUCH_START:
            open_touch.setdefault(pair, []).append((e.step, key_for(a, b, e.step)))
        elif e.type == TOUCH_END:
            opened = open_touch.get(pair)
            if opened:
                ending = key_for(a, b, e.step - 1)
                match = next((o for o in opened if o[1] == ending), opened[0])
                opened.remove(match)
                start, key = match
            else:
                start = max(0, e.step - COLLISION_MAX_STEPS - 1)
                key = key_for(a, b, start)
            contacts.setdefault(key, []).append((start, e.step))
        elif e.type == ENTER_BASKET:
            body = b if a == basket_id else a
            sensors.setdefault((basket_id, body), []).append((e.step, -1))
    for opened in open_touch.values():
        for start, key in opened:
            contacts.setdefault(key, []).append((start, steps))
    closed_sensors: dict[SensorKey, list[Interval]] = {}
    for (basket, body), ivs in sensors.items():
        starts = sorted(s for s, _ in ivs)
        out = []
        for i, s in enumerate(starts):
            limit = starts[i + 1] if i + 1 < len(starts) else steps
            end = limit
            if geometry is not None and in_world(basket, body):
                for f in range(s + 1, limit):
                    if not geometry.inside(basket, body, f):
                        end = f
                        break
            out.append((s, max(end, s + 1)))
        closed_sensors[(basket, body)] = out
    return ContactLog(steps, {k: coalesce(v) for k, v in sorted(contacts.items())},
                      {k: coalesce(v) for k, v in sorted(closed_sensors.items())})


def derived_event_tolerance(sigma_px: float, metres_per_px: float, window: int) -> float:
    """Contact tolerance for tracks with position noise ``sigma_px`` smoothed over ``window`` frames."""
    if sigma_px <= 0:
        return CONTACT_TOLERANCE
    return CONTACT_TOLERANCE + 3.0 * sigma_px * metres_per_px / np.sqrt(max(window, 1) / 2.0)


