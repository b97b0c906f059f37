"""The perceived scene as a physics world: bodies from the most likely reading, the initial state fitted to the
tracks, the factual run re-simulated and its drift from the tracks measured.

Bodies. Static elements are placed at their pose (walls and ground, which never move in any CRAFT scene, at
their fixed place when the model gives no pose; a wall or ground the model did not list is added with a fresh id).
Dynamic bodies get the geometry of their most likely shape and size. Objects whose shape or size is unknown, or
that have neither pose nor track, are left out of the physics (listed in :attr:`PhysicsWorld.left_out`). Bodies
are created in the original order (walls, ground, basket, other statics, dynamic bodies; by descending id within a
group), which is the simulator's own order for a scene exported from it.

Initial state (row 0, never shown in a video). Gauss-Newton (finite-difference Jacobian, backtracking) fits it
against the perceived row-1 state when the tracks give velocities, else against the positions of the first rows;
bodies that may touch each other are fitted jointly, and the engine itself handles contacts and the push-out of
initial overlaps in the first frame. Because the first frames do not always pin the start down, each
initial-velocity hypothesis of :func:`start_hypotheses` is fitted and each body takes the simplest that fits.
When the scene layout is known, every dynamic body starts at angle pi without spin, as in every CRAFT layout.
:func:`refine_start` can further adjust the initial velocities to minimise the drift over the first second.

Drift: per object, the distance in video pixels between the re-simulated and the perceived positions, at every
row the track covers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..physics.engine import PhysicsEngine, RawRun
from ..physics.reach import interaction_groups
from ..world import (
    INITIAL_ANGLE,
    BodySpec,
    WorldSpec,
    bounding_radius,
    dynamic_geometry,
    make_static,
)
from .coords import to_metres
from .events import RowStates
from .params import ANGLE, POSITION, SPIN, VELOCITY, VX, VY, X, Y
from .reading import ObjectReading, is_static_shape
from .schema import PerceivedScene
from .tracks import INTEGRATOR_C, Motion, window_for

#: Gauss-Newton iterations of the start fit.
FIT_ITERATIONS = 12
#: Misfit (square metres, summed over the fitted rows) within which a simpler initial-velocity hypothesis is as
#: good as the best one.
MISFIT_MARGIN = 1e-9
#: Finite-difference steps of the state components.
_FD_STEP = {X: 1e-6, Y: 1e-6, ANGLE: 1e-7, VX: 1e-5, VY: 1e-5, SPIN: 1e-6}
#: The start fit stops when every residual is below this (metres, radians, m/s, rad/s).
FIT_TOLERANCE = 1e-12
#: ...or when its last iteration lowered no group's misfit by this share of it or more: a hypothesis that cannot fit
#: (a body at rest that the next row shows moving) keeps its misfit whatever the free components do, and a fit that
#: does converges by orders of magnitude an iteration until it reaches the floating-point floor.
STALL_FRACTION = 1e-6
_FIXED_STATICS = ("wall_l", "wall_r", "ground")
_ORDER = {"wall_l": 0, "wall_r": 1, "ground": 2, "basket": 3}


@dataclass(frozen=True)
class PhysicsWorld:
    """The bodies of a perceived scene (row-0 state fitted), and what could not be put in it."""

    world: WorldSpec
    left_out: dict[int, str] = field(default_factory=dict)
    added: dict[int, str] = field(default_factory=dict)

    @property
    def columns(self) -> dict[int, int]:
        return {b.uid: i for i, b in enumerate(self.world.bodies)}


@dataclass(frozen=True)
class Drift:
    """How far a re-simulated body strays from its perceived track (video pixels)."""

    mean_px: float
    max_px: float
    final_px: float
    first_step_over_1px: int | None


def _order_key(spec: BodySpec) -> tuple[int, int]:
    group = _ORDER.get(spec.shape, 5 if spec.dynamic else 4)
    return group, -spec.uid


def build_world(scene: PerceivedScene, objects: Sequence[ObjectReading], motions: Mapping[int, Motion]
                ) -> PhysicsWorld:
    """Bodies at the row-0 guess of the tracks (not yet fitted; see :func:`fit_start`)."""
    size = scene.video.width
    perceived = {o.id: o for o in scene.objects}
    bodies: list[BodySpec] = []
    left_out: dict[int, str] = {}
    for reading in objects:
        obj = perceived[reading.id]
        motion = motions.get(reading.id)
        if not reading.dynamic:
            if not is_static_shape(reading.shape):
                left_out[reading.id] = f"static object of shape {reading.shape!r}: no static geometry"
                continue
            if obj.pose is not None:
                x, y = to_metres(obj.pose.x, obj.pose.y, size)
                position, angle = (float(x), float(y)), obj.pose.angle
            elif motion is not None:
                position, angle = (float(motion.positions[1, 0]), float(motion.positions[1, 1])), float(
                    motion.angles[1])
            elif reading.shape in _FIXED_STATICS:
                position, angle = (0.0, 0.0), 0.0
            else:
                left_out[reading.id] = f"{reading.shape} without pose or track: its place is unknown"
                continue
            bodies.append(replace(make_static(reading.id, reading.shape, position, angle), color=reading.color))
            continue
        if motion is None:
            left_out[reading.id] = "dynamic object without a usable track"
            continue
        try:
            geometry = dynamic_geometry(reading.shape, reading.size)
        except (ValueError, KeyError):
            left_out[reading.id] = f"no geometry for shape {reading.shape!r}, size {reading.size!r}"
            continue
        bodies.append(BodySpec(
            uid=reading.id, shape=reading.shape, color=reading.color, size=reading.size, dynamic=True,
            position=(float(motion.positions[0, 0]), float(motion.positions[0, 1])), angle=float(motion.angles[0]),
            velocity=(float(motion.velocities[0, 0]), float(motion.velocities[0, 1])),
            angular_velocity=float(motion.angular_velocities[0]), geometry=geometry))
    added: dict[int, str] = {}
    present = {b.shape for b in bodies}
    next_id = max([o.id for o in scene.objects] + [-1]) + 1
    for shape in _FIXED_STATICS:
        if shape not in present and not any(r.shape == shape for r in objects):
            bodies.append(make_static(next_id, shape))
            added[next_id] = shape
            next_id += 1
    world = WorldSpec(bodies=tuple(sorted(bodies, key=_order_key)), scene_id=scene.scene)
    return PhysicsWorld(world, left_out, added)


# -- initial state ------------------------------------------------------------------------------------------


def _row_state(raw: RawRun, col: int, row: int) -> np.ndarray:
    t = raw.trajectory
    return np.array([t.positions[row, col, 0], t.positions[row, col, 1], t.angles[row, col],
                     t.velocities[row, col, 0], t.velocities[row, col, 1], t.angular_velocities[row, col]])


def _motion_state(m: Motion, row: int) -> np.ndarray:
    return np.array([m.positions[row, 0], m.positions[row, 1], m.angles[row], m.velocities[row, 0],
                     m.velocities[row, 1], m.angular_velocities[row]])


def _with_state(spec: BodySpec, s: np.ndarray) -> BodySpec:
    return replace(spec, position=(float(s[X]), float(s[Y])), angle=float(s[ANGLE]),
                   velocity=(float(s[VX]), float(s[VY])), angular_velocity=float(s[SPIN]))


def _state_of(spec: BodySpec) -> np.ndarray:
    return np.array([spec.position[0], spec.position[1], spec.angle, spec.velocity[0], spec.velocity[1],
                     spec.angular_velocity])


def fit_start(pw: PhysicsWorld, motions: Mapping[int, Motion], engine: PhysicsEngine,
              layout: int | None) -> PhysicsWorld:
    """Fit row 0 to the tracks (see the module docstring): for each initial-velocity hypothesis, Gauss-Newton
    against the row-1 state when every track gives velocities, else against the first rows' positions; each body
    takes the simplest hypothesis that fits."""
    dynamic = [b for b in pw.world.bodies if b.dynamic]
    if not dynamic:
        return pw
    use_state = all(motions[b.uid].given_velocities for b in dynamic)
    return _fit_hypotheses(pw, motions, engine, layout, use_state)


def _with_states(world: WorldSpec, states: Mapping[int, np.ndarray]) -> WorldSpec:
    return replace(world, bodies=tuple(_with_state(b, states[b.uid]) if b.dynamic else b for b in world.bodies))


def fit_rows(motions: Mapping[int, Motion]) -> int:
    """Rows of the position fit: 4 for exact tracks, more for noisy ones (twice the smoothing window)."""
    sigma = max((m.sigma_px for m in motions.values()), default=0.0)
    return 4 if sigma <= 0 else max(4, 2 * window_for(sigma))


#: An initial-velocity hypothesis: vx, vy, each fixed (a number) or free (None).
Hypothesis = tuple[float | None, float | None]
_HYPOTHESIS_INDEX = (VX, VY)


def start_hypotheses(layout: int | None) -> list[Hypothesis]:
    """The initial velocities a body may have, simplest first. With a known layout: one per distinct slot
    velocity (a number where the slot gives one, free where it draws one); then at rest; then free. (Positions
    are always fitted: a hypothesis is tried on every body at once, and fixed slot positions would stack them.)"""
    out: list[Hypothesis] = []
    if layout is not None:
        from ..scenes import Const, Expr, load_scene

        def fixed(q: object) -> float | None:
            if isinstance(q, Const):
                return q.value
            if isinstance(q, Expr) and not q.names:
                return q.evaluate({})
            return None

        for slot in load_scene(layout).dynamic:
            h = (fixed(slot.velocity[0]), fixed(slot.velocity[1]))
            if h not in out:
                out.append(h)
    for h in ((0.0, 0.0), (None, None)):
        if h not in out:
            out.append(h)
    return sorted(out, key=lambda h: sum(c is None for c in h))


def _fit_hypotheses(pw: PhysicsWorld, motions: Mapping[int, Motion], engine: PhysicsEngine, layout: int | None,
                    use_state: bool) -> PhysicsWorld:
    """Fit the start under each hypothesis of :func:`start_hypotheses` and give each body the simplest one whose
    misfit is within :data:`MISFIT_MARGIN` (plus the noise's chi-square allowance for the extra parameters) of
    the best.

    The first frames do not always pin the start down: a body resting on a platform at row 1 fits equally well
    at rest at row 0 and falling into the platform during frame 0, or drifting by a millimetre per second."""
    world = pw.world
    dynamic = [b for b in world.bodies if b.dynamic]
    sigma_m = max(m.sigma_px for m in motions.values()) * 50.0 / 256.0
    h = 1.0 / world.steps_per_second
    g = np.asarray(world.gravity)
    fits: list[tuple[Hypothesis, dict[int, np.ndarray], dict[int, float]]] = []
    for hypothesis in start_hypotheses(layout):
        if fits and all(min(f[2][b.uid] for f in fits) <= MISFIT_MARGIN for b in dynamic):
            break  # every body already fits (exact tracks): more complex hypotheses cannot be simpler
        guess = {}
        for b in dynamic:
            s = _state_of(b)
            for k, value in zip(_HYPOTHESIS_INDEX, hypothesis):
                if value is not None:
                    s[k] = value
            # the position that reaches the perceived row 1 in free flight with this velocity
            s[POSITION] = motions[b.uid].positions[1] - h * s[VELOCITY] - INTEGRATOR_C * g * h * h
            guess[b.uid] = s
        states, cost = _gauss_newton(world, motions, engine, layout is not None, guess,
                                     {b.uid: hypothesis for b in dynamic}, use_state)
        fits.append((hypothesis, states, cost))
    best: dict[int, np.ndarray] = {}
    chosen: dict[int, Hypothesis] = {}
    most_free = max(_free(f[0]) for f in fits)
    for b in dynamic:
        lowest = min(f[2][b.uid] for f in fits)
        for hypothesis, states, cost in fits:  # simplest first
            if cost[b.uid] <= lowest + MISFIT_MARGIN + 9.2 * (most_free - _free(hypothesis)) * sigma_m ** 2:
                best[b.uid], chosen[b.uid] = states[b.uid], hypothesis
                break
    # each hypothesis was fitted on every body at once, and the engine's sub-steps follow the fastest body: polish
    # the chosen mixture together
    best, _ = _gauss_newton(world, motions, engine, layout is not None, best, chosen, use_state)
    return replace(pw, world=_with_states(world, best))


def _free(hypothesis: Hypothesis) -> int:
    return sum(c is None for c in hypothesis)


def _components(dynamic: Sequence[BodySpec], motions: Mapping[int, Motion], rows: int) -> list[list[int]]:
    """The groups of bodies that may touch each other within ``rows`` rows (bounding circles with a 1 m margin over
    their perceived paths, closed transitively): each group is fitted jointly, and groups never interact."""
    paths = np.stack([motions[b.uid].positions[: rows + 1] for b in dynamic], axis=1)
    labels = interaction_groups(paths, [bounding_radius(b.geometry) for b in dynamic], margin=0.5)
    groups: list[list[int]] = [[] for _ in range(max(labels) + 1)]
    for b, g in zip(dynamic, labels):
        groups[g].append(b.uid)
    return groups


def _gauss_newton(world: WorldSpec, motions: Mapping[int, Motion], engine: PhysicsEngine, layout_prior: bool,
                  guess: Mapping[int, np.ndarray], hypotheses: Mapping[int, Hypothesis], use_state: bool = False
                  ) -> tuple[dict[int, np.ndarray], dict[int, float]]:
    """Gauss-Newton on the position, the free components of its hypothesis and (without the layout prior) angle
    and spin of every body, from ``guess``, against the first rows' positions (and angles), or with ``use_state``
    against the whole row-1 state (position, angle, velocity, spin).
    Returns the states and each body's misfit (sum of squares). Bodies that may touch each other are fitted
    jointly (:func:`_components`); a step is taken with backtracking."""
    fit = _JointFit(world, motions, engine, hypotheses, fit_angle=not layout_prior, use_state=use_state)
    states = {uid: np.array(s, dtype=np.float64) for uid, s in guess.items()}
    if layout_prior:
        for s in states.values():
            s[ANGLE], s[SPIN] = INITIAL_ANGLE, 0.0
    base, residual, cost = fit.evaluate(states)
    for _ in range(FIT_ITERATIONS):
        if max(cost.values()) < FIT_TOLERANCE ** 2:
            break
        accepted = fit.backtrack(states, fit.steps(fit.jacobian(states, base), residual), cost)
        if not accepted:
            break
        states = {uid: accepted.get(uid, st) for uid, st in states.items()}
        before = cost
        base, residual, cost = fit.evaluate(states)
        if fit.stalled(before, cost):
            break
    return states, cost


def _fitted_components(hypothesis: Hypothesis, fit_angle: bool) -> list[int]:
    """The state components fitted under ``hypothesis``: position, the free velocity components, angle and spin."""
    free = [k for k, c in zip(_HYPOTHESIS_INDEX, hypothesis) if c is None]
    return [X, Y] + free + ([ANGLE, SPIN] if fit_angle else [])


#: A group of bodies fitted jointly (uids).
Group = tuple[int, ...]


class _JointFit:
    """The misfit of start states against the first rows, and its Gauss-Newton steps, per group of bodies that may
    touch each other (:func:`_gauss_newton`)."""

    def __init__(self, world: WorldSpec, motions: Mapping[int, Motion], engine: PhysicsEngine,
                 hypotheses: Mapping[int, Hypothesis], fit_angle: bool, use_state: bool) -> None:
        self.world = world
        self.engine = engine
        self.fit_angle = fit_angle
        self.use_state = use_state
        self.dynamic = [b for b in world.bodies if b.dynamic]
        self.cols = {b.uid: i for i, b in enumerate(world.bodies)}
        self.rows = 1 if use_state else min(fit_rows(motions), min(motions[b.uid].steps for b in self.dynamic))
        #: per body, the state components fitted
        self.index = {uid: _fitted_components(h, fit_angle) for uid, h in hypotheses.items()}
        self.targets = {b.uid: self.observed(motions[b.uid]) for b in self.dynamic}
        self.components = _components(self.dynamic, motions, self.rows)
        self.width = max(len(c) for c in self.components)
        #: per group, where each body's parameters start in the group's parameter vector
        self.offsets = {tuple(g): np.cumsum([0] + [len(self.index[u]) for u in g]) for g in self.components}

    def observed(self, m: Motion) -> np.ndarray:
        """What a body's track shows of the fitted rows."""
        if self.use_state:
            return _motion_state(m, 1)
        rows = self.rows
        parts = [m.positions[1:rows + 1].ravel()] + ([m.angles[1:rows + 1]] if self.fit_angle else [])
        return np.concatenate(parts)

    def simulated(self, raw: RawRun, uid: int) -> np.ndarray:
        """The same of body ``uid`` in ``raw``."""
        if self.use_state:
            return _row_state(raw, self.cols[uid], 1)
        t, rows, col = raw.trajectory, self.rows, self.cols[uid]
        parts = [t.positions[1:rows + 1, col].ravel()] + ([t.angles[1:rows + 1, col]] if self.fit_angle else [])
        return np.concatenate(parts)

    def run(self, states: Mapping[int, np.ndarray]) -> RawRun:
        return self.engine.run(_with_states(self.world, states), self.rows)

    def evaluate(self, states: Mapping[int, np.ndarray]) -> tuple[RawRun, dict[int, np.ndarray], dict[int, float]]:
        """The run from ``states``, each body's residual and its misfit."""
        raw = self.run(states)
        residual = {b.uid: self.targets[b.uid] - self.simulated(raw, b.uid) for b in self.dynamic}
        return raw, residual, {uid: float(r @ r) for uid, r in residual.items()}

    def jacobian(self, states: Mapping[int, np.ndarray], base: RawRun) -> dict[Group, np.ndarray]:
        """Jacobian of each group's residuals w.r.t. all its bodies' parameters (forward differences from ``base``,
        the run from ``states``); the n-th parameter of the k-th body of every group is perturbed in the same run
        (groups do not interact)."""
        index, components = self.index, self.components
        jac = {tuple(g): np.zeros((sum(self.targets[u].size for u in g), int(self.offsets[tuple(g)][-1])))
               for g in components}
        for slot in range(self.width):
            for n in range(max(len(index[g[slot]]) for g in components if slot < len(g))):
                moved = {uid: st.copy() for uid, st in states.items()}
                perturbed = []
                for g in components:
                    if slot < len(g) and n < len(index[g[slot]]):
                        k = index[g[slot]][n]
                        moved[g[slot]][k] += _FD_STEP[k]
                        perturbed.append((g, k))
                run = self.run(moved)
                for g, k in perturbed:
                    column = np.concatenate([self.simulated(run, u) - self.simulated(base, u) for u in g]) / _FD_STEP[k]
                    jac[tuple(g)][:, self.offsets[tuple(g)][slot] + n] = column
        return jac

    def steps(self, jac: Mapping[Group, np.ndarray], residual: Mapping[int, np.ndarray]) -> dict[int, np.ndarray]:
        """Each body's Gauss-Newton step (least squares per group)."""
        deltas = {}
        for g in self.components:
            r = np.concatenate([residual[u] for u in g])
            step = np.linalg.lstsq(jac[tuple(g)], r, rcond=None)[0]
            off = self.offsets[tuple(g)]
            deltas.update({u: step[off[i]:off[i + 1]] for i, u in enumerate(g)})
        return deltas

    def backtrack(self, states: Mapping[int, np.ndarray], deltas: Mapping[int, np.ndarray],
                  cost: Mapping[int, float]) -> dict[int, np.ndarray]:
        """The new states of the groups whose misfit a full, half, quarter or eighth step lowers (the longest that
        does; contacts make the landscape kinked); groups no step improves are left out."""
        accepted: dict[int, np.ndarray] = {}
        for alpha in (1.0, 0.5, 0.25, 0.125):
            trial = {uid: st.copy() for uid, st in states.items()}
            for u in states:
                if u not in accepted:
                    trial[u][self.index[u]] += alpha * deltas[u]
            _, _, trial_cost = self.evaluate(trial)
            for g in self.components:
                if g[0] not in accepted and _group_cost(trial_cost, g) < _group_cost(cost, g):
                    accepted.update({u: trial[u] for u in g})
            if len(accepted) == len(states):
                break
        return accepted

    def stalled(self, before: Mapping[int, float], after: Mapping[int, float]) -> bool:
        """Whether the last iteration converged or lowered no group's misfit by :data:`STALL_FRACTION` of it."""
        for g in self.components:
            b, a = _group_cost(before, g), _group_cost(after, g)
            if not (a < FIT_TOLERANCE ** 2 or b - a < STALL_FRACTION * b):
                return False
        return True


def _group_cost(cost: Mapping[int, float], group: Sequence[int]) -> float:
    return sum(cost[u] for u in group)


def _with_velocity(spec: BodySpec, v: np.ndarray) -> BodySpec:
    return replace(spec, velocity=(float(v[0]), float(v[1])))


def refine_start(pw: PhysicsWorld, motions: Mapping[int, Motion], engine: PhysicsEngine, frames: int = 60,
                 iterations: int = 3, epsilon: float = 1e-4) -> PhysicsWorld:
    """Adjust the initial velocities to minimise the squared drift over the first ``frames`` rows."""
    world = pw.world
    dynamic = [b for b in world.bodies if b.dynamic]
    if not dynamic:
        return pw
    cols = {b.uid: i for i, b in enumerate(world.bodies)}
    frames = min(frames, min(m.steps for m in motions.values()))
    target = np.concatenate([motions[b.uid].positions[1:frames + 1].ravel() for b in dynamic])

    def residual(velocities: np.ndarray) -> np.ndarray:
        bodies = []
        it = iter(velocities.reshape(-1, 2))
        for b in world.bodies:
            bodies.append(_with_velocity(b, next(it)) if b.dynamic else b)
        raw = engine.run(replace(world, bodies=tuple(bodies)), frames)
        pos = raw.trajectory.positions
        return np.concatenate([pos[1:frames + 1, cols[b.uid]].ravel() for b in dynamic]) - target

    v = np.array([c for b in dynamic for c in b.velocity], dtype=np.float64)
    r = residual(v)
    cost = float(r @ r)
    for _ in range(iterations):
        jac = np.empty((r.size, v.size))
        for j in range(v.size):
            dv = v.copy()
            dv[j] += epsilon
            jac[:, j] = (residual(dv) - r) / epsilon
        step, *_ = np.linalg.lstsq(jac, -r, rcond=None)
        candidate = v + step
        rc = residual(candidate)
        c_cost = float(rc @ rc)
        if c_cost >= cost:
            break
        v, r, cost = candidate, rc, c_cost
    it = iter(v.reshape(-1, 2))
    bodies = tuple(_with_velocity(b, next(it)) if b.dynamic else b for b in world.bodies)
    return replace(pw, world=replace(world, bodies=bodies))


# -- rows and drift ------------------------------------------------------------------------------------------


def row_states(pw: PhysicsWorld, motions: Mapping[int, Motion], steps: int,
               engine: PhysicsEngine | None = None) -> RowStates:
    """Per-row states of every body: statics at rest, dynamic bodies on their tracks with row 0 the fitted start.

    With ``engine``, the estimated velocities of the first rows (those the start was fitted to, where bodies may
    still be pushed out of an initial overlap) are taken from the engine's run of the fitted start."""
    world = pw.world
    n = len(world.bodies)
    pos = np.zeros((steps + 1, n, 2))
    ang = np.zeros((steps + 1, n))
    vel = np.zeros((steps + 1, n, 2))
    angv = np.zeros((steps + 1, n))
    for i, b in enumerate(world.bodies):
        if b.dynamic:
            m = motions[b.uid]
            pos[:, i] = m.positions
            ang[:, i] = m.angles
            vel[:, i] = m.velocities
            angv[:, i] = m.angular_velocities
            pos[0, i] = b.position
            ang[0, i] = b.angle
            vel[0, i] = b.velocity
            angv[0, i] = b.angular_velocity
        else:
            pos[:, i] = b.position
            ang[:, i] = b.angle
    estimated = [i for i, b in enumerate(world.bodies) if b.dynamic and not motions[b.uid].given_velocities]
    if engine is not None and estimated:
        head = min(fit_rows(motions), steps)
        run = engine.run(world, head).trajectory
        vel[1:head, estimated] = run.velocities[1:head, estimated]
        angv[1:head, estimated] = run.angular_velocities[1:head, estimated]
    return RowStates(pos, ang, vel, angv)


def drift(pw: PhysicsWorld, run: RawRun, states: RowStates, size: int) -> dict[int, Drift]:
    """Per dynamic body: distance (pixels) between the re-simulated and the perceived positions, rows 1..T."""
    px_per_m = size / 50.0
    out = {}
    traj = run.trajectory
    for i, b in enumerate(pw.world.bodies):
        if not b.dynamic:
            continue
        d = np.hypot(*(traj.positions[1:, traj.column(b.uid)] - states.positions[1:, i]).T) * px_per_m
        over = np.nonzero(d > 1.0)[0]
        out[b.uid] = Drift(float(d.mean()), float(d.max()), float(d[-1]),
                           int(over[0]) + 1 if over.size else None)
    return out
