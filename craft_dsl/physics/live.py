"""Live simulations: run a scene, derive events, and make clean counterfactuals and perturbations.

Clean counterfactuals. Re-running a physics engine without one body is not clean:
removing a body changes the engine's internal pair order, and chaotic contacts amplify the rounding, so
bodies that never met the removed one drift. Instead, the run without ``o`` is built against the base
(factual) run as a monotone fixed point:

1. every dynamic body X is either *replayed* (kinematic, on its base trajectory bit for bit) or *active*
   from a frame ``a(X)`` on (simulated from its exact base state at row ``a(X)``);
2. ``a(X)`` starts as the first frame X touches ``o`` in the base log, then, closed over the base log:
   a body that touched, in the base run, a body active at that frame becomes active at that frame (the
   base impulse no longer exists);
3. the world without ``o`` is re-run under that plan; a replayed body touching an active body in this
   run (a kinematic body pushes with infinite mass, which cannot be trusted) becomes active at that frame;
   steps 2-3 repeat until nothing changes (activations only grow or move earlier, so this terminates);
4. the counterfactual contact log takes, per pair, the base log before the first activation among the
   pair and the run's log from it on; events come from that log with the same rules as any run.

A body that is never activated has, by construction, its base trajectory and exactly its base events:
each of its pairs is either with a never-active body or a static (base log throughout), or with an
active body that it never touches from that body's activation on, in either run (otherwise it would
have been activated), so the spliced log equals the base log for that pair.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, TypeVar, overload

from ..errors import CounterfactualUnavailable, MissingExtraError
from ..simulation import ObjectState, SimObject, Simulation, Trajectory
from ..vocabulary import BOX2D128_ENGINE, DEFAULT_ENGINE, ENGINES, ORIGINAL_ENGINE
from ..world import DEFAULT_STEPS, WorldSpec
from .engine import ContactLog, Interval, PhysicsEngine, RawRun, ReplayPlan, perturb_world, splice
from .events import events_from_log

if TYPE_CHECKING:
    from .original import OriginalSimulation

_INF = math.inf
_K = TypeVar("_K", bound=tuple[int, ...])


#: Engine names accepted by :func:`get_engine` and ``simulate(..., engine=...)``.


def get_engine(engine: str | PhysicsEngine) -> PhysicsEngine:
    """An engine instance from a name ("box2d", the default; "pymunk"; "box2d128", which needs Box2D built with
    128-vertex polygons) or an instance.

    Box2D (pybox2d) is a dependency of the package, imported only when asked for."""
    if not isinstance(engine, str):
        return engine
    if engine == "pymunk":
        from .pymunk_engine import PymunkEngine

        return PymunkEngine()
    if engine in ("box2d", BOX2D128_ENGINE):
        try:
            from .box2d_engine import Box2D128Engine, Box2DEngine
        except ModuleNotFoundError as exc:  # the optional extra is missing
            if exc.name != "Box2D":
                raise
            raise MissingExtraError(f"the {engine} engine", "box2d", "pybox2d") from exc
        return Box2DEngine() if engine == "box2d" else Box2D128Engine()
    if engine == ORIGINAL_ENGINE:
        raise ValueError("the original simulator records runs and cannot step a world frame by frame: use "
                         "simulate(..., engine='original'); engines that step worlds: " + ", ".join(ENGINES))
    raise ValueError(f"unknown physics engine {engine!r}; available: {', '.join(ENGINES)}")


def objects_from_run(world: WorldSpec, raw: RawRun) -> list[SimObject]:
    """SimObjects with start state = row 0 and end state = last row (statics never move)."""
    traj = raw.trajectory
    out = []
    for spec in world.bodies:
        i = traj.column(spec.uid)

        def state(row: int, i: int = i, dynamic: bool = spec.dynamic) -> ObjectState:
            position = (float(traj.positions[row, i, 0]), float(traj.positions[row, i, 1]))
            angle = float(traj.angles[row, i])
            if not dynamic:
                return ObjectState(position=position, angle=angle)
            return ObjectState(
                position=position,
                angle=angle,
                velocity=(float(traj.velocities[row, i, 0]), float(traj.velocities[row, i, 1])),
                angular_velocity=float(traj.angular_velocities[row, i]),
                awake=bool(raw.awake[row, i]),
            )

        out.append(SimObject(spec.uid, spec.shape, spec.color, spec.size, spec.dynamic, state(0), state(-1)))
    return out


class LiveSimulation(Simulation):
    """A simulation produced by a physics engine, with lazy clean counterfactuals.

    Attributes besides :class:`Simulation`'s: ``raw`` (trajectory, awake flags, contact log), ``engine``,
    ``activation`` (for a counterfactual: body -> first frame it was simulated dynamically; the
    *affected set* is its keys) and ``parent`` (the run a counterfactual was made from).
    """

    def __init__(
        self,
        world: WorldSpec,
        raw: RawRun,
        engine: PhysicsEngine,
        *,
        meta: dict[str, Any] | None = None,
        removed: tuple[int, ...] = (),
        activation: dict[int, int] | None = None,
        parent: LiveSimulation | None = None,
    ) -> None:
        super().__init__(
            objects_from_run(world, raw),
            events_from_log(raw.log),
            steps=raw.log.steps,
            counterfactuals=self._make_counterfactual,
            trajectory=raw.trajectory,
            world=world,
            removed=removed,
            meta=meta,
        )
        self.raw = raw
        self.engine = engine
        self.activation: dict[int, int] = dict(activation or {})
        self.parent = parent

    def counterfactual(self, object_id: int) -> LiveSimulation:
        """The clean run of the same scene without ``object_id`` (lazy, cached), itself live."""
        sim = super().counterfactual(object_id)
        assert isinstance(sim, LiveSimulation)
        return sim

    @property
    def traj(self) -> Trajectory:
        """The trajectory (never None for a live simulation)."""
        return self.raw.trajectory

    @property
    def affected(self) -> frozenset[int]:
        """Bodies simulated dynamically at some point of this counterfactual (empty for a factual run)."""
        return frozenset(self.activation)

    @property
    def world_spec(self) -> WorldSpec:
        assert self.world is not None
        return self.world

    def _make_counterfactual(self, uid: int) -> LiveSimulation:
        world = self.world_spec
        spec = world.body(uid)
        if spec.shape in ("ground", "basket"):
            raise CounterfactualUnavailable(
                f"cannot remove object {uid} ({spec.shape}): every scene needs its ground and basket"
            )
        raw, activation = clean_counterfactual(self.engine, world, self.raw, uid)
        return LiveSimulation(
            world.without(uid), raw, self.engine, meta=dict(self.meta), removed=self.removed + (uid,),
            activation=activation, parent=self,
        )

    def perturbed(self, seed: int, amount: float = 0.02) -> LiveSimulation:
        """The whole scene re-simulated from a perturbed initial state (the original simulator's perturbation
        noise, applied once); its counterfactuals are live and not perturbed again."""
        world = perturb_world(self.world_spec, seed, amount)
        meta = dict(self.meta, perturbation_seed=seed, perturbation_amount=amount)
        return LiveSimulation(world, self.engine.run(world, self.steps), self.engine, meta=meta,
                              removed=self.removed)


# -- counterfactuals ---------------------------------------------------------------------------------


def _close_over_base(base: ContactLog, activation: dict[int, int], dynamic: set[int]) -> None:
    """Activate every body that touched, in the base log, a body active at that frame (in place)."""
    pairs = [(ua, ub, ivs) for (ua, _pa, ub, _pb), ivs in base.contacts.items() if ua in dynamic and ub in dynamic]
    changed = True
    while changed:
        changed = False
        for ua, ub, ivs in pairs:
            for x, y in ((ua, ub), (ub, ua)):
                ax = activation.get(x, _INF)
                ay = activation.get(y, _INF)
                if ax >= ay:
                    continue
                for s, e in ivs:
                    if e > ax:
                        frame = max(s, int(ax))
                        if frame < ay:
                            activation[y] = frame
                            ay = frame
                            changed = True
                        break


def _activate_from_run(run: ContactLog, activation: dict[int, int], dynamic: set[int]) -> bool:
    """Activate replayed bodies that touched an active body in ``run``; True if anything changed."""
    changed = False
    for (ua, _pa, ub, _pb), ivs in run.contacts.items():
        if ua not in dynamic or ub not in dynamic:
            continue
        for x, y in ((ua, ub), (ub, ua)):
            ax = activation.get(x, _INF)
            ay = activation.get(y, _INF)
            for s, e in ivs:
                frame = max(s, int(ax)) if ax < _INF else None
                if frame is not None and frame < e and frame < ay:
                    activation[y] = frame
                    changed = True
                    break
    return changed


def _splice_map(
    base: Mapping[_K, tuple[Interval, ...]],
    run: Mapping[_K, tuple[Interval, ...]],
    switch: Callable[[_K], float],
    steps: int,
) -> dict[_K, tuple[Interval, ...]]:
    """Per key: base intervals before frame ``switch(key)``, run intervals from it on (base only if inf)."""
    out = {}
    for key in sorted(set(base) | set(run)):
        at = switch(key)
        if at == _INF:
            ivs = base.get(key, ())
        else:
            ivs = splice(base.get(key, ()), run.get(key, ()), int(at), steps)
        if ivs:
            out[key] = ivs
    return out


def splice_logs(base: ContactLog, run: ContactLog, activation: dict[int, int]) -> ContactLog:
    """Per pair: base intervals before the first activation among its bodies, run intervals after."""

    def active_from(uid: int) -> float:
        return activation.get(uid, _INF)

    contacts = _splice_map(base.contacts, run.contacts, lambda k: min(active_from(k[0]), active_from(k[2])),
                           base.steps)
    sensors = _splice_map(base.sensors, run.sensors, lambda k: active_from(k[1]), base.steps)
    return ContactLog(base.steps, contacts, sensors)


def clean_counterfactual(
    engine: PhysicsEngine, world: WorldSpec, base: RawRun, removed: int, max_rounds: int = 100
) -> tuple[RawRun, dict[int, int]]:
    """The run of ``world`` without ``removed``, clean against ``base`` (see the module docstring).

    Returns the spliced run and the activation map (affected body -> first dynamically simulated frame).
    """
    cf_world = world.without(removed)
    dynamic = set(cf_world.dynamic_uids)
    steps = base.log.steps
    activation: dict[int, int] = {removed: 0}
    _close_over_base(base.log, activation, dynamic | {removed})
    del activation[removed]
    base_log = base.log.without_uid(removed)
    keep = [base.trajectory.column(b.uid) for b in cf_world.bodies]
    base_traj = replace(
        base.trajectory,
        ids=tuple(b.uid for b in cf_world.bodies),
        positions=base.trajectory.positions[:, keep],
        angles=base.trajectory.angles[:, keep],
        velocities=base.trajectory.velocities[:, keep],
        angular_velocities=base.trajectory.angular_velocities[:, keep],
    )
    base_awake = base.awake[:, keep]
    if not activation:
        return RawRun(base_traj, base_awake, base_log), activation
    for _ in range(max_rounds):
        run = engine.run(cf_world, steps, ReplayPlan(base_traj, base_awake, dict(activation)))
        if not _activate_from_run(run.log, activation, dynamic):
            break
        _close_over_base(base_log, activation, dynamic)
    else:  # pragma: no cover - activations are monotone and bounded; this guards against engine bugs
        raise RuntimeError(f"counterfactual without {removed} did not converge in {max_rounds} rounds")
    return RawRun(run.trajectory, run.awake, splice_logs(base_log, run.log, activation)), activation


# -- entry point -------------------------------------------------------------------------------------


def world_and_meta(scene: int | str | Path | WorldSpec, seed: int = 0) -> tuple[WorldSpec, dict[str, Any]]:
    """The world :func:`simulate` runs (``scene`` itself, or sampled from a scene id or layout file with ``seed``) and
    the provenance it records (``scene``, ``seed``)."""
    if isinstance(scene, WorldSpec):
        world = scene
    else:
        from ..scenes import sample_world  # written in parallel; imported lazily

        world = sample_world(scene, seed)
    label = world.scene_id if world.scene_id is not None or isinstance(scene, WorldSpec) else str(scene)
    return world, {"scene": label, "seed": world.seed if world.seed is not None else seed}


@overload
def simulate(scene: int | str | Path | WorldSpec, seed: int = 0, steps: int = DEFAULT_STEPS,
             engine: Literal["pymunk", "box2d", "box2d128"] | PhysicsEngine = DEFAULT_ENGINE) -> LiveSimulation: ...


@overload
def simulate(scene: int | str | Path | WorldSpec, seed: int = 0, steps: int = DEFAULT_STEPS, *,
             engine: Literal["original"]) -> OriginalSimulation: ...


@overload
def simulate(scene: int | str | Path | WorldSpec, seed: int = 0, steps: int = DEFAULT_STEPS,
             engine: str | PhysicsEngine = DEFAULT_ENGINE) -> LiveSimulation | OriginalSimulation: ...


def simulate(
    scene: int | str | Path | WorldSpec,
    seed: int = 0,
    steps: int = DEFAULT_STEPS,
    engine: str | PhysicsEngine = DEFAULT_ENGINE,
) -> LiveSimulation | OriginalSimulation:
    """Simulate a scene (id 1-20, a layout file, or a concrete WorldSpec).

    With a physics engine ("box2d", the default; "pymunk"; or an instance) the result is a :class:`LiveSimulation`;
    Box2D is the default because its runs agree with the original simulator's more often than the original agrees
    with its own 2% perturbation, and pymunk's less often (docs/original.md). With
    "original" it is the original CRAFT simulator's run of the same start state, an
    :class:`~craft_dsl.physics.original.OriginalSimulation` (the simulator must be built:
    ``tools/original/build.sh``)."""
    world, meta = world_and_meta(scene, seed)
    if engine == ORIGINAL_ENGINE:
        from .original import simulate_original

        return simulate_original(world, steps, meta=meta)
    eng = get_engine(engine)
    meta["engine"] = eng.name
    return LiveSimulation(world, eng.run(world, steps), eng, meta=meta)

