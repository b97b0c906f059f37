"""The Box2D engine adapter (PyPI ``box2d`` = pybox2d 2.3.10, the Box2D 2.3 line the original used).

Settings as in the original simulator; pybox2d's compiled
constants already match the original's build (linear slop 0.005, polygon skin 0.01, velocity threshold
1 m/s, time to sleep 0.5 s, sleep tolerances 0.01 m/s and 2 deg/s, max translation 2 m per step):

* one ``b2World.Step(1/60, 8, 3)`` per frame, warm starting, continuous collision (TOI), no sub-stepping,
  sleeping on; gravity (0, -15); no damping;
* every fixture: density 50, friction 0.1, restitution 0.2; Box2D mixes them itself (sqrt / max) and drops
  restitution below a 1 m/s approach speed;
* polygons as ``b2PolygonShape`` (skin 0.01); circles (dynamic circles, static balls) as ``b2CircleShape``
  (pybox2d caps polygons at 16 vertices, the original used 128-gons), with the 128-gons' rolling loss added
  (:data:`ROLLING_DECELERATION`, below); the basket as one open
  ``b2ChainShape`` (its three children are the parts 0-2 of the contact log) plus a sensor polygon on the
  basket's static body (Box2D never pairs two non-dynamic bodies, so the sensor reports dynamic bodies only).

Contact log: a ``b2ContactListener`` records ``BeginContact`` / ``EndContact`` stamped with the frame
counter (completed steps, as the original's callbacks). A contact ``[b, e)`` that begins and ends within
one step (a TOI touch) is stored as ``[b, b + 1)`` so it still yields its Collision. The contact
identity is the (fixture, child) pair, as in the original.

Rolling: the original's "circles" are 128-gons, and they lose speed as they roll, far more than an ideal polygon's
vertex impacts would take (where in Box2D's contact handling it comes from was not traced). Measured in the original
simulator, a circle rolling on the flat ground slows by 0.15-0.3 m/s every second at any speed from 0.75 to 10 m/s,
both sizes, and one rolling at 0.3 m/s stops within 1.5 s, where a true circle rolls on for ever. So after every
step a dynamic circle that touches anything has its spin reduced towards zero by ``3 a dt / r`` (``a`` =
:func:`rolling_deceleration` of its radius ``r``; once friction has shared the loss between spin and motion, a
rolling disc slows by ``a dt``: :data:`SPIN_LOSS_PER_SPEED_LOSS` says why).
``Box2DEngine(rolling_deceleration=(0.0, 0.0))`` gives true circles. Their contacts with statics flicker
as the 128-gons' do (:mod:`~craft_dsl.physics.flicker`; ``flicker=False``: one contact).

128-gons (``circle_sides=128``, the engine ``box2d128``): circles and static balls as the original builds them, one
regular polygon fixture each (first vertex straight below the centre, counter-clockwise), with neither the rolling
loss nor the flicker added: both come from the polygon itself. It needs a Box2D built to take polygons of that many
vertices, as the original's build does (``tools/box2d128/build.sh``; the box2d wheel takes 16). Run from the same
start states, its answers agree with the original's on 97-99.5% of test questions, against 93-96% for true circles.

Replay (see :class:`~craft_dsl.physics.engine.ReplayPlan`): a replayed body is a kinematic body, placed
exactly on its recorded row at the start of every frame and moved at the recorded mean velocity during
it. Box2D creates no contact between two non-dynamic bodies, so replayed bodies touch only dynamically
simulated ones (never statics, the sensor or each other) without any filter. A body activated mid-run
is switched to dynamic (``SetType`` drops its contacts; the ones with active bodies are re-found before
the step, so a contact that persists stays one contact) and given its exact recorded state.
"""

from __future__ import annotations

import math
import operator
import re
import warnings
from collections.abc import Hashable
from dataclasses import replace
from typing import Any, cast

import numpy as np

with warnings.catch_warnings():  # SWIG's builtin types trigger import-time DeprecationWarnings on 3.12+
    warnings.simplefilter("ignore", DeprecationWarning)
    import Box2D

from ..errors import CraftError
from ..world import DENSITY, FRICTION, RESTITUTION, BodySpec, Geometry, Segment, WorldSpec
from .engine import PairKey, RawRun, ReplayPlan
from .flicker import add_flicker
from .recording import BodyState, ContactRecorder, FrameIntervalRecorder, StateRecorder


class Box2DBuildError(CraftError, RuntimeError):
    """The installed Box2D cannot make polygons of as many vertices as asked for (the box2d wheel's cap is 16)."""

    def __init__(self, wanted: int, cap: int) -> None:
        super().__init__(f"the box2d128 engine needs Box2D built to take polygons of {wanted} vertices, as the "
                         f"original CRAFT simulator's build does; the installed one takes {cap}: build it with "
                         "`bash tools/box2d128/build.sh` (it replaces the box2d wheel in this Python; the other "
                         "engines run as before)")
        self._fields = (wanted, cap)

    def __reduce__(self) -> tuple[Any, ...]:  # raised in a worker process, it crosses back pickled
        return (type(self), self._fields)


#: The sides of the original's circles and static balls (regular polygons).
ORIGINAL_CIRCLE_SIDES = 128
#: The basket sensor's category bits in the original (``SENSOR_BASKET``); informative only.
SENSOR_CATEGORY = 0x0042
#: How fast a circle rolling on flat ground slows down (m/s every second) as the original's 128-gons do, by radius:
#: measured 0.22 for the small circles (radius 1 m) and 0.17 for the large ones (2 m), each the mean over launch
#: speeds of 0.75 to 10 m/s (1.5 s of rolling each; the spread between speeds is about 0.03); in between and beyond,
#: linear in the radius (at least 0.05).
ROLLING_DECELERATION = (0.22, 0.17)
#: The spin a rolling disc must lose for its speed to drop by one unit (times 1/radius): friction at the contact
#: point conserves the disc's angular momentum about that point, ``(I + m r^2) w`` = ``(3/2) m r^2 w`` for a uniform
#: disc (``I = m r^2 / 2``). Taking ``dw`` of spin alone removes ``I dw``, a third of what the same drop while
#: rolling would (``(3/2) m r^2 dw``): once friction has shared the loss between spin and motion, the disc rolls
#: ``dw / 3`` slower, ``r dw / 3`` m/s. So a loss of ``a dt`` m/s in a step takes ``3 a dt / r`` of spin.
SPIN_LOSS_PER_SPEED_LOSS = 3.0
#: The numbers of a simulated body's recorded row: x, y, angle, vx, vy, spin, awake (1.0 or 0.0).
_ROW_WIDTH = 7


def rolling_deceleration(radius: float, measured: tuple[float, float] = ROLLING_DECELERATION) -> float:
    """The deceleration (m/s every second) of a circle of ``radius`` rolling on flat ground (``measured``: the
    values at radius 1 and 2 m; (0, 0): true circles, which roll on for ever)."""
    at_1, at_2 = measured
    if at_1 <= 0.0 and at_2 <= 0.0:
        return 0.0
    return max(0.05, at_1 + (at_2 - at_1) * (radius - 1.0))


class _Listener(Box2D.b2ContactListener):
    """Forwards Box2D's begin/end callbacks to a recording run."""

    # Box2D calls PreSolve / PostSolve for every touching contact in every step. The inherited ones are SWIG
    # upcalls to Box2D's empty defaults (a costly round trip that doubled the stepping time); a C builtin that
    # takes the two arguments and does nothing is several times cheaper, with the same (no) effect.
    PreSolve = staticmethod(operator.is_)
    PostSolve = staticmethod(operator.is_)

    def __init__(self, run: _Run) -> None:
        super().__init__()
        self.run = run

    def BeginContact(self, contact: Any) -> None:  # noqa: N802 - Box2D's callback name
        run = self.run
        rec, key = run.route(contact)
        rec.begin(key, run.frame)
        run.touch(rec, key, 1)

    def EndContact(self, contact: Any) -> None:  # noqa: N802 - Box2D's callback name
        run = self.run
        rec, key = run.route(contact)
        rec.end(key, run.frame)
        run.touch(rec, key, -1)


def _native(owner: Any, name: str) -> Any:
    """The SWIG builtin ``name`` (``GetAngle``, ``SetTransform``, ...) of a pybox2d class or object, bound where
    ``owner`` is an object.

    pybox2d wraps each getter and setter in a Python property (``body.angle`` calls ``body._b2Body__GetAngle``),
    and in the per-step loops and contact callbacks that layer costs as much as the stepping itself; the builtin
    gives the same values. pybox2d declares them private (``__GetAngle`` in class ``b2Body``), so they are
    reached by their name-mangled form ``_b2Body__GetAngle``."""
    cls = owner if isinstance(owner, type) else type(owner)
    return getattr(owner, f"_{cls.__name__}__{name}")


# The builtins behind contact.fixtureA / .fixtureB / .childIndexA / .childIndexB and fixture.userData, called
# directly in the contact callbacks.
_fixture_a = _native(Box2D.b2Contact, "GetFixtureA")
_fixture_b = _native(Box2D.b2Contact, "GetFixtureB")
_child_a = _native(Box2D.b2Contact, "GetChildIndexA")
_child_b = _native(Box2D.b2Contact, "GetChildIndexB")
_user_data = _native(Box2D.b2Fixture, "GetUserData")


def _chains(segments: tuple[Segment, ...]) -> list[list[tuple[float, float]]]:
    """Consecutive connected segments as vertex chains (the basket's three edges are one chain)."""
    chains: list[list[tuple[float, float]]] = []
    for a, b in segments:
        if chains and chains[-1][-1] == a:
            chains[-1].append(b)
        else:
            chains.append([a, b])
    return chains


def _body_def(kind: str) -> Any:
    if kind == "dynamic":
        return Box2D.b2BodyDef(type=Box2D.b2_dynamicBody, bullet=False, allowSleep=True, linearDamping=0.0,
                               angularDamping=0.0)
    return Box2D.b2BodyDef(type=Box2D.b2_kinematicBody if kind == "kinematic" else Box2D.b2_staticBody)


#: One body definition of each kind, its position and angle set for each body made (Box2D copies a definition
#: into the body it makes; a fresh definition from keyword arguments cost as much as the rest of a short run).
_BODY_DEFS: dict[str, Any] = {kind: _body_def(kind) for kind in ("static", "kinematic", "dynamic")}


#: The one fixture definition of every collision shape (the world's density, friction and restitution), its shape
#: set for each fixture made (Box2D copies definition and shape into the fixture).
_FIXTURE_DEF = Box2D.b2FixtureDef(density=DENSITY, friction=FRICTION, restitution=RESTITUTION)
#: The Box2D shapes of each geometry (Box2D computes a polygon's centroid and normals when it is made), for up to
#: _MAX_SHAPES geometries (a reader's fitted statics each have their own).
_SHAPES: dict[Geometry, tuple[Any, ...]] = {}
_MAX_SHAPES = 4096


def regular_polygon(radius: float, sides: int) -> list[tuple[float, float]]:
    """The vertices of a regular ``sides``-gon of circumradius ``radius``, as the original builds its circles: the
    first straight below the centre, counter-clockwise."""
    return [(radius * math.cos(-math.pi / 2 + 2 * math.pi * k / sides),
             radius * math.sin(-math.pi / 2 + 2 * math.pi * k / sides)) for k in range(sides)]


def max_polygon_vertices(wanted: int = ORIGINAL_CIRCLE_SIDES) -> int:
    """Whether the installed Box2D takes polygons of ``wanted`` vertices: ``wanted`` if it does, else its own cap
    (the box2d wheel's is 16)."""
    try:
        Box2D.b2PolygonShape(vertices=regular_polygon(1.0, wanted))
    except ValueError as err:
        found = re.search(r"b2_maxPolygonVertices=(\d+)", str(err))
        return int(found.group(1)) if found else 0
    return wanted


def _shapes(geo: Geometry) -> tuple[Any, ...]:
    """The collision shapes of ``geo`` in fixture order: polygons, the circle, the edge chains (made once)."""
    found = _SHAPES.get(geo)
    if found is None:
        shapes: list[Any] = [Box2D.b2PolygonShape(vertices=list(poly)) for poly in geo.polygons]
        if geo.circle_radius is not None:
            shapes.append(Box2D.b2CircleShape(radius=geo.circle_radius))
        shapes.extend(Box2D.b2ChainShape(vertices_chain=chain) for chain in _chains(geo.segments))
        if len(_SHAPES) >= _MAX_SHAPES:
            _SHAPES.clear()
        found = _SHAPES[geo] = tuple(shapes)
    return found


class Box2DEngine:
    """Physics adapter on pybox2d (Box2D 2.3). Parameters are the original's solver settings; ``circle_sides``: circles
    and static balls as regular polygons of that many sides (:func:`regular_polygon`; None: true circles, with the
    rolling loss and flicker given)."""

    name = "box2d"

    def __init__(
        self,
        velocity_iterations: int = 8,
        position_iterations: int = 3,
        warm_starting: bool = True,
        continuous: bool = True,
        sleeping: bool = True,
        rolling_deceleration: tuple[float, float] = ROLLING_DECELERATION,
        flicker: bool = True,
        circle_sides: int | None = None,
    ) -> None:
        if circle_sides is not None:
            cap = max_polygon_vertices(circle_sides)
            if cap < circle_sides:
                raise Box2DBuildError(circle_sides, cap)
        self.velocity_iterations = velocity_iterations
        self.position_iterations = position_iterations
        self.warm_starting = warm_starting
        self.continuous = continuous
        self.sleeping = sleeping
        self.rolling_deceleration = rolling_deceleration
        self.flicker = flicker
        self.circle_sides = circle_sides

    # -- building a world ------------------------------------------------------------------------

    def build_world(
        self, world: WorldSpec, kinematic: frozenset[int] = frozenset()
    ) -> tuple[Any, dict[int, Any]]:
        """A b2World holding ``world`` (bodies in creation order; uids in ``kinematic`` as kinematic bodies)."""
        b2w = Box2D.b2World(gravity=world.gravity, doSleep=self.sleeping)
        b2w.warmStarting = self.warm_starting
        b2w.continuousPhysics = self.continuous
        b2w.subStepping = False
        bodies: dict[int, Any] = {}
        for spec in world.bodies:
            bodies[spec.uid] = self._make_body(b2w, spec, spec.uid in kinematic)
        return b2w, bodies

    def _make_body(self, b2w: Any, spec: BodySpec, kinematic: bool) -> Any:
        kind = "static" if not spec.dynamic else "kinematic" if kinematic else "dynamic"
        defn = _BODY_DEFS[kind]
        defn.position = spec.position
        defn.angle = spec.angle
        body = b2w.CreateBody(defn)
        geo = spec.geometry
        if self.circle_sides is not None and geo.circle_radius is not None:  # one polygon fixture, as the original
            geo = replace(geo, polygons=(*geo.polygons, tuple(regular_polygon(geo.circle_radius, self.circle_sides))),
                          circle_radius=None)
        part = 0
        for shape in _shapes(geo):
            _FIXTURE_DEF.shape = shape
            fixture = body.CreateFixture(_FIXTURE_DEF)
            fixture.userData = (spec.uid, part, False)
            part += shape.childCount
        if geo.sensor is not None:
            sensor = body.CreateFixture(shape=Box2D.b2PolygonShape(vertices=list(geo.sensor)), isSensor=True,
                                        density=0.0, friction=0.2, restitution=0.0, categoryBits=SENSOR_CATEGORY)
            sensor.userData = (spec.uid, 0, True)
        if spec.dynamic and not kinematic:
            body.linearVelocity = spec.velocity
            body.angularVelocity = spec.angular_velocity
        return body

    # -- running -----------------------------------------------------------------------------------

    def run(self, world: WorldSpec, steps: int, replay: ReplayPlan | None = None) -> RawRun:
        return _Run(self, world, steps, replay).execute()

    def run_bare(self, world: WorldSpec, steps: int) -> Any:
        """Step the same world with no listener and no recording (the benchmark's baseline)."""
        b2w, _ = self.build_world(world)
        dt = 1.0 / world.steps_per_second
        step, vi, pi = b2w.Step, self.velocity_iterations, self.position_iterations
        for _ in range(steps):
            step(dt, vi, pi)
        return b2w


class Box2D128Engine(Box2DEngine):
    """Box2D with the original's 128-gon circles and static balls, their rolling loss and flicker their own
    (``box2d128``; needs Box2D built with 128-vertex polygons: ``tools/box2d128/build.sh``)."""

    name = "box2d128"

    def __init__(self, velocity_iterations: int = 8, position_iterations: int = 3) -> None:
        super().__init__(velocity_iterations, position_iterations, rolling_deceleration=(0.0, 0.0), flicker=False,
                         circle_sides=ORIGINAL_CIRCLE_SIDES)


class _Run:
    def __init__(self, engine: Box2DEngine, world: WorldSpec, steps: int, replay: ReplayPlan | None) -> None:
        self.engine = engine
        self.world = world
        self.steps = steps
        self.replay = replay
        self.frame = 0
        self.log = ContactRecorder(FrameIntervalRecorder)
        self.touching: dict[int, int] = {}  # uid -> its touching contacts (sensor overlaps left out)

    def touch(self, rec: FrameIntervalRecorder, key: Hashable, change: int) -> None:
        """Count a contact that starts (+1) or stops (-1) touching for both its bodies, from the recorder and key
        :meth:`route` gave (a sensor overlap is not a touch)."""
        if rec is self.log.contacts:
            uid_a, _, uid_b, _ = cast(PairKey, key)
            touching = self.touching
            touching[uid_a] = touching.get(uid_a, 0) + change
            touching[uid_b] = touching.get(uid_b, 0) + change

    def route(self, contact: Any) -> tuple[FrameIntervalRecorder, Hashable]:
        """The recorder and key of a Box2D contact (its fixtures' tags plus the chain children)."""
        ua, pa, sa = _user_data(_fixture_a(contact))
        ub, pb, sb = _user_data(_fixture_b(contact))
        return self.log.route(ua, pa + _child_a(contact), sa, ub, pb + _child_b(contact), sb)

    def execute(self) -> RawRun:
        """Build the world, step it ``steps`` times (activating, replaying and rolling as due) and record the run."""
        eng, world, steps = self.engine, self.world, self.steps
        rec: StateRecorder[Any] = StateRecorder(world, steps, self.replay)
        self.rec = rec
        b2w, self.bodies = eng.build_world(world, rec.replayed)
        rec.attach(self.bodies)
        first = rec.first
        if self.replay is not None:
            for i, body in rec.active:
                _set_state(body, rec.state(i, first), wake=True)
        b2w.contactListener = _Listener(self)
        self.fps = float(world.steps_per_second)
        self.dt = 1.0 / self.fps
        # Rows of simulated bodies: per body one flat list of _ROW_WIDTH numbers per frame, read through Box2D's own
        # position / velocity vectors (SWIG references into the body, valid for its life), converted to arrays once
        # at the end (rec.rows stay empty, so rec.result keeps these rows).
        self.tracks = [_Track(i, first + 1, body) for i, body in rec.active]
        self.replays = {i: _Replay(body, rec, i) for i, body in rec.kinematic}
        # the circles that lose spin as they roll: (uid, spin loss per step, the body's spin getter and setter)
        self.rollers: list[tuple[int, float, Any, Any]] = []
        for i, body in rec.active:
            self.add_roller(rec.ids[i], body)
        self.find_new_contacts = b2w.contactManager.FindNewContacts
        step, vi, pi, dt = b2w.Step, eng.velocity_iterations, eng.position_iterations, self.dt
        pending = rec.pending
        next_due = pending[0][0] if pending else -1
        for k in range(first, steps):
            self.frame = k
            if k == next_due:
                self.activate_due(k)
                next_due = pending[0][0] if pending else -1
            self.replay_kinematic(k)
            step(dt, vi, pi)
            self.lose_rolling_spin()
            self.record_rows()
        b2w.contactListener = None
        return self.result()

    def add_roller(self, uid: int, body: Any) -> None:
        """Register ``body`` as losing spin while it rolls, if it is a circle with a rolling loss."""
        radius = self.world.body(uid).geometry.circle_radius
        if not radius:
            return
        decel = rolling_deceleration(radius, self.engine.rolling_deceleration)
        if decel > 0.0:
            self.rollers.append((uid, SPIN_LOSS_PER_SPEED_LOSS * decel * self.dt / radius,
                                 _native(body, "GetAngularVelocity"), _native(body, "SetAngularVelocity")))

    def activate_due(self, k: int) -> None:
        """Switch the replayed bodies due at frame ``k`` to dynamic, on their recorded state there."""
        rec = self.rec
        for uid in rec.due(k):
            body = self.bodies[uid]
            body.type = Box2D.b2_dynamicBody  # drops its contacts (EndContact stamped k)
            i = rec.col[uid]
            _set_state(body, rec.state(i, k), wake=True)
            rec.activate(uid, body, k)
            self.tracks.append(_Track(i, k + 1, body))
            self.add_roller(uid, body)
        self.find_new_contacts()  # so this step's Collide sees them again (and continues the contacts)

    def replay_kinematic(self, k: int) -> None:
        """Place each replayed body on its row ``k``, moving at the mean velocity that reaches row ``k + 1``."""
        fps, replays = self.fps, self.replays
        for i, _ in self.rec.kinematic:
            r = replays[i]
            xs, ys, angs = r.xs, r.ys, r.angles
            x0, y0, a0 = xs[k], ys[k], angs[k]
            r.set_transform((x0, y0), a0)
            r.set_velocity(((xs[k + 1] - x0) * fps, (ys[k + 1] - y0) * fps))
            r.set_angular_velocity((angs[k + 1] - a0) * fps)

    def lose_rolling_spin(self) -> None:
        """Take each touching roller's spin loss of one step off its spin (towards zero, never past it)."""
        touching = self.touching
        for uid, loss, get_spin, set_spin in self.rollers:
            if touching.get(uid):
                spin = get_spin()
                if spin > loss:
                    set_spin(spin - loss)
                elif spin < -loss:
                    set_spin(spin + loss)
                elif spin:
                    set_spin(0.0)

    def record_rows(self) -> None:
        """Append each simulated body's row of the step just taken."""
        for t in self.tracks:
            if t.awake():
                p, v = t.p, t.v
                t.buf += (p.x, p.y, t.angle(), v.x, v.y, t.angular_velocity(), 1.0)
                t.asleep = None
            elif t.asleep is not None:  # still asleep: Box2D has not moved it
                t.buf += t.asleep
            else:  # fell asleep in this step (after moving in it) or asleep from the start
                p = t.p
                row = (p.x, p.y, t.angle(), 0.0, 0.0, 0.0, 0.0)  # Box2D zeroes a sleeping body's velocity
                t.buf += row
                t.asleep = row

    def result(self) -> RawRun:
        """The recorded run: the tracks' rows in the recorder's arrays, the contact log (with flicker)."""
        rec, world = self.rec, self.world
        for t in self.tracks:
            if t.buf:
                a = np.fromiter(t.buf, dtype=np.float64, count=len(t.buf)).reshape(-1, _ROW_WIDTH)
                i, r0 = t.col, t.row
                rec.pos[r0:, i] = a[:, 0:2]
                rec.ang[r0:, i] = a[:, 2]
                rec.vel[r0:, i] = a[:, 3:5]
                rec.angv[r0:, i] = a[:, 5]
                rec.awake[r0:, i] = a[:, 6] != 0.0
        raw = rec.result(self.log.log(self.steps))
        if self.engine.flicker:
            circles = [b.uid for b in world.bodies if b.dynamic and b.geometry.circle_radius]
            statics = [b.uid for b in world.bodies if not b.dynamic]
            raw = replace(raw, log=add_flicker(raw.log, raw.trajectory, circles, statics))
        return raw


class _Replay:
    """A replayed body's setters (behind body.transform / .linearVelocity / .angularVelocity) and its recorded
    rows as Python floats (the same values and arithmetic as rec.kinematic_state)."""

    __slots__ = ("set_transform", "set_velocity", "set_angular_velocity", "xs", "ys", "angles")

    def __init__(self, body: Any, rec: StateRecorder[Any], i: int) -> None:
        self.set_transform = _native(body, "SetTransform")
        self.set_velocity = _native(body, "SetLinearVelocity")
        self.set_angular_velocity = _native(body, "SetAngularVelocity")
        self.xs: list[float] = rec.pos[:, i, 0].tolist()
        self.ys: list[float] = rec.pos[:, i, 1].tolist()
        self.angles: list[float] = rec.ang[:, i].tolist()


class _Track:
    """The recorded rows of one simulated body from row ``row`` on, and its cached Box2D accessors."""

    __slots__ = ("col", "row", "awake", "p", "v", "angle", "angular_velocity", "buf", "asleep")

    def __init__(self, col: int, row: int, body: Any) -> None:
        self.col = col
        self.row = row
        self.awake = _native(body, "IsAwake")  # the bound getters behind body.awake / .angle / .angularVelocity
        self.p = body.position  # references to the body's position and velocity (not copies)
        self.v = body.linearVelocity
        self.angle = _native(body, "GetAngle")
        self.angular_velocity = _native(body, "GetAngularVelocity")
        self.buf: list[float] = []
        self.asleep: tuple[float, ...] | None = None  # the last row if it was asleep


def _set_state(body: Any, state: BodyState, wake: bool) -> None:
    """Place ``body`` on a state; ``wake`` for a body switched to dynamic (not for kinematic replays)."""
    position, angle, velocity, angular_velocity = state
    body.transform = (position, angle)
    body.linearVelocity = velocity
    body.angularVelocity = angular_velocity
    if wake:
        body.awake = True
