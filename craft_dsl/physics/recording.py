"""Engine-independent recording of one run: touching intervals from contact callbacks, and state rows.

Both engine adapters drive the same bookkeeping (see :mod:`~craft_dsl.physics.engine` for the frame
convention and :class:`~craft_dsl.physics.engine.ReplayPlan` for replays):

* :class:`ContactRecorder` routes begin/end callbacks of shape pairs and basket-sensor overlaps to two
  :class:`IntervalRecorder` instances. The engines stamp their callbacks differently, so the end rule is a small
  subclass: :class:`FrameIntervalRecorder` (Box2D, frame counter only) and
  :class:`SubstepIntervalRecorder` (pymunk, frame and sub-step).
* :class:`StateRecorder` holds the per-row state arrays, seeds them from the world and the replay plan,
  schedules the activations of replayed bodies, collects the rows of simulated bodies and assembles the
  :class:`~craft_dsl.physics.engine.RawRun`.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping
from typing import Any, Generic, NamedTuple, TypeVar

import numpy as np

from ..simulation import Trajectory
from ..world import WorldSpec
from .engine import ContactLog, Interval, PairKey, RawRun, ReplayPlan, SensorKey, pair_key

# -- touching intervals ----------------------------------------------------------------------------


class ShapeTag(NamedTuple):
    """What a contact callback needs to know about a shape: its body, its part number, whether a sensor."""

    uid: int
    part: int
    sensor: bool


class IntervalRecorder:
    """Begin/end callbacks stamped with a frame -> half-open frame intervals ``[start, end)`` per key.

    An interval is open (``end == -1``) from its begin until its end; :meth:`result` closes open ones at
    ``steps``. Subclasses define how an end is stamped (``end`` / ``separate``) and set
    :attr:`join_adjacent`.
    """

    #: Whether a begin in frame ``f`` continues a contact that closed exactly at ``f`` (touching in
    #: consecutive frames is one contact) rather than starting a new one.
    join_adjacent = False

    def __init__(self) -> None:
        self.open: dict[Any, list[list[int]]] = {}

    def begin(self, key: Any, frame: int) -> None:
        ivs = self.open.get(key)
        if ivs is None:
            self.open[key] = [[frame, -1]]
            return
        last = ivs[-1]
        if last[1] == -1 or last[1] > frame or (self.join_adjacent and last[1] == frame):
            last[1] = -1  # still touching in this frame: the same contact continues
        else:
            ivs.append([frame, -1])

    def _open_interval(self, key: Any) -> list[int] | None:
        """The key's open interval, or None if it has none (an end without a recorded begin)."""
        ivs = self.open.get(key)
        if ivs is None or ivs[-1][1] != -1:
            return None
        return ivs[-1]

    def result(self, steps: int) -> dict[Any, tuple[Interval, ...]]:
        return {
            k: tuple((s, steps if e == -1 else min(e, steps)) for s, e in v)
            for k, v in sorted(self.open.items())
            if v
        }


class FrameIntervalRecorder(IntervalRecorder):
    """Callbacks stamped with the frame counter only (Box2D): a contact that began and ended within one
    step still touched in that frame, and a begin at the counter of an end starts a new contact."""

    def end(self, key: Any, frame: int) -> None:
        last = self._open_interval(key)
        if last is not None:
            last[1] = max(frame, last[0] + 1)


class SubstepIntervalRecorder(IntervalRecorder):
    """Callbacks stamped with (frame, sub-step) (pymunk): a pair touches in a frame if it touches at any
    sub-step of it, so separating at sub-step 0 means it did not touch in that frame, and touching in
    consecutive frames is one contact."""

    join_adjacent = True

    def separate(self, key: Any, frame: int, substep: int) -> None:
        last = self._open_interval(key)
        if last is None:
            return
        last[1] = frame + 1 if substep > 0 else frame
        if last[1] <= last[0]:  # did not touch in any frame: drop the interval
            ivs = self.open[key]
            ivs.pop()
            if not ivs:
                del self.open[key]


R = TypeVar("R", bound=IntervalRecorder)


class ContactRecorder(Generic[R]):
    """The two interval recorders of a run: shape-pair contacts and basket-sensor overlaps."""

    def __init__(self, recorder: Callable[[], R]) -> None:
        self.contacts: R = recorder()
        self.sensors: R = recorder()

    def route(self, ua: int, pa: int, sa: bool, ub: int, pb: int, sb: bool) -> tuple[R, Hashable]:
        """The recorder and key of a callback between shape (ua, pa, sa) and shape (ub, pb, sb)."""
        if sa or sb:
            key_s: SensorKey = (ua, ub) if sa else (ub, ua)
            return self.sensors, key_s
        return self.contacts, pair_key(ua, pa, ub, pb)

    def log(self, steps: int) -> ContactLog:
        contacts: dict[PairKey, tuple[Interval, ...]] = self.contacts.result(steps)
        sensors: dict[SensorKey, tuple[Interval, ...]] = self.sensors.result(steps)
        return ContactLog(steps, contacts, sensors)


# -- state rows ------------------------------------------------------------------------------------

B = TypeVar("B")
#: Recorded rows of one simulated column: (first row, positions, angles, velocities, angular velocities,
#: awake flags), appended to by the engine frame by frame.
Rows = tuple[int, list[Any], list[float], list[Any], list[float], list[bool]]
#: A body state taken from one row: ((x, y), angle, (vx, vy), angular velocity).
BodyState = tuple[tuple[float, float], float, tuple[float, float], float]


class StateRecorder(Generic[B]):
    """The state arrays [T+1, N] of a run, with the replay schedule and the rows of simulated bodies.

    Rows of statics are their initial pose; without a replay plan every dynamic body is simulated from
    frame 0. With one, dynamic rows up to each body's activation row are the base rows, ``first`` is the
    first simulated frame and ``replayed`` the bodies that follow the base trajectory kinematically from
    ``first`` on. After :meth:`attach`, ``active`` and ``kinematic`` list (column, engine body) of the
    simulated and the replayed bodies, in world order.
    """

    def __init__(self, world: WorldSpec, steps: int, replay: ReplayPlan | None) -> None:
        self.steps = steps
        self.ids = tuple(b.uid for b in world.bodies)
        self.col = {uid: i for i, uid in enumerate(self.ids)}
        self.dynamic_uids = [b.uid for b in world.bodies if b.dynamic]
        n = len(self.ids)
        self.pos = pos = np.zeros((steps + 1, n, 2))
        self.ang = ang = np.zeros((steps + 1, n))
        self.vel = vel = np.zeros((steps + 1, n, 2))
        self.angv = angv = np.zeros((steps + 1, n))
        self.awake = awake = np.zeros((steps + 1, n), dtype=bool)
        for b in world.bodies:
            i = self.col[b.uid]
            pos[:, i] = b.position
            ang[:, i] = b.angle
            if b.dynamic:
                vel[0, i] = b.velocity
                angv[0, i] = b.angular_velocity
                awake[0, i] = True
        self.first = 0
        self.activation: dict[int, int] = {}
        self.replayed: frozenset[int] = frozenset()
        if replay is not None:
            base = replay.base
            self.first = min(replay.first_frame, steps)
            self.activation = {uid: a for uid, a in replay.activation.items() if uid in self.col}
            for uid in self.dynamic_uids:
                i, bc = self.col[uid], base.column(uid)
                hi = min(self.activation.get(uid, steps), steps) + 1  # rows up to the activation row are base
                pos[:hi, i] = base.positions[:hi, bc]
                ang[:hi, i] = base.angles[:hi, bc]
                vel[:hi, i] = base.velocities[:hi, bc]
                angv[:hi, i] = base.angular_velocities[:hi, bc]
                awake[:hi, i] = replay.base_awake[:hi, bc]
            self.replayed = frozenset(uid for uid in self.dynamic_uids if self.activation.get(uid, steps) > self.first)
        self.pending = sorted((a, uid) for uid, a in self.activation.items() if self.first < a < steps)
        self.active: list[tuple[int, B]] = []
        self.kinematic: list[tuple[int, B]] = []
        self.rows: dict[int, Rows] = {}

    def attach(self, bodies: Mapping[int, B]) -> None:
        """Bind the engine's bodies: simulated ones are recorded from row ``first + 1`` on."""
        self.active = [(self.col[uid], bodies[uid]) for uid in self.dynamic_uids if uid not in self.replayed]
        self.kinematic = [(self.col[uid], bodies[uid]) for uid in self.dynamic_uids if uid in self.replayed]
        self.rows = {i: (self.first + 1, [], [], [], [], []) for i, _ in self.active}

    def due(self, frame: int) -> list[int]:
        """Pop the replayed bodies to activate at the start of ``frame``."""
        out = []
        while self.pending and self.pending[0][0] == frame:
            out.append(self.pending.pop(0)[1])
        return out

    def activate(self, uid: int, body: B, frame: int) -> None:
        """Move ``body`` from the replayed to the simulated bodies as of ``frame``."""
        self.kinematic = [(i, b) for i, b in self.kinematic if b is not body]
        self.active.append((self.col[uid], body))
        self.rows[self.col[uid]] = (frame + 1, [], [], [], [], [])

    def state(self, i: int, row: int) -> BodyState:
        """Column ``i``'s recorded state at ``row``."""
        pos, vel = self.pos, self.vel
        return ((float(pos[row, i, 0]), float(pos[row, i, 1])), float(self.ang[row, i]),
                (float(vel[row, i, 0]), float(vel[row, i, 1])), float(self.angv[row, i]))

    def kinematic_state(self, i: int, frame: int, fps: float) -> BodyState:
        """Column ``i`` at the start of ``frame``, moving at the mean velocity that reaches the next row."""
        pos, ang = self.pos, self.ang
        x0, y0 = float(pos[frame, i, 0]), float(pos[frame, i, 1])
        x1, y1 = float(pos[frame + 1, i, 0]), float(pos[frame + 1, i, 1])
        a0, a1 = float(ang[frame, i]), float(ang[frame + 1, i])
        return (x0, y0), a0, ((x1 - x0) * fps, (y1 - y0) * fps), (a1 - a0) * fps

    def result(self, log: ContactLog) -> RawRun:
        """The run: recorded rows written over the arrays, with ``log``."""
        for i, (r0, p_, a_, v_, w_, aw_) in self.rows.items():
            if p_:
                self.pos[r0:, i] = p_
                self.ang[r0:, i] = a_
                self.vel[r0:, i] = v_
                self.angv[r0:, i] = w_
                self.awake[r0:, i] = aw_
        traj = Trajectory(ids=self.ids, positions=self.pos, angles=self.ang, velocities=self.vel,
                          angular_velocities=self.angv)
        return RawRun(traj, self.awake, log)
