"""The pymunk 7 (Chipmunk2D) engine adapter.

Box2D behaviour of the original simulator, emulated:

* friction 0.1 on every contact (each shape gets sqrt(0.1), Chipmunk multiplies); restitution 0.2 applied
  only when a contact begins with a normal approach speed above 1 m/s (Box2D's velocity threshold), else 0;
* polygons and basket edges carry a 0.01 m radius like Box2D's skin; circles are pymunk circles
  (``circle_sides=128`` builds the original's 128-gons instead; docs/original.md measures both);
* collision slop 0.005 m; overlap is resolved with Chipmunk's bias pseudo-velocities, which are not kept
  as real velocity, so initial overlaps are pushed out without launching bodies (20% of an overlap per frame;
  Box2D's three position iterations push out about 49%: ``collision_bias=0.8**180``);
* several sub-steps per 1/60-s frame stand in for Box2D's continuous collision (no tunnelling through
  the 0.01-m basket walls at ~50 m/s);
* sleeping after 0.5 s below 0.01 m/s; a sleeping body reports zero velocity.

Replay (see :class:`~craft_dsl.physics.engine.ReplayPlan`): a replayed body is kinematic, placed exactly
on its recorded row at the start of every frame and moved at the recorded mean velocity during it; its
shapes collide only with dynamically simulated bodies (never with statics, the sensor or other replays).
"""

from __future__ import annotations

import math
from typing import Any

import pymunk
from pymunk._chipmunk import lib as _lib

from ..world import FRICTION, RESTITUTION, RESTITUTION_THRESHOLD, BodySpec, WorldSpec, regular_polygon
from .engine import RawRun, ReplayPlan
from .recording import BodyState, ContactRecorder, ShapeTag, StateRecorder, SubstepIntervalRecorder

_CAT_STATIC = 0b001
_CAT_DYNAMIC = 0b010
_CAT_REPLAY = 0b100
_FILTER_STATIC = pymunk.ShapeFilter(categories=_CAT_STATIC, mask=_CAT_DYNAMIC)
_FILTER_DYNAMIC = pymunk.ShapeFilter(categories=_CAT_DYNAMIC, mask=_CAT_STATIC | _CAT_DYNAMIC | _CAT_REPLAY)
_FILTER_REPLAY = pymunk.ShapeFilter(categories=_CAT_REPLAY, mask=_CAT_DYNAMIC)

_SHAPE_FRICTION = math.sqrt(FRICTION)


class PymunkEngine:
    """Physics adapter on pymunk 7. Parameters are the emulation's tuning knobs."""

    name = "pymunk"

    def __init__(
        self,
        substeps: int = 8,
        iterations: int = 10,
        collision_slop: float = 0.005,
        collision_bias: float = (1.0 - 0.2) ** 60,
        polygon_radius: float = 0.01,
        sleep_time: float = 0.5,
        idle_speed: float = 0.01,
        max_move: float = 0.03,
        max_substeps: int = 32,
        circle_sides: int = 0,
    ) -> None:
        self.substeps = substeps
        self.circle_sides = circle_sides
        self.max_move = max_move
        self.max_substeps = max_substeps
        self.iterations = iterations
        self.collision_slop = collision_slop
        self.collision_bias = collision_bias
        self.polygon_radius = polygon_radius
        self.sleep_time = sleep_time
        self.idle_speed = idle_speed

    # -- building a space ------------------------------------------------------------------------

    def build_space(self, world: WorldSpec) -> tuple[pymunk.Space, dict[int, pymunk.Body], dict[Any, ShapeTag]]:
        """A pymunk space holding ``world`` (all dynamic bodies dynamic), with no callbacks."""
        space = pymunk.Space()
        space.gravity = world.gravity
        space.iterations = self.iterations
        space.collision_slop = self.collision_slop
        space.collision_bias = self.collision_bias
        space.damping = 1.0
        if self.sleep_time > 0:
            space.sleep_time_threshold = self.sleep_time
            space.idle_speed_threshold = self.idle_speed
        bodies: dict[int, pymunk.Body] = {}
        infos: dict[Any, ShapeTag] = {}
        for spec in world.bodies:
            body, shapes = self._make_body(spec)
            space.add(body, *shapes)
            bodies[spec.uid] = body
            for part, shape in enumerate(shapes):
                infos[shape] = ShapeTag(spec.uid, part, shape.sensor)
        return space, bodies, infos

    def _make_body(self, spec: BodySpec) -> tuple[pymunk.Body, list[pymunk.Shape]]:
        body = pymunk.Body(body_type=pymunk.Body.DYNAMIC if spec.dynamic else pymunk.Body.STATIC)
        geo = spec.geometry
        shapes: list[pymunk.Shape] = []
        for poly in geo.polygons:
            shapes.append(pymunk.Poly(body, list(poly), radius=self.polygon_radius))
        if geo.circle_radius is not None and self.circle_sides:
            shapes.append(pymunk.Poly(body, list(regular_polygon(geo.circle_radius, self.circle_sides)),
                                      radius=self.polygon_radius))
        elif geo.circle_radius is not None:
            shapes.append(pymunk.Circle(body, geo.circle_radius))
        for a, b in geo.segments:
            shapes.append(pymunk.Segment(body, a, b, geo.segment_radius))
        # the Chipmunk setters pymunk's properties call, in the same order, without their Python wrappers (a
        # reconstruction builds hundreds of spaces a video)
        shape_filter = _FILTER_DYNAMIC if spec.dynamic else _FILTER_STATIC
        for shape in shapes:
            h = shape._shape
            _lib.cpShapeSetFriction(h, _SHAPE_FRICTION)
            _lib.cpShapeSetElasticity(h, 0.0)
            if spec.dynamic:
                _lib.cpShapeSetDensity(h, 50.0)
            _lib.cpShapeSetFilter(h, shape_filter)
        if geo.sensor is not None:
            sensor = pymunk.Poly(body, list(geo.sensor))
            sensor.sensor = True
            sensor.filter = _FILTER_STATIC
            shapes.append(sensor)
        hb = body._body
        _lib.cpBodySetPosition(hb, spec.position)
        _lib.cpBodySetAngle(hb, spec.angle)
        if spec.dynamic:
            _lib.cpBodySetVelocity(hb, spec.velocity)
            _lib.cpBodySetAngularVelocity(hb, spec.angular_velocity)
        return body, shapes

    def substeps_for(self, max_speed_sq: float, fps: float) -> int:
        """Sub-steps for a frame whose fastest dynamic body moves at sqrt(max_speed_sq) m/s: at least
        ``substeps``, more so that no body moves more than ``max_move`` per sub-step (without CCD, a
        deeper penetration of a basket wall would reach the sensor 0.04 m inside it)."""
        need = math.ceil(math.sqrt(max_speed_sq) / fps / self.max_move)
        return min(self.max_substeps, max(self.substeps, need))

    # -- running -----------------------------------------------------------------------------------

    def run(self, world: WorldSpec, steps: int, replay: ReplayPlan | None = None) -> RawRun:
        return _Run(self, world, steps, replay).execute()

    def run_bare(self, world: WorldSpec, steps: int) -> pymunk.Space:
        """Step the same space with no callbacks and no recording (the benchmarks' floor: Chipmunk's step called
        directly, as :meth:`run` does)."""
        space, bodies, _ = self.build_space(world)
        fps = float(world.steps_per_second)
        handles = [b._body for b in bodies.values() if b.body_type == pymunk.Body.DYNAMIC]
        get_vel = _lib.cpBodyGetVelocity
        vmax2 = max((v[0] ** 2 + v[1] ** 2 for v in (b.velocity for b in world.bodies if b.dynamic)), default=0.0)
        c_step, c_space = _lib.cpSpaceStep, space._space
        for _ in range(steps):
            n = self.substeps_for(vmax2, fps)
            dt = 1.0 / fps / n
            for _ in range(n):
                c_step(c_space, dt)
            vmax2 = 0.0
            for h in handles:
                v = get_vel(h)
                vmax2 = max(vmax2, v.x * v.x + v.y * v.y)
        return space


class _Run:
    def __init__(self, engine: PymunkEngine, world: WorldSpec, steps: int, replay: ReplayPlan | None) -> None:
        self.engine = engine
        self.world = world
        self.steps = steps
        self.replay = replay
        self.frame = 0
        self.substep = 0
        self.stepping = False
        self.log = ContactRecorder(SubstepIntervalRecorder)

    # Callbacks --------------------------------------------------------------------------------------

    def _begin(self, arb: pymunk.Arbiter, space: pymunk.Space, data: Any) -> None:
        if not self.stepping:
            return
        sa, sb = arb.shapes
        ia, ib = self.infos[sa], self.infos[sb]
        rec, key = self.log.route(*ia, *ib)
        rec.begin(key, self.frame)
        if ia.sensor or ib.sensor:
            return
        # Box2D's restitution threshold: bounce only on an approach faster than 1 m/s. (The Chipmunk calls
        # behind pymunk's arb.normal, arb.contact_point_set, body.velocity_at_world_point and arb.restitution,
        # with the same arithmetic, without building their Python objects.)
        ba, bb = sa.body, sb.body
        assert ba is not None and bb is not None
        h, ha, hb = arb._arbiter, ba._body, bb._body
        n = _lib.cpArbiterGetNormal(h)
        nx, ny = n.x, n.y
        points = _lib.cpArbiterGetContactPointSet(h)
        velocity_at = _lib.cpBodyGetVelocityAtWorldPoint
        approach = 0.0
        for i in range(points.count):
            pa = points.points[i].pointA
            p = (pa.x, pa.y)
            vb, va = velocity_at(hb, p), velocity_at(ha, p)
            dvx, dvy = vb.x - va.x, vb.y - va.y
            approach = max(approach, -(dvx * nx + dvy * ny))
        _lib.cpArbiterSetRestitution(h, RESTITUTION if approach > RESTITUTION_THRESHOLD else 0.0)

    def _separate(self, arb: pymunk.Arbiter, space: pymunk.Space, data: Any) -> None:
        if not self.stepping or arb.is_removal:
            return
        sa, sb = arb.shapes
        rec, key = self.log.route(*self.infos[sa], *self.infos[sb])
        rec.separate(key, self.frame, self.substep)

    # Main loop --------------------------------------------------------------------------------------

    def execute(self) -> RawRun:
        eng, world, steps = self.engine, self.world, self.steps
        space, bodies, self.infos = eng.build_space(world)
        space.on_collision(None, None, begin=self._begin, separate=self._separate)
        rec: StateRecorder[pymunk.Body] = StateRecorder(world, steps, self.replay)
        rec.attach(bodies)
        first = rec.first
        for _, body in rec.kinematic:
            body.body_type = pymunk.Body.KINEMATIC
            for shape in body.shapes:
                shape.filter = _FILTER_REPLAY
        if self.replay is not None:
            for i, body in rec.active:
                _set_state(body, rec.state(i, first))

        fps = float(world.steps_per_second)
        active, rows = rec.active, rec.rows
        zero = (0.0, 0.0)
        get_pos, get_angle, get_vel = _lib.cpBodyGetPosition, _lib.cpBodyGetAngle, _lib.cpBodyGetVelocity
        get_angvel, is_sleeping = _lib.cpBodyGetAngularVelocity, _lib.cpBodyIsSleeping
        vel = rec.vel
        vmax2 = max((float(vel[first, i, 0] ** 2 + vel[first, i, 1] ** 2) for i, _ in active), default=0.0)
        # Chipmunk's step called directly: pymunk's Space.step wrapper only adds bookkeeping for shapes added or
        # removed inside callbacks (none here), and costs as much as a small world's step.
        c_step, c_space = _lib.cpSpaceStep, space._space
        kinematic = _KinematicRows(rec, fps)
        pending = rec.pending
        # substeps_for(), inlined: the same arithmetic
        sqrt, ceil, max_move = math.sqrt, math.ceil, eng.max_move
        min_sub, max_sub = eng.substeps, eng.max_substeps
        def recorders() -> list[tuple[Any, ...]]:
            """Each active body's Chipmunk handle and its rows' appends (looked up once, not every frame)."""
            return [(body._body, *(row.append for row in rows[i][1:])) for i, body in active]

        recording = recorders()
        self.stepping = True
        for k in range(first, steps):
            self.frame = k
            if pending and pending[0][0] == k:
                for uid in rec.due(k):
                    body = bodies[uid]
                    body.body_type = pymunk.Body.DYNAMIC
                    for shape in body.shapes:
                        shape.filter = _FILTER_DYNAMIC
                    _set_state(body, rec.state(rec.col[uid], k))
                    rec.activate(uid, body, k)
                kinematic = _KinematicRows(rec, fps)
                recording = recorders()
            if kinematic.rows:
                kinematic.place(k)
            need = ceil(sqrt(vmax2) / fps / max_move)
            at_least = min_sub if need < min_sub else need
            n_sub = max_sub if at_least > max_sub else at_least
            dt = 1.0 / fps / n_sub
            # the separate callback only asks whether a sub-step is the frame's first (see _separate)
            self.substep = 0
            c_step(c_space, dt)
            self.substep = 1
            for _ in range(n_sub - 1):
                c_step(c_space, dt)
            vmax2 = 0.0
            for h, add_p, add_a, add_v, add_w, add_aw in recording:
                # Direct Chipmunk getters: the recording is the hot loop of a run.
                p = get_pos(h)
                add_p((p.x, p.y))
                add_a(get_angle(h))
                if is_sleeping(h):  # Box2D zeroes a sleeping body's velocity
                    add_v(zero)
                    add_w(0.0)
                    add_aw(False)
                else:
                    v = get_vel(h)
                    vx, vy = v.x, v.y
                    add_v((vx, vy))
                    speed2 = vx * vx + vy * vy
                    if speed2 > vmax2:
                        vmax2 = speed2
                    add_w(get_angvel(h))
                    add_aw(True)
        self.stepping = False
        return rec.result(self.log.log(steps))


def _set_state(body: pymunk.Body, state: BodyState) -> None:
    """Place ``body`` in ``state`` (the Chipmunk setters pymunk's properties call, in the same order)."""
    position, angle, velocity, angular_velocity = state
    h = body._body
    _lib.cpBodySetPosition(h, position)
    _lib.cpBodySetAngle(h, angle)
    _lib.cpBodySetVelocity(h, velocity)
    _lib.cpBodySetAngularVelocity(h, angular_velocity)


class _KinematicRows:
    """The replayed bodies' recorded rows as Python floats, placed frame by frame.

    Frame ``k`` puts each replayed body on row ``k`` moving at the mean velocity that reaches row ``k + 1``:
    the same values, in the same order of Chipmunk calls, as ``_set_state(body, rec.kinematic_state(...))``,
    without converting numpy scalars every frame."""

    def __init__(self, rec: StateRecorder[pymunk.Body], fps: float) -> None:
        self.fps = fps
        self.rows = [
            (body._body, rec.pos[:, i, 0].tolist(), rec.pos[:, i, 1].tolist(), rec.ang[:, i].tolist())
            for i, body in rec.kinematic
        ]

    def place(self, k: int) -> None:
        fps = self.fps
        set_pos, set_angle = _lib.cpBodySetPosition, _lib.cpBodySetAngle
        set_vel, set_angvel = _lib.cpBodySetVelocity, _lib.cpBodySetAngularVelocity
        for h, xs, ys, angles in self.rows:
            x0, y0, a0 = xs[k], ys[k], angles[k]
            set_pos(h, (x0, y0))
            set_angle(h, a0)
            set_vel(h, ((xs[k + 1] - x0) * fps, (ys[k + 1] - y0) * fps))
            set_angvel(h, (angles[k + 1] - a0) * fps)
