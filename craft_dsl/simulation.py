"""The simulation data model every adapter produces and the DSL evaluates over.

A :class:`Simulation` holds objects (with start and end states), events in (step, id) order, a networkx
causal graph over the events, and a way to obtain counterfactual simulations (the same scene with one
object removed). Recorded files and live physics engines plug in by constructing this one type.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from .errors import CounterfactualUnavailable, EvaluationError, SimulationFileError
from .vocabulary import END, MOVING_THRESHOLD, START

if TYPE_CHECKING:
    import networkx as nx
    import numpy as np

    from .world import WorldSpec


@dataclass(frozen=True, slots=True)
class ObjectState:
    """Kinematic state of one body at one instant (metres, radians, m/s, rad/s)."""

    position: tuple[float, float] = (0.0, 0.0)
    angle: float = 0.0
    velocity: tuple[float, float] = (0.0, 0.0)
    angular_velocity: float = 0.0
    awake: bool = True

    def is_moving(self) -> bool:
        """The original's test: a velocity component strictly above 0.001 m/s in magnitude."""
        vx, vy = self.velocity
        return abs(vx) > MOVING_THRESHOLD or abs(vy) > MOVING_THRESHOLD


@dataclass(frozen=True, slots=True)
class SimObject:
    """One body of a scene. Static elements are black and large; only dynamic bodies ever move."""

    id: int
    shape: str
    color: str
    size: str
    dynamic: bool
    start: ObjectState = field(default_factory=ObjectState)
    end: ObjectState = field(default_factory=ObjectState)

    @property
    def states(self) -> tuple[ObjectState, ObjectState]:
        """The recorded states; index 0 is the start (StartSceneStep), -1 the end (EndSceneStep)."""
        return (self.start, self.end)

    def is_moving(self, state_index: int) -> bool:
        """Moving in the chosen state; static bodies are never moving."""
        return self.dynamic and self.states[state_index].is_moving()


@dataclass(frozen=True, slots=True)
class Event:
    """An event: Start (step -1), End (last step), Collision, TouchStart, TouchEnd or EnterBasket."""

    id: int
    type: str
    step: int
    objects: tuple[int, ...] = ()

    def involves(self, object_id: int) -> bool:
        return object_id in self.objects

    def __repr__(self) -> str:
        objs = ",".join(map(str, self.objects))
        return f"Event({self.id}:{self.type}@{self.step}[{objs}])"


@dataclass(frozen=True)
class Trajectory:
    """Per-step states of every body: row t is the state after t physics steps (row 0 = initial state).

    ``ids[k]`` is the object id of column k. Arrays are float64:
    positions [T+1, N, 2], angles [T+1, N], velocities [T+1, N, 2], angular_velocities [T+1, N].
    """

    ids: tuple[int, ...]
    positions: np.ndarray
    angles: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray

    @property
    def steps(self) -> int:
        return int(self.positions.shape[0]) - 1

    def column(self, object_id: int) -> int:
        return self.ids.index(object_id)


CounterfactualSource = Callable[[int], "Simulation"]


def causal_graph_from_events(events: Sequence[Event], dynamic_ids: Iterable[int]) -> nx.DiGraph:
    """Build the causal graph by the original simulator's rule.

    Every event other than Start and End gets an edge from the latest strictly earlier event of each
    dynamic participant (Start if no dynamic participant had an earlier event); End gets an edge from the
    last event of every body that has any event. Static bodies never carry causality forward. Events
    are taken in (step, id) order, so "latest" is by step (the original used its insertion order).
    """
    import networkx as nx  # a causal graph is built only when asked for: keep `import craft_dsl` light

    dynamic = set(dynamic_ids)
    graph = nx.DiGraph()
    start = next((e for e in events if e.type == START), None)
    end = next((e for e in events if e.type == END), None)
    for e in events:
        graph.add_node(e.id, type=e.type, step=e.step, objects=e.objects)
    history: dict[int, list[Event]] = {}
    for e in events:
        if e.type in (START, END):
            continue
        causes: set[int] = set()
        for obj in e.objects:
            if obj not in dynamic:
                continue
            earlier = [p for p in history.get(obj, ()) if p.step < e.step]
            if earlier:
                causes.add(earlier[-1].id)
        if not causes and start is not None:
            causes.add(start.id)
        for c in causes:
            graph.add_edge(c, e.id)
        for obj in e.objects:
            history.setdefault(obj, []).append(e)
    if end is not None:
        for obj_events in history.values():
            graph.add_edge(obj_events[-1].id, end.id)
    return graph


class Simulation:
    """A simulated scene as the DSL sees it.

    Args:
        objects: every body, in any order (stored in ascending id order).
        events: every event, in any order (stored in (step, id) order).
        steps: number of physics steps of the run.
        causal_graph: a DiGraph over event ids; built by :func:`causal_graph_from_events` if omitted.
        counterfactuals: ``f(object_id) -> Simulation`` giving the run without that object.
        trajectory: per-step states (live simulators), for rendering.
        world: the concrete scene the run started from (live simulators), for rendering and re-runs.
        removed: ids of objects removed from the parent scene to make this run (counterfactuals).
        meta: free-form provenance (scene id, seed, engine, file name...).
    """

    def __init__(
        self,
        objects: Iterable[SimObject],
        events: Iterable[Event],
        *,
        steps: int,
        causal_graph: nx.DiGraph | None = None,
        counterfactuals: CounterfactualSource | None = None,
        trajectory: Trajectory | None = None,
        world: WorldSpec | None = None,
        removed: tuple[int, ...] = (),
        meta: dict[str, Any] | None = None,
        require_ground_and_basket: bool = True,
    ) -> None:
        self.objects: tuple[SimObject, ...] = tuple(sorted(objects, key=lambda o: o.id))
        self.events: tuple[Event, ...] = tuple(sorted(events, key=lambda e: (e.step, e.id)))
        self.steps = steps
        self.trajectory = trajectory
        self.world = world
        self.removed = removed
        self.meta: dict[str, Any] = dict(meta or {})
        self._counterfactuals = counterfactuals
        self._cf_cache: dict[int, Simulation] = {}
        self._causal_graph = causal_graph
        self._by_id: dict[int, SimObject] = {}
        for o in self.objects:
            if o.id in self._by_id:
                raise SimulationFileError(f"object id {o.id} appears twice; object ids must be unique")
            self._by_id[o.id] = o
        event_ids = set()
        for e in self.events:
            if e.id in event_ids:
                raise SimulationFileError(f"event id {e.id} appears twice; event ids must be unique")
            event_ids.add(e.id)
            for obj in e.objects:
                if obj not in self._by_id:
                    raise SimulationFileError(
                        f"event {e.type} at step {e.step} names object {obj}, which is not in the scene "
                        f"(objects: {sorted(self._by_id)})"
                    )
        self.ground_id = self._single("ground", require_ground_and_basket)
        self.basket_id = self._single("basket", require_ground_and_basket)
        # Fast read-only indexes for the evaluator's hot loop.
        self.all_ids: tuple[int, ...] = tuple(o.id for o in self.objects)
        self.dynamic_ids: frozenset[int] = frozenset(o.id for o in self.objects if o.dynamic)
        self.moving_ids: tuple[frozenset[int], frozenset[int]] = (
            frozenset(o.id for o in self.objects if o.is_moving(0)),
            frozenset(o.id for o in self.objects if o.is_moving(-1)),
        )
        #: Values derived from this simulation's own event list, memoised by the module semantics.
        self.memo: dict[Any, Any] = {}
        # Event lists owned by this simulation or its counterfactuals, by identity (see owner_of).
        self._event_lists: dict[int, Simulation] = {id(self.events): self}
        #: Object id -> colour, shape, size (read-only).
        self.color_of: dict[int, str] = {o.id: o.color for o in self.objects}
        self.shape_of: dict[int, str] = {o.id: o.shape for o in self.objects}
        self.size_of: dict[int, str] = {o.id: o.size for o in self.objects}

    def _single(self, shape: str, required: bool) -> int:
        found = [o.id for o in self.objects if o.shape == shape]
        if len(found) == 1:
            return found[0]
        if not required and not found:
            return -1
        raise SimulationFileError(
            f"a scene needs exactly one object of shape {shape!r}; found {len(found)}"
            + (f" (ids {found})" if found else "")
        )

    # -- lookups ---------------------------------------------------------------------------------

    def object(self, object_id: int) -> SimObject:
        """The object with this id (KeyError-free: raises EvaluationError naming the known ids)."""
        try:
            return self._by_id[object_id]
        except KeyError:
            raise EvaluationError(
                f"no object with id {object_id} in this simulation (ids: {list(self.all_ids)})"
            ) from None

    def has_object(self, object_id: int) -> bool:
        return object_id in self._by_id

    def moving(self, state_index: int) -> frozenset[int]:
        """Ids of objects moving in recorded state ``state_index`` (0 / -2 start, -1 / 1 end)."""
        if state_index not in (0, 1, -1, -2):
            raise EvaluationError(
                f"state index {state_index} is out of range: a simulation records 2 states "
                "(0 = start, as StartSceneStep(); -1 = end, as EndSceneStep(); 1 and -2 also allowed)"
            )
        return self.moving_ids[state_index]

    @property
    def causal_graph(self) -> nx.DiGraph:
        """The causal graph over events (node = event id, attributes type/step/objects)."""
        if self._causal_graph is None:
            self._causal_graph = causal_graph_from_events(self.events, self.dynamic_ids)
        return self._causal_graph

    # -- counterfactuals --------------------------------------------------------------------------

    def counterfactual(self, object_id: int) -> Simulation:
        """The simulation of the same scene with ``object_id`` removed (cached per object)."""
        cached = self._cf_cache.get(object_id)
        if cached is not None:
            return cached
        if object_id not in self._by_id:
            raise CounterfactualUnavailable(
                f"cannot remove object {object_id}: it is not in this simulation (ids: {list(self.all_ids)})"
            )
        if self._counterfactuals is None:
            obj = self._by_id[object_id]
            raise CounterfactualUnavailable(
                f"no counterfactual for object {object_id} ({obj.size} {obj.color} {obj.shape}): this "
                "simulation was loaded without variations (a bare simulator output); load a "
                "'simulation with variations' file or use a live simulator"
            )
        sim = self._counterfactuals(object_id)
        self.provide_counterfactual(object_id, sim)
        return sim

    def owner_of(self, events: tuple[Event, ...]) -> Simulation | None:
        """The simulation (this one or one of its counterfactuals) whose whole event list ``events`` is, or
        None for any other event set."""
        owner = self._event_lists.get(id(events))
        return owner if owner is not None and owner.events is events else None

    def provide_counterfactual(self, object_id: int, sim: Simulation) -> None:
        """Store the run without ``object_id`` computed ahead (a recorded file's variation)."""
        if object_id not in self._by_id:
            raise CounterfactualUnavailable(
                f"cannot store a counterfactual for object {object_id}: it is not in this simulation "
                f"(ids: {list(self.all_ids)})"
            )
        self._cf_cache[object_id] = sim
        self._event_lists[id(sim.events)] = sim

    def describe(self, object_id: int) -> str:
        o = self.object(object_id)
        return f"#{o.id} {o.size} {o.color} {o.shape}"

    def __repr__(self) -> str:
        return (
            f"Simulation({len(self.objects)} objects, {len(self.events)} events, {self.steps} steps"
            + (f", {self.meta}" if self.meta else "")
            + ")"
        )
