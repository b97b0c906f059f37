"""Recorded CRAFT simulations: load and save the original JSON formats.

Two formats are read (spec ``original-question-engine.md`` §5): the *simulation with variations*
file (``original_video_output`` + ``variations_outputs``, counterfactuals from the variations) and a
bare simulator output (``causal_graph``, ``scene_states``; counterfactuals are then unavailable and
asking for one names the object). Files are validated on load and refused with a message naming the
defect. Events are numbered 0..n-1 by a stable sort on step that keeps the file's order among ties.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import networkx as nx
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from .atomic import write_json_atomic
from .errors import CounterfactualUnavailable, SimulationFileError
from .simulation import Event, ObjectState, SimObject, Simulation
from .vocabulary import END, ORIGINAL_EVENT_TYPE, canonical_event_type

# -- file schema (only what the engine reads is required) -----------------------------------------------


class _Loose(BaseModel):
    model_config = ConfigDict(extra="allow", populate_by_name=True)


class ObjectRecord(_Loose):
    uniqueID: int
    shape: str
    color: str
    size: str
    bodyType: int
    linear_velocity: tuple[float, float] = Field(alias="2dLinearVelocity")
    coords: tuple[float, float] = Field(default=(0.0, 0.0), alias="2dCoords")
    angle: float = 0.0
    angularVelocity: float = 0.0
    awake: bool = True


class SceneRecord(_Loose):
    objects: list[ObjectRecord]


class SceneStateRecord(_Loose):
    step: int
    scene: SceneRecord


class EventRecord(_Loose):
    id: int
    type: str
    step: int
    objects: list[int]


class EdgeRecord(_Loose):
    from_: int = Field(alias="from")
    to: list[int]


class CausalGraphRecord(_Loose):
    nodes: list[EventRecord]
    edges: list[EdgeRecord] = []


class BareOutput(_Loose):
    causal_graph: CausalGraphRecord
    scene_states: list[SceneStateRecord] | None = None
    video_filename: str = ""


class VariationsFile(_Loose):
    original_video_output: BareOutput
    variations_outputs: dict[str, BareOutput] = {}


def _validation_message(err: ValidationError, where: str) -> str:
    first = err.errors()[0]
    loc = ".".join(str(p) for p in first["loc"])
    return f"{where}: field {loc}: {first['msg']} ({len(err.errors())} problem(s) in all)"


# -- building simulations ----------------------------------------------------------------------------------


def _state(rec: ObjectRecord) -> ObjectState:
    return ObjectState(rec.coords, rec.angle, rec.linear_velocity, rec.angularVelocity, rec.awake)


def _objects(output: BareOutput, where: str) -> tuple[SimObject, ...]:
    states = output.scene_states or []
    if not states:
        raise SimulationFileError(f"{where}: no scene_states; a simulation needs its start and end states")
    by_step = sorted(states, key=lambda s: s.step)
    start, end = by_step[0], by_step[-1]
    if start.step != 0:
        raise SimulationFileError(f"{where}: no scene state with step 0 (steps: {[s.step for s in states]})")
    if end.step == 0:
        raise SimulationFileError(f"{where}: no end state (a scene state with a step other than 0)")
    seen: set[int] = set()
    for o in start.scene.objects:
        if o.uniqueID in seen:
            raise SimulationFileError(f"{where}: uniqueID {o.uniqueID} appears twice in the start state")
        seen.add(o.uniqueID)
    end_by_id = {o.uniqueID: o for o in end.scene.objects}
    objects = []
    for o in start.scene.objects:
        e = end_by_id.get(o.uniqueID)
        if e is None:
            raise SimulationFileError(
                f"{where}: object {o.uniqueID} ({o.shape}) is in the start state but not in the end state"
            )
        objects.append(SimObject(o.uniqueID, o.shape, o.color, o.size, o.bodyType != 0, _state(o), _state(e)))
    return tuple(objects)


def _events(graph: CausalGraphRecord, where: str) -> tuple[list[Event], nx.DiGraph]:
    ordered = sorted(enumerate(graph.nodes), key=lambda p: p[1].step)  # stable: file order among ties
    new_id: dict[int, int] = {}
    events: list[Event] = []
    for new, (index, rec) in enumerate(ordered):
        if rec.id in new_id:
            raise SimulationFileError(f"{where}: causal_graph.nodes[{index}]: event id {rec.id} appears twice")
        try:
            etype = canonical_event_type(rec.type)
        except ValueError as err:
            raise SimulationFileError(f"{where}: causal_graph.nodes[{index}]: {err}") from None
        new_id[rec.id] = new
        events.append(Event(new, etype, rec.step, tuple(rec.objects)))
    dg = nx.DiGraph()
    for e in events:
        dg.add_node(e.id, type=e.type, step=e.step, objects=e.objects)
    for k, edge in enumerate(graph.edges):
        for target in (edge.from_, *edge.to):
            if target not in new_id:
                raise SimulationFileError(
                    f"{where}: causal_graph.edges[{k}] names event {target}, which is not in causal_graph.nodes"
                )
        for t in edge.to:
            dg.add_edge(new_id[edge.from_], new_id[t])
    return events, dg


def _build(output: BareOutput, objects: tuple[SimObject, ...], where: str, **kw: Any) -> Simulation:
    events, graph = _events(output.causal_graph, where)
    end_steps = [e.step for e in events if e.type == END]
    state_steps = [s.step for s in output.scene_states or ()]
    steps = end_steps[0] if end_steps else max(state_steps + [e.step for e in events] + [0])
    try:
        return Simulation(objects, events, steps=steps, causal_graph=graph,
                          meta={"source": where, "video_filename": output.video_filename}, **kw)
    except SimulationFileError as err:
        raise SimulationFileError(f"{where}: {err}") from None


def _variation_source(
    variations: dict[str, BareOutput], factual: tuple[SimObject, ...], where: str
) -> Any:
    def make(object_id: int) -> Simulation:
        key = str(object_id)
        if key not in variations:
            obj = next(o for o in factual if o.id == object_id)
            kind = "dynamic" if obj.dynamic else "static"
            available = ", ".join(sorted(variations, key=lambda s: int(s) if s.lstrip("-").isdigit() else 0))
            raise CounterfactualUnavailable(
                f"GetCounterfactEvents: {where} has no variation for object {object_id} ({kind} {obj.size} "
                f"{obj.color} {obj.shape}); variations recorded for objects: {available or 'none'}"
            )
        return _variation(variations[key], object_id, factual, where)

    return make


def _variation(output: BareOutput, object_id: int, factual: tuple[SimObject, ...], where: str) -> Simulation:
    vwhere = f"{where} variations_outputs[{str(object_id)!r}]"
    if output.scene_states:
        objects = _objects(output, vwhere)
        allowed = {o.id for o in factual} - {object_id}
        ids = {o.id for o in objects}
        if object_id in ids:
            raise SimulationFileError(
                f"{vwhere}: the variation without object {object_id} still contains object {object_id}"
            )
        if ids - allowed:
            raise SimulationFileError(
                f"{vwhere}: objects {sorted(ids - allowed)} are not in the original scene "
                f"(a variation holds the original objects less {object_id})"
            )
    else:  # only the events were recorded: the scene is the factual one without the object
        objects = tuple(o for o in factual if o.id != object_id)
    return _build(output, objects, vwhere, removed=(object_id,))


def load_simulation(source: str | os.PathLike[str] | Mapping[str, Any]) -> Simulation:
    """Load a recorded CRAFT simulation (path to a JSON file, or the parsed dict).

    Every variation is validated on load, so a malformed file fails here, not halfway through a run.
    """
    if isinstance(source, Mapping):
        data: Any = source
        where = "<dict>"
    else:
        path = Path(source)
        where = str(path)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise SimulationFileError(f"{where}: no such file") from None
        except json.JSONDecodeError as err:
            raise SimulationFileError(
                f"{where}: not valid JSON (line {err.lineno}, column {err.colno}: {err.msg}); "
                "the file may be truncated"
            ) from None
    if not isinstance(data, Mapping):
        raise SimulationFileError(f"{where}: expected a JSON object, found {type(data).__name__}")
    try:
        if "original_video_output" in data:
            file = VariationsFile.model_validate(data)
            original, variations = file.original_video_output, file.variations_outputs
        elif "causal_graph" in data:
            original, variations = BareOutput.model_validate(data), None
        else:
            raise SimulationFileError(
                f"{where}: not a CRAFT simulation: expected the key 'original_video_output' (simulation with "
                f"variations) or 'causal_graph' and 'scene_states' (bare output); found keys {sorted(data)}"
            )
    except ValidationError as err:
        raise SimulationFileError(_validation_message(err, where)) from None
    objects = _objects(original, where)
    source_fn = _variation_source(variations, objects, where) if variations is not None else None
    sim = _build(original, objects, where, counterfactuals=source_fn)
    if variations is not None:
        for key, output in variations.items():
            if not key.lstrip("-").isdigit() or not sim.has_object(int(key)):
                raise SimulationFileError(
                    f"{where}: variations_outputs has key {key!r}, which is not an object id of the scene "
                    f"(ids: {list(sim.all_ids)})"
                )
            sim.provide_counterfactual(int(key), _variation(output, int(key), objects, where))
    return sim


# -- saving --------------------------------------------------------------------------------------------------


def _float(x: float) -> float:
    return 0.0 if x == 0 else float(x)


def _object_record(obj: SimObject, state: ObjectState, extra: Mapping[str, Any]) -> dict[str, Any]:
    rec = {
        "uniqueID": obj.id, "shape": obj.shape, "color": obj.color, "size": obj.size,
        "bodyType": 2 if obj.dynamic else 0,
        "2dCoords": [_float(state.position[0]), _float(state.position[1])],
        "angle": _float(state.angle),
        "2dLinearVelocity": [_float(state.velocity[0]), _float(state.velocity[1])],
        "angularVelocity": _float(state.angular_velocity),
        "linearDamping": 0.0, "angularDamping": 0.0, "gravityScale": 1.0,
        "active": True, "awake": bool(state.awake), "bullet": False, "allowSleep": True,
        "fixedRotation": False, "friction": 0.1, "restitution": 0.2, "density": 50.0,
    }
    rec.update(extra)
    return dict(sorted(rec.items()))


def _mass_data(sim: Simulation) -> dict[int, dict[str, float]]:
    world = sim.world
    out: dict[int, dict[str, float]] = {}
    if world is None:
        return out
    for b in world.bodies:
        mass = inertia = 0.0
        if b.dynamic:
            g = b.geometry
            if g.circle_radius is not None:
                mass = 50.0 * math.pi * g.circle_radius**2
                inertia = 0.5 * mass * g.circle_radius**2
            for poly in g.polygons:
                area = 0.5 * abs(sum(x1 * y2 - x2 * y1 for (x1, y1), (x2, y2) in zip(poly, poly[1:] + poly[:1])))
                m = 50.0 * area
                r2 = sum(x * x + y * y for x, y in poly) / len(poly)
                mass += m
                inertia += m * r2 / 2.0
        out[b.uid] = {"massData-mass": mass, "massData-I": inertia, "massData-centerX": 0.0,
                      "massData-centerY": 0.0}
    return out


def bare_output(sim: Simulation) -> dict[str, Any]:
    """The original simulator's output dict (``causal_graph``, ``scene_states``, ``video_filename``)."""
    mass = _mass_data(sim)
    objects = sorted(sim.objects, key=lambda o: -o.id)  # creation order: ids descend
    directions = {"above": [0, 1], "below": [0, -1], "left": [-1, 0], "right": [1, 0]}
    states = [
        {"scene": {"directions": directions,
                   "objects": [_object_record(o, o.start, mass.get(o.id, {})) for o in objects]}, "step": 0},
        {"scene": {"directions": directions,
                   "objects": [_object_record(o, o.end, mass.get(o.id, {})) for o in objects]},
         "step": sim.steps},
    ]
    graph = sim.causal_graph
    nodes = [{"id": e.id, "objects": list(e.objects), "step": e.step, "type": ORIGINAL_EVENT_TYPE[e.type]}
             for e in sim.events]
    edges = [{"from": e.id, "to": sorted(graph.successors(e.id))} for e in sim.events if e.id in graph]
    return {
        "causal_graph": {"edges": edges, "nodes": nodes, "vis": ""},
        "scene_states": states,
        "video_filename": str(sim.meta.get("video_filename", "")),
    }


def simulation_dict(sim: Simulation, variations: bool = True) -> dict[str, Any]:
    """The file content: a simulation with variations (every dynamic object removed once) or bare."""
    if not variations:
        return bare_output(sim)
    outputs = {str(o.id): bare_output(sim.counterfactual(o.id)) for o in sim.objects if o.dynamic}
    return {"original_video_output": bare_output(sim), "variations_outputs": outputs,
            "enables": [], "prevents": []}


def save_simulation(sim: Simulation, path: str | os.PathLike[str], variations: bool = True) -> None:
    """Write ``sim`` in the original JSON format (atomically). See :func:`simulation_dict`."""
    write_json_atomic(simulation_dict(sim, variations), path)


__all__ = ["load_simulation", "save_simulation", "simulation_dict", "bare_output", "write_json_atomic"]
