"""The Box2D engine adapter (PyPI ``box2d`` = pybox2d 2.3.10, the Box2D 2.3 line the original used).

Settings as in the original simulator (spec ``original-simulator.md`` §1-2, §10); pybox2d's compiled
constants already match the original's build (linear slop 0.005, polygon skin 0.01, velocity threshold
1 m/s, time to sleep 0.5 s, sleep tolerances 0.01 m/s and 2 deg/s, max translation 2 m per step):

* one ``b2World.Step(1/60, 8, 3)`` per frame, warm starting, continuous collision (TOI), no sub-stepping,
  sleeping on; gravity (0, -15); no damping;
* every fixture: density 50, friction 0.1, restitution 0.2; Box2D mixes them itself (sqrt / max) and drops
  restitution below a 1 m/s approach speed;
* polygons as ``b2PolygonShape`` (skin 0.01); circles (dynamic circles, static balls) as ``b2CircleShape``
  (pybox2d caps polygons at 16 vertices, the original used 128-gons); the basket as one open
  ``b2ChainShape`` (its three children are the parts 0-2 of the contact log) plus a sensor polygon on the
  basket's static body (Box2D never pairs two non-dynamic bodies, so the sensor reports dynamic bodies only).

Contact log: a ``b2ContactListener`` records ``BeginContact`` / ``EndContact`` stamped with the frame
counter (completed steps, as the original's callbacks). A contact ``[b, e)`` that begins and ends within
one step (a TOI touch) is stored as ``[b, b + 1)`` so it still yields its Collision. The contact
identity is the (fixture, child) pair, as in the original.

Replay (see :class:`~craft_dsl.physics.engine.ReplayPlan`): a replayed body is a kinematic body, placed
exactly on its recorded row at the start of every frame and moved at the recorded mean velocity during
it. Box2D creates no contact between two non-dynamic bodies, so replayed bodies touch only dynamically
simulated ones (never statics, the sensor or each other) without any filter. A body activated mid-run
is switched to dynamic (``SetType`` drops its contacts; the ones with active bodies are re-found before
the step, so a contact that persists stays one contact) and given its exact recorded state.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

with warnings.catch_warnings():  # SWIG's builtin types trigger import-time DeprecationWarnings on 3.12+
    warnings.simplefilter("ignore", DeprecationWarning)
    import Box2D

from ..simulation import Trajectory
from ..world import DENSITY, FRICTION, RESTITUTION, BodySpec, Segment, WorldSpec
from .engine import ContactLog, Interval, PairKey, RawRun, ReplayPlan, SensorKey, pair_key

#: The basket sensor's category bits in the original (``SENSOR_BASKET``); informative only.
SENSOR_CATEGORY = 0x0042


class _IntervalRecorder:
    """Begin/end callbacks stamped with the frame counter -> half-open frame intervals per key."""

    def __init__(self) -> None:
        self.open: dict[Any, list[list[int]]] = {}

    def begin(self, key: Any, frame: int) -> None:
        ivs = self.open.get(key)
        if ivs is None:
            self.open[key] = [[frame, -1]]
            return
        last = ivs[-1]
        if last[1] == -1 or last[1] > frame:  # still touching in this frame: the same contact continues
            last[1] = -1
        else:
            ivs.append([frame, -1])

    def end(self, key: Any, frame: int) -> None:
        ivs = self.open.get(key)
        if ivs is None or ivs[-1][1] != -1:
            return
        # A contact that began and ended within one step still touched in that frame.
        ivs[-1][1] = max(frame, ivs[-1][0] + 1)

    def result(self, steps: int) -> dict[Any, tuple[Interval, ...]]:
        return {
            k: tuple((s, steps if e == -1 else min(e, steps)) for s, e in v)
            for k, v in sorted(self.open.items())
            if v
        }


class _Listener(Box2D.b2ContactListener):
    """Forwards Box2D's begin/end callbacks to a recording run."""

    def __init__(self, run: _Run) -> None:
        super().__init__()
        self.run = run

    def BeginContact(self, contact: Any) -> None:  # noqa: N802 - Box2D's callback name
        self.run.contact_changed(contact, True)

    def EndContact(self, contact: Any) -> None:  # noqa: N802 - Box2D's callback name
        self.run.contact_changed(contact, False)


def _chains(segments: tuple[Segment, ...]) -> list[list[tuple[float, float]]]:
    """Consecutive connected segments as vertex chains (the basket's three edges are one chain)."""
    chains: list[list[tuple[float, float]]] = []
    for a, b in segments:
        if chains and chains[-1][-1] == a:
            chains[-1].append(b)
        else:
            chains.append([a, b])
    return chains


class Box2DEngine:
    """Physics adapter on pybox2d (Box2D 2.3). Parameters are the original's solver settings."""

    name = "box2d"

    def __init__(
        self,
        velocity_iterations: int = 8,
        position_iterations: int = 3,
        warm_starting: bool = True,
        continuous: bool = True,
        sleeping: bool = True,
    ) -> None:
        self.velocity_iterations = velocity_iterations
        self.position_iterations = position_iterations
        self.warm_starting = warm_starting
        self.continuous = continuous
        self.sleeping = sleeping

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
        if not spec.dynamic:
            body = b2w.CreateStaticBody(position=spec.position, angle=spec.angle)
        elif kinematic:
            body = b2w.CreateKinematicBody(position=spec.position, angle=spec.angle)
        else:
            body = b2w.CreateDynamicBody(position=spec.position, angle=spec.angle, bullet=False,
                                         allowSleep=True, linearDamping=0.0, angularDamping=0.0)
        geo = spec.geometry
        shapes: list[Any] = [Box2D.b2PolygonShape(vertices=list(poly)) for poly in geo.polygons]
        if geo.circle_radius is not None:
            shapes.append(Box2D.b2CircleShape(radius=geo.circle_radius))
        shapes.extend(Box2D.b2ChainShape(vertices_chain=chain) for chain in _chains(geo.segments))
        part = 0
        for shape in shapes:
            fixture = body.CreateFixture(shape=shape, density=DENSITY, friction=FRICTION, restitution=RESTITUTION)
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


class _Run:
    def __init__(self, engine: Box2DEngine, world: WorldSpec, steps: int, replay: ReplayPlan | None) -> None:
        self.engine = engine
        self.world = world
        self.steps = steps
        self.replay = replay
        self.frame = 0
        self.contacts = _IntervalRecorder()
        self.sensors = _IntervalRecorder()

    def contact_changed(self, contact: Any, begin: bool) -> None:
        fa, fb = contact.fixtureA, contact.fixtureB
        ua, pa, sa = fa.userData
        ub, pb, sb = fb.userData
        key: SensorKey | PairKey
        if sa or sb:
            rec, key = self.sensors, ((ua, ub) if sa else (ub, ua))
        else:
            rec, key = self.contacts, pair_key(ua, pa + contact.childIndexA, ub, pb + contact.childIndexB)
        if begin:
            rec.begin(key, self.frame)
        else:
            rec.end(key, self.frame)

    def execute(self) -> RawRun:
        eng, world, steps, replay = self.engine, self.world, self.steps, self.replay
        ids = tuple(b.uid for b in world.bodies)
        n = len(ids)
        col = {uid: i for i, uid in enumerate(ids)}
        pos = np.zeros((steps + 1, n, 2))
        ang = np.zeros((steps + 1, n))
        vel = np.zeros((steps + 1, n, 2))
        angv = np.zeros((steps + 1, n))
        awake = np.zeros((steps + 1, n), dtype=bool)
        for b in world.bodies:
            i = col[b.uid]
            pos[:, i] = b.position
            ang[:, i] = b.angle
            if b.dynamic:
                vel[0, i] = b.velocity
                angv[0, i] = b.angular_velocity
                awake[0, i] = True

        first = 0
        activation: dict[int, int] = {}
        dynamic_uids = [b.uid for b in world.bodies if b.dynamic]
        replayed: set[int] = set()
        if replay is not None:
            base = replay.base
            first = min(replay.first_frame, steps)
            activation = {uid: a for uid, a in replay.activation.items() if uid in col}
            for uid in dynamic_uids:
                i, bc = col[uid], base.column(uid)
                hi = min(activation.get(uid, steps), steps) + 1  # rows up to the activation row are base
                pos[:hi, i] = base.positions[:hi, bc]
                ang[:hi, i] = base.angles[:hi, bc]
                vel[:hi, i] = base.velocities[:hi, bc]
                angv[:hi, i] = base.angular_velocities[:hi, bc]
                awake[:hi, i] = replay.base_awake[:hi, bc]
            replayed = {uid for uid in dynamic_uids if activation.get(uid, steps) > first}
        b2w, bodies = eng.build_world(world, frozenset(replayed))
        if replay is not None:
            for uid in dynamic_uids:
                if uid not in replayed:
                    self._set_state(bodies[uid], pos, ang, vel, angv, col[uid], first)
        listener = _Listener(self)
        b2w.contactListener = listener

        fps = float(world.steps_per_second)
        dt = 1.0 / fps
        active = [(col[uid], bodies[uid]) for uid in dynamic_uids if uid not in replayed]
        pending = sorted((a, uid) for uid, a in activation.items() if first < a < steps)
        kin = [(col[uid], bodies[uid]) for uid in dynamic_uids if uid in replayed]
        rec: dict[int, tuple[int, list[Any], list[float], list[Any], list[float], list[bool]]] = {
            i: (first + 1, [], [], [], [], []) for i, _ in active
        }
        zero = (0.0, 0.0)
        step, vi, pi = b2w.Step, eng.velocity_iterations, eng.position_iterations
        find_new_contacts = b2w.contactManager.FindNewContacts
        for k in range(first, steps):
            self.frame = k
            if pending and pending[0][0] == k:
                while pending and pending[0][0] == k:
                    _, uid = pending.pop(0)
                    body = bodies[uid]
                    body.type = Box2D.b2_dynamicBody  # drops its contacts (EndContact stamped k)
                    self._set_state(body, pos, ang, vel, angv, col[uid], k)
                    kin = [(i, b) for i, b in kin if b is not body]
                    active.append((col[uid], body))
                    rec[col[uid]] = (k + 1, [], [], [], [], [])
                find_new_contacts()  # so this step's Collide sees them again (and continues the contacts)
            for i, body in kin:
                self._set_kinematic(body, pos, ang, i, k, fps)
            step(dt, vi, pi)
            for i, body in active:
                _, p_, a_, v_, w_, aw_ = rec[i]
                if body.awake:
                    p = body.position
                    p_.append((p.x, p.y))
                    a_.append(body.angle)
                    v = body.linearVelocity
                    v_.append((v.x, v.y))
                    w_.append(body.angularVelocity)
                    aw_.append(True)
                elif aw_ and not aw_[-1]:  # still asleep: Box2D has not moved it, its velocity is zero
                    p_.append(p_[-1])
                    a_.append(a_[-1])
                    v_.append(zero)
                    w_.append(0.0)
                    aw_.append(False)
                else:  # fell asleep in this step (after moving in it) or asleep from the start
                    p = body.position
                    p_.append((p.x, p.y))
                    a_.append(body.angle)
                    v_.append(zero)
                    w_.append(0.0)
                    aw_.append(False)
        b2w.contactListener = None
        for i, (r0, p_, a_, v_, w_, aw_) in rec.items():
            if p_:
                pos[r0:, i] = p_
                ang[r0:, i] = a_
                vel[r0:, i] = v_
                angv[r0:, i] = w_
                awake[r0:, i] = aw_
        traj = Trajectory(ids=ids, positions=pos, angles=ang, velocities=vel, angular_velocities=angv)
        contacts: dict[PairKey, tuple[Interval, ...]] = self.contacts.result(steps)
        sensors: dict[SensorKey, tuple[Interval, ...]] = self.sensors.result(steps)
        return RawRun(traj, awake, ContactLog(steps, contacts, sensors))

    @staticmethod
    def _set_state(body: Any, pos: np.ndarray, ang: np.ndarray, vel: np.ndarray, angv: np.ndarray,
                   i: int, row: int) -> None:
        body.transform = ((float(pos[row, i, 0]), float(pos[row, i, 1])), float(ang[row, i]))
        body.linearVelocity = (float(vel[row, i, 0]), float(vel[row, i, 1]))
        body.angularVelocity = float(angv[row, i])
        body.awake = True

    @staticmethod
    def _set_kinematic(body: Any, pos: np.ndarray, ang: np.ndarray, i: int, k: int, fps: float) -> None:
        x0, y0 = float(pos[k, i, 0]), float(pos[k, i, 1])
        a0 = float(ang[k, i])
        body.transform = ((x0, y0), a0)
        body.linearVelocity = ((float(pos[k + 1, i, 0]) - x0) * fps, (float(pos[k + 1, i, 1]) - y0) * fps)
        body.angularVelocity = (float(ang[k + 1, i]) - a0) * fps
