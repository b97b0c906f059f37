"""Executing over a perceived scene: the scene model shared by every reading, and the Simulation of one reading.

:class:`SceneModel` holds what does not depend on the reading: the motions from the tracks, the physics world
with its fitted initial state, the perceived run (tracks as trajectory, perceived events as contact log), and
the counterfactual runs (computed once per removed object, lazily). :meth:`SceneModel.simulation` turns one
:class:`~craft_dsl.perception.reading.Reading` into a :class:`PerceivedSimulation`, a
:class:`~craft_dsl.simulation.Simulation` like any other: objects, events, causal graph, counterfactuals.

Counterfactual modes (``ExecutionOptions.counterfactual``):

* ``"replay"`` (default): the run without object o is re-simulated against the *perceived* run exactly as live
  simulations make clean counterfactuals (:func:`craft_dsl.physics.clean_counterfactual`): bodies the removal
  cannot reach follow their perceived tracks and keep their perceived events; a body is re-simulated from its
  perceived state (position, angle, velocity) at the first frame it touched o, or touched a re-simulated body.
  This is the definition the ground truth uses, applied to what was seen.
* ``"resimulate"``: the whole scene is re-simulated from the fitted initial state (as VRDP does on CLEVRER) and
  the counterfactual is the clean counterfactual of that re-simulated run. Chaotic contacts make the re-simulated
  factual run drift from the video; :meth:`SceneModel.drift` reports by how much.

Events of the factual run (``ExecutionOptions.events``): ``"perceived"`` (the scene's events), ``"derived"`` (from
the tracks and the geometry, :mod:`craft_dsl.perception.events`), ``"auto"`` (perceived when the scene has an
``events`` list, else derived).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterable
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any, Literal

import numpy as np

from ..errors import CounterfactualUnavailable, PerceptionError, SimulationFileError
from ..physics.engine import PhysicsEngine, RawRun
from ..physics.events import events_from_log
from ..physics.flicker import add_flicker
from ..physics.live import LiveSimulation, clean_counterfactual, get_engine
from ..simulation import Event, ObjectState, SimObject, Simulation, Trajectory
from ..vocabulary import DEFAULT_ENGINE, END, ENTER_BASKET, START, canonical_event_type
from .coords import event_step, frame_rows, metres_per_pixel
from .events import CONTACT_TOLERANCE, RowStates, StepEvent, derive_log, derived_event_tolerance, log_from_events
from .fit import Drift, PhysicsWorld, build_world, drift, fit_start, refine_start, row_states
from .reading import ObjectReading, Reading, most_likely_objects, most_likely_reading
from .schema import PerceivedScene
from .tracks import Motion, moving_probability, scene_motions, window_for
from .validation import checked

#: A fitted initial velocity slower than this (m/s, per component) counts as rest: a body touching something in the
#: first frame fits its first frames as well at rest as drifting by a few millimetres per second.
START_REST_SPEED = 0.05

EventSource = Literal["auto", "perceived", "derived"]
CounterfactualMode = Literal["replay", "resimulate"]
EVENT_SOURCES: tuple[str, ...] = ("auto", "perceived", "derived")
COUNTERFACTUAL_MODES: tuple[str, ...] = ("replay", "resimulate")


@dataclass(frozen=True)
class ExecutionOptions:
    """How a perceived scene is executed (see the module docstring)."""

    events: EventSource = "auto"
    counterfactual: CounterfactualMode = "replay"
    engine: str | None = None  # None: the engine the scene names (``PerceivedScene.physics``), else pymunk
    refine: bool = False
    tolerance: float | None = None

    def __post_init__(self) -> None:
        if self.events not in EVENT_SOURCES:
            raise PerceptionError(f"unknown event source {self.events!r}; allowed: {', '.join(EVENT_SOURCES)}")
        if self.counterfactual not in COUNTERFACTUAL_MODES:
            raise PerceptionError(f"unknown counterfactual mode {self.counterfactual!r}; allowed: "
                                  f"{', '.join(COUNTERFACTUAL_MODES)}")


class PerceivedSimulation(Simulation):
    """The Simulation of one reading of a perceived scene (``model`` and ``reading`` say which)."""

    def __init__(self, model: SceneModel, reading: Reading, objects: Iterable[SimObject], events: Iterable[Event],
                 **kwargs: Any) -> None:
        super().__init__(objects, events, **kwargs)
        self.model = model
        self.reading = reading
        dynamic = self.dynamic_ids
        self.moving_ids = (frozenset(reading.moving_start) & dynamic, frozenset(reading.moving_end) & dynamic)


class SceneModel:
    """Everything about a perceived scene that does not depend on the reading (lazy where it costs)."""

    def __init__(self, scene: PerceivedScene, options: ExecutionOptions | None = None) -> None:
        self.scene = checked(scene)  # free for a scene validated when built; checks one made by model_copy
        self.options = options or ExecutionOptions()
        self.steps = scene.steps
        self.motions: dict[int, Motion] = scene_motions(scene)
        self.map_objects: tuple[ObjectReading, ...] = most_likely_objects(scene)
        self._unfitted = build_world(scene, self.map_objects, self.motions)
        self._cf_cache: dict[int, LiveSimulation] = {}
        self._reading_cf_cache: dict[tuple[int, frozenset[int]], Simulation] = {}
        rows = frame_rows(self.steps, scene.video.fps)
        self.step_events: list[StepEvent] = []
        for i, e in enumerate(scene.events or ()):
            kind = canonical_event_type(e.type)
            if kind in (START, END):
                continue
            objects = tuple(e.objects)
            if kind == ENTER_BASKET and objects[1] in self.basket_ids:
                objects = (objects[1], objects[0])
            self.step_events.append(StepEvent(kind, objects, event_step(e.frame, rows), i))

    # -- the physics ------------------------------------------------------------------------------------------

    @cached_property
    def engine(self) -> PhysicsEngine:
        return get_engine(self.options.engine or self.scene.physics or DEFAULT_ENGINE)

    @property
    def basket_ids(self) -> set[int]:
        return {o.id for o in self.map_objects if o.shape == "basket"}

    @cached_property
    def physics(self) -> PhysicsWorld:
        """The physics world with its initial state fitted to the tracks."""
        pw = fit_start(self._unfitted, self.motions, self.engine, self.scene.scene)
        if self.options.refine:
            pw = refine_start(pw, self.motions, self.engine)
        return pw

    @cached_property
    def states(self) -> RowStates:
        """The perceived run, row by row (tracks, with row 0 the fitted start)."""
        return row_states(self.physics, self.motions, self.steps, self.engine)

    @property
    def events_source(self) -> Literal["perceived", "derived"]:
        if self.options.events == "auto":
            return "perceived" if self.scene.events is not None else "derived"
        return self.options.events

    @cached_property
    def tolerance(self) -> float:
        if self.options.tolerance is not None:
            return self.options.tolerance
        sigmas = [m.sigma_px for m in self.motions.values()]
        sigma = max(sigmas, default=0.0)
        return derived_event_tolerance(sigma, metres_per_pixel(self.scene.video.width), window_for(sigma))

    @cached_property
    def derived_log(self) -> Any:
        """The contact log rebuilt from the tracks and the geometry; with an engine whose circles' contacts with
        statics flicker as the original's 128-gons' do (Box2D's default), split as that engine splits them
        (:func:`~craft_dsl.physics.flicker.add_flicker`, a function of the run's own speeds)."""
        world = self.physics.world
        log = derive_log(world, self.states, self.tolerance)
        if getattr(self.engine, "flicker", False):
            circles = [b.uid for b in world.bodies if b.dynamic and b.geometry.circle_radius]
            statics = [b.uid for b in world.bodies if not b.dynamic]
            log = add_flicker(log, self.trajectory, circles, statics)
        return log

    @cached_property
    def trajectory(self) -> Trajectory:
        """The perceived run as a trajectory (the fitted world's bodies, row by row)."""
        world, states = self.physics.world, self.states
        return Trajectory(ids=tuple(b.uid for b in world.bodies), positions=states.positions, angles=states.angles,
                          velocities=states.velocities, angular_velocities=states.angular_velocities)

    @cached_property
    def base_run(self) -> RawRun:
        """The perceived run as the engine's RawRun: the counterfactual base of the replay mode."""
        world, states = self.physics.world, self.states
        if self.events_source == "derived":
            log = self.derived_log
        else:
            basket = next(iter(self.basket_ids), -1)
            log = log_from_events(self.step_events, self.steps, basket, world, states, CONTACT_TOLERANCE)
        traj = self.trajectory
        moved = np.zeros(states.angles.shape, dtype=bool)
        moved[1:] = np.any(states.positions[1:] != states.positions[:-1], axis=2)
        awake = (np.any(states.velocities != 0, axis=2) | moved) & np.array([b.dynamic for b in world.bodies])
        return RawRun(traj, awake, log)

    def perturbed(self, seed: int, amount: float) -> SceneModel:
        """This model with its counterfactuals replayed against the perceived run with each dynamic body's velocity
        scaled by one factor ``1 + amount * r``, ``r ~ U(-1, 1)`` drawn per body (in the physics world's body order)
        from ``seed``: a body re-simulated from its perceived state starts a little faster or slower. The fit, the
        tracks and the factual events are shared with this model (computed once); only the counterfactual runs are
        new. Replay mode only: re-simulated counterfactuals do not read the perceived run."""
        if self.options.counterfactual != "replay":
            raise PerceptionError("a perturbed replay needs the replay counterfactual mode")
        base = self.base_run
        dynamic = np.array([b.dynamic for b in self.physics.world.bodies], dtype=float)
        factors = 1.0 + amount * np.random.default_rng(seed).uniform(-1.0, 1.0, dynamic.size) * dynamic
        traj = replace(base.trajectory, velocities=base.trajectory.velocities * factors[None, :, None])
        other = copy.copy(self)
        other.__dict__["base_run"] = RawRun(traj, base.awake, base.log)
        other._cf_cache = {}
        other._reading_cf_cache = {}
        return other

    @cached_property
    def fitted_run(self) -> LiveSimulation:
        """The factual run re-simulated from the fitted initial state."""
        world = self.physics.world
        return LiveSimulation(world, self.engine.run(world, self.steps), self.engine,
                              meta={"scene": self.scene.scene, "source": "re-simulated from the fitted start"})

    def drift(self) -> dict[int, Drift]:
        """Per dynamic object, how far the re-simulated factual run strays from the perceived track."""
        return drift(self.physics, self.fitted_run.raw, self.states, self.scene.video.width)

    # -- moving flags ------------------------------------------------------------------------------------------

    @cached_property
    def moving_start(self) -> dict[int, float]:
        """P(moving in the first state) per object."""
        out = {}
        starts = {b.uid: b for b in self.physics.world.bodies if b.dynamic} if self.motions else {}
        for obj in self.scene.objects:
            if obj.moving_start is not None:
                out[obj.id] = obj.moving_start
            elif obj.id in starts:
                velocity = np.asarray(starts[obj.id].velocity)
                if np.max(np.abs(velocity)) < START_REST_SPEED:
                    velocity = np.zeros(2)
                out[obj.id] = moving_probability(velocity, self.motions[obj.id].velocity_sigma)
            else:
                out[obj.id] = 0.0
        return out

    @cached_property
    def moving_end(self) -> dict[int, float]:
        """P(moving in the last state) per object."""
        out = {}
        for obj in self.scene.objects:
            if obj.moving_end is not None:
                out[obj.id] = obj.moving_end
            elif obj.id in self.motions:
                m = self.motions[obj.id]
                out[obj.id] = moving_probability(m.end_velocity, m.end_velocity_sigma)
            else:
                out[obj.id] = 0.0
        return out

    # -- readings ----------------------------------------------------------------------------------------------

    def most_likely_reading(self) -> Reading:
        return most_likely_reading(self.scene, self.moving_start, self.moving_end)

    @cached_property
    def _derived_events(self) -> list[Event]:
        return events_from_log(self.derived_log)

    def factual_events(self, reading: Reading) -> list[Event]:
        """Start, the reading's events (ids in (step, listed order)), End."""
        if self.events_source == "derived":
            return list(self._derived_events)
        chosen = sorted((e for e in self.step_events if e.index in reading.events), key=lambda e: (e.step, e.index))
        events = [Event(0, START, -1, ())]
        events += [Event(i + 1, e.type, e.step, e.objects) for i, e in enumerate(chosen)]
        events.append(Event(len(events), END, self.steps, ()))
        return events

    @cached_property
    def _states(self) -> dict[int, tuple[ObjectState, ObjectState]]:
        """Start and end state of every tracked object (the moving flags come from the reading)."""
        out = {}
        for uid, m in self.motions.items():
            out[uid] = tuple(
                ObjectState((float(m.positions[r, 0]), float(m.positions[r, 1])), float(m.angles[r]),
                            (float(m.velocities[r, 0]), float(m.velocities[r, 1])), float(m.angular_velocities[r]))
                for r in (0, -1))
        return out  # type: ignore[return-value]

    def _objects(self, reading: Reading) -> list[SimObject]:
        out = []
        rest = (ObjectState(), ObjectState())
        for o in reading.objects:
            start, end = self._states.get(o.id, rest)
            out.append(SimObject(o.id, o.shape, o.color, o.size, o.dynamic, start, end))
        for uid, shape in self._unfitted.added.items():
            out.append(SimObject(uid, shape, "black", "large", False))
        return out

    def simulation(self, reading: Reading | None = None) -> PerceivedSimulation:
        """The Simulation of ``reading`` (default: the most likely reading)."""
        reading = reading or self.most_likely_reading()
        try:
            return PerceivedSimulation(
                self, reading, self._objects(reading), self.factual_events(reading), steps=self.steps,
                counterfactuals=lambda uid: self.counterfactual(uid, reading),
                meta={"scene": self.scene.scene, "source": "perceived", **self.scene.meta})
        except SimulationFileError as err:  # e.g. no basket: say that it is the perceived scene that is wrong
            raise PerceptionError(f"the perceived scene does not make a simulation: {err}") from None

    # -- counterfactuals ---------------------------------------------------------------------------------------

    def counterfactual_run(self, uid: int) -> LiveSimulation:
        """The run without ``uid`` (cached), in the configured mode."""
        cached = self._cf_cache.get(uid)
        if cached is not None:
            return cached
        pw = self.physics
        if uid in pw.left_out:
            raise CounterfactualUnavailable(
                f"cannot remove object {uid}: it is not in the physics ({pw.left_out[uid]})")
        if not any(b.uid == uid for b in pw.world.bodies):
            raise CounterfactualUnavailable(f"cannot remove object {uid}: it is not in this scene")
        if not self.basket_ids & {b.uid for b in pw.world.bodies}:
            raise CounterfactualUnavailable("counterfactuals need the basket in the physics: give the basket a pose")
        if self.options.counterfactual == "resimulate":
            sim = self.fitted_run.counterfactual(uid)
        else:
            spec = pw.world.body(uid)
            if spec.shape in ("ground", "basket"):
                raise CounterfactualUnavailable(
                    f"cannot remove object {uid} ({spec.shape}): every scene needs its ground and basket")
            raw, activation = clean_counterfactual(self.engine, pw.world, self.base_run, uid)
            sim = LiveSimulation(pw.world.without(uid), raw, self.engine, removed=(uid,), activation=activation,
                                 meta={"scene": self.scene.scene, "source": "perceived, replayed"})
        self._cf_cache[uid] = sim
        return sim

    def counterfactual(self, uid: int, reading: Reading) -> Simulation:
        """The counterfactual of ``reading`` without ``uid``.

        Replay mode with perceived events: an event of a pair before the first frame either of its bodies was
        re-simulated is the perceived event itself (when the reading has it); from that frame on, events come from
        the re-simulated run. So every body the removal cannot reach keeps exactly its perceived events. The other
        modes take the run's events as they are."""
        run = self.counterfactual_run(uid)
        if self.events_source == "derived" or self.options.counterfactual == "resimulate":
            return run
        cached = self._reading_cf_cache.get((uid, reading.events))
        if cached is not None:
            return cached
        activation = run.activation

        def switch(e: Event) -> float:
            return min((activation.get(o, math.inf) for o in e.objects), default=math.inf)

        seen = [e for e in self.factual_events(reading)
                if e.type not in (START, END) and uid not in e.objects and e.step < switch(e)]
        present = {o.id for o in run.objects}
        absent = sorted({o for e in seen for o in e.objects if o not in present})
        if absent:  # the run has no such body: its perceived events cannot be replayed
            reason = self.physics.left_out.get(absent[0], "not in the physics")
            raise CounterfactualUnavailable(f"cannot remove object {uid}: object {absent[0]} has perceived events but "
                                            f"is not in the physics ({reason})")
        simulated = [e for e in run.events if e.type not in (START, END) and e.step >= switch(e)]
        merged = sorted([(e.step, 0, i, e) for i, e in enumerate(seen)]
                        + [(e.step, 1, i, e) for i, e in enumerate(simulated)])
        events = [Event(0, START, -1, ())]
        events += [Event(i + 1, e.type, e.step, e.objects) for i, (_, _, _, e) in enumerate(merged)]
        events.append(Event(len(events), END, self.steps, ()))
        sim = Simulation(run.objects, events, steps=run.steps, removed=(uid,), meta=dict(run.meta))
        self._reading_cf_cache[(uid, reading.events)] = sim
        return sim


def most_likely_world(scene: PerceivedScene, options: ExecutionOptions | None = None) -> PerceivedSimulation:
    """The Simulation of the most likely reading of ``scene`` (any program runs on it)."""
    return SceneModel(scene, options).simulation()
