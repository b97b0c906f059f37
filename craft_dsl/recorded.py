"""Recorded CRAFT simulations: load and save the original JSON formats.

Two formats are read: the *simulation with variations* file (``original_video_output`` +
``variations_outputs``, counterfactuals from the variations) and a bare simulator output (``causal_graph``,
``scene_states``; counterfactuals are then unavailable and asking for one names the object). Files are
validated on load and refused with a :class:`~craft_dsl.errors.SimulationFileError` naming the file, the field
and what is allowed; ``strict=True`` adds the checks of what the original simulator always writes (see
docs/recorded.md). Events are numbered 0..n-1 by a stable sort on step that keeps the file's order among ties.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from typing import Annotated, Any

import networkx as nx
from pydantic import BaseModel, ConfigDict, Field, StrictInt, ValidationError

from .atomic import write_json_atomic
from .errors import CounterfactualUnavailable, SimulationFileError
from .files import INT64_MAX, INT64_MIN, describe, key_text, read_json
from .simulation import Event, ObjectState, SimObject, Simulation
from .vocabulary import (
    COLORS,
    END,
    ORIGINAL_EVENT_TYPE,
    SHAPES,
    SIZES,
    START,
    STATIC_COLOR,
    STATIC_SHAPES,
    STATIC_SIZE,
    canonical_event_type,
)

# -- file schema (only what the engine reads is required) -----------------------------------------------


#: An integer of the file (an id, a step, a body type): a 64-bit signed integer, as the original writes them.
Int64 = Annotated[StrictInt, Field(ge=INT64_MIN, le=INT64_MAX)]
#: Shapes, colours and sizes a recorded object may have.
ALLOWED_SHAPES: tuple[str, ...] = SHAPES + STATIC_SHAPES
ALLOWED_COLORS: tuple[str, ...] = COLORS + (STATIC_COLOR,)
ALLOWED_SIZES: tuple[str, ...] = SIZES
#: Box2D body types: 0 static, 1 kinematic (never used by CRAFT), 2 dynamic.
BODY_TYPES: tuple[int, ...] = (0, 1, 2)
_ID_KEY = re.compile(r"-?[0-9]{1,19}")


class _Loose(BaseModel):
    # Numbers must be finite: a NaN velocity would make "moving" silently false.
    model_config = ConfigDict(extra="allow", populate_by_name=True, allow_inf_nan=False)


class ObjectRecord(_Loose):
    uniqueID: Int64
    shape: str
    color: str
    size: str
    bodyType: Int64
    linear_velocity: tuple[float, float] = Field(alias="2dLinearVelocity")
    coords: tuple[float, float] = Field(default=(0.0, 0.0), alias="2dCoords")
    angle: float = 0.0
    angularVelocity: float = 0.0
    awake: bool = True


class SceneRecord(_Loose):
    objects: list[ObjectRecord]


class SceneStateRecord(_Loose):
    step: Int64
    scene: SceneRecord


class EventRecord(_Loose):
    id: Int64
    type: str
    step: Int64
    objects: list[Int64]


class EdgeRecord(_Loose):
    from_: Int64 = Field(alias="from")
    to: list[Int64]


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


def _validation_error(err: ValidationError, where: str, path: str | None) -> SimulationFileError:
    first = err.errors()[0]
    loc = ".".join(key_text(p) for p in first["loc"])
    found = f", found {describe(first['input'])}" if "input" in first and first["type"] != "missing" else ""
    msg = first["msg"]
    if first["type"] in ("greater_than_equal", "less_than_equal"):
        msg = f"must be a 64-bit integer (between {INT64_MIN} and {INT64_MAX})"
    return SimulationFileError(f"{where}: field {loc}: {msg}{found} ({len(err.errors())} problem(s) in all)",
                               path=path, field=loc)


# -- building simulations ----------------------------------------------------------------------------------


class _Reader:
    """Builds the simulations of one file; ``where`` starts every message, ``strict`` adds the strict checks."""

    def __init__(self, where: str, path: str | None, strict: bool) -> None:
        self.where = where
        self.path = path
        self.strict = strict

    def fail(self, field: str, message: str) -> SimulationFileError:
        at = f"field {field}: " if field else ""
        return SimulationFileError(f"{self.where}: {at}{message}", path=self.path, field=field or None)

    def objects(self, output: BareOutput, field: str) -> tuple[SimObject, ...]:
        states = output.scene_states or []
        if not states:
            raise self.fail(field, "no scene_states; a simulation needs its start and end states")
        for k, state in enumerate(states):
            if state.step < 0:
                raise self.fail(f"{field}scene_states.{k}.step",
                                f"a scene state has step {state.step}; allowed: 0 (start) or a later step")
            for j, o in enumerate(state.scene.objects):
                self.check_object(o, f"{field}scene_states.{k}.scene.objects.{j}")
        by_step = sorted(states, key=lambda s: s.step)
        start, end = by_step[0], by_step[-1]
        if start.step != 0:
            raise self.fail(f"{field}scene_states",
                            f"no scene state with step 0 (steps: {_few(s.step for s in states)})")
        if end.step == 0:
            raise self.fail(f"{field}scene_states", "no end state (a scene state with a step other than 0)")
        if self.strict and len(states) != 2:
            raise self.fail(f"{field}scene_states", f"{len(states)} scene states; strict: exactly 2 (step 0 and the "
                                                    "end step)")
        seen: set[int] = set()
        for o in start.scene.objects:
            if o.uniqueID in seen:
                raise self.fail(f"{field}scene_states", f"uniqueID {o.uniqueID} appears twice in the start state")
            seen.add(o.uniqueID)
        end_by_id = {o.uniqueID: o for o in end.scene.objects}
        objects = []
        for o in start.scene.objects:
            e = end_by_id.get(o.uniqueID)
            if e is None:
                raise self.fail(f"{field}scene_states",
                                f"object {o.uniqueID} ({o.shape}) is in the start state but not in the end state")
            objects.append(SimObject(o.uniqueID, o.shape, o.color, o.size, o.bodyType != 0, _state(o), _state(e)))
        if self.strict:
            self.check_scene(objects, f"{field}scene_states")
        return tuple(objects)

    def check_object(self, o: ObjectRecord, field: str) -> None:
        """The object's shape, colour, size and body type are values CRAFT knows."""
        for name, value, allowed in (("shape", o.shape, ALLOWED_SHAPES), ("color", o.color, ALLOWED_COLORS),
                                     ("size", o.size, ALLOWED_SIZES), ("bodyType", o.bodyType, BODY_TYPES)):
            if value not in allowed:
                raise self.fail(f"{field}.{name}", f"object {o.uniqueID} has {name} {describe(value)}; allowed: "
                                                   f"{', '.join(map(str, allowed))}")

    def check_scene(self, objects: list[SimObject], field: str) -> None:
        """Strict: dynamic objects look like CRAFT's (a shape, a colour, unique triples), static ones are black,
        large and still."""
        triples: dict[tuple[str, str, str], int] = {}
        for o in objects:
            if o.dynamic:
                if o.shape not in SHAPES or o.color not in COLORS:
                    raise self.fail(field, f"dynamic object {o.id} is a "
                                           f"{o.color} {o.shape}; strict: dynamic objects are one of "
                                           f"{', '.join(SHAPES)} in one of {', '.join(COLORS)}")
                triple = (o.shape, o.color, o.size)
                if triple in triples:
                    raise self.fail(field, f"objects {triples[triple]} and {o.id} are both {o.size} {o.color} "
                                           f"{o.shape}; strict: dynamic objects differ in shape, colour or size")
                triples[triple] = o.id
            else:
                if o.shape not in STATIC_SHAPES or o.color != STATIC_COLOR or o.size != STATIC_SIZE:
                    raise self.fail(field, f"static object {o.id} is a {o.size} {o.color} {o.shape}; strict: static "
                                           f"objects are {STATIC_SIZE} {STATIC_COLOR} {', '.join(STATIC_SHAPES)}")
                if any(st.velocity != (0.0, 0.0) for st in o.states):
                    raise self.fail(field, f"static object {o.id} ({o.shape}) moves; strict: static objects have "
                                           "velocity [0, 0]")

    def events(self, graph: CausalGraphRecord, field: str) -> tuple[list[Event], nx.DiGraph]:
        ordered = sorted(enumerate(graph.nodes), key=lambda p: p[1].step)  # stable: file order among ties
        new_id: dict[int, int] = {}
        events: list[Event] = []
        for new, (index, rec) in enumerate(ordered):
            where = f"{field}causal_graph.nodes.{index}"
            if rec.id in new_id:
                raise self.fail(f"{where}.id", f"event id {rec.id} appears twice")
            try:
                etype = canonical_event_type(rec.type)
            except ValueError as err:
                raise self.fail(f"{where}.type", str(err)) from None
            lowest = -1 if etype == START else 0
            if rec.step < lowest:
                raise self.fail(f"{where}.step", f"a {etype} event has step {rec.step}; allowed: 0 or more "
                                                 "(the Start event: -1 or more)")
            new_id[rec.id] = new
            events.append(Event(new, etype, rec.step, tuple(rec.objects)))
        dg = nx.DiGraph()
        for e in events:
            dg.add_node(e.id, type=e.type, step=e.step, objects=e.objects)
        for k, edge in enumerate(graph.edges):
            for target in (edge.from_, *edge.to):
                if target not in new_id:
                    raise self.fail(f"{field}causal_graph.edges.{k}",
                                    f"names event {target}, which is not in causal_graph.nodes")
            for t in edge.to:
                dg.add_edge(new_id[edge.from_], new_id[t])
        if not nx.is_directed_acyclic_graph(dg):
            file_id = {new: old for old, new in new_id.items()}
            cycle = [file_id[a] for a, _ in nx.find_cycle(dg)]
            path = " -> ".join(map(str, [*cycle, cycle[0]]))
            raise self.fail(f"{field}causal_graph.edges", f"the causal graph has a cycle ({path}); an event cannot "
                                                          "cause itself, directly or through others")
        if self.strict:
            self.check_events(graph, events, new_id, dg, field)
        return events, dg

    def check_events(self, graph: CausalGraphRecord, events: list[Event], new_id: dict[int, int], dg: nx.DiGraph,
                     field: str) -> None:
        """Strict: one Start (step -1) and one End (the last step), two objects per contact event (the basket
        first in EnterBasket), every event an edge source, edges forward in time."""
        where = f"{field}causal_graph.nodes"
        for kind, step in ((START, -1), (END, None)):
            found = [e for e in events if e.type == kind]
            if len(found) != 1 or (step is not None and found[0].step != step):
                raise self.fail(where, f"{len(found)} {kind} event(s){f' at step {found[0].step}' if found else ''}; "
                                       f"strict: exactly one{f' at step {step}' if step is not None else ''}")
        end_step = next(e.step for e in events if e.type == END)
        for e in events:
            if e.type in (START, END):
                if e.objects:
                    raise self.fail(where, f"the {e.type} event names objects {list(e.objects)}; strict: none")
                continue
            if len(e.objects) != 2 or e.objects[0] == e.objects[1]:
                raise self.fail(where, f"a {e.type} event at step {e.step} names objects {list(e.objects)}; strict: "
                                       "two different objects")
            if not 0 <= e.step <= end_step:
                raise self.fail(where, f"a {e.type} event at step {e.step}; strict: steps 0 to {end_step} (End)")
        sources = {edge.from_ for edge in graph.edges}
        missing = [rec.id for rec in graph.nodes if rec.id not in sources]
        if missing:
            raise self.fail(f"{field}causal_graph.edges", f"events {_few(missing)} have no edges entry; strict: "
                                                          "every event has one (its 'to' may be empty)")
        for a, b in dg.edges:
            if events[a].step >= events[b].step:
                raise self.fail(f"{field}causal_graph.edges",
                                f"an edge goes from a {events[a].type} at step {events[a].step} to a "
                                f"{events[b].type} at step {events[b].step}; strict: causes come strictly earlier")

    def build(self, output: BareOutput, objects: tuple[SimObject, ...], field: str, **kw: Any) -> Simulation:
        events, graph = self.events(output.causal_graph, field)
        end_steps = [e.step for e in events if e.type == END]
        state_steps = [s.step for s in output.scene_states or ()]
        steps = end_steps[0] if end_steps else max(state_steps + [e.step for e in events] + [0])
        try:
            return Simulation(objects, events, steps=steps, causal_graph=graph,
                              meta={"source": self.where, "video_filename": output.video_filename}, **kw)
        except SimulationFileError as err:
            raise self.fail(field.rstrip("."), str(err)) from None

    def variation(self, output: BareOutput, object_id: int, factual: tuple[SimObject, ...]) -> Simulation:
        field = f"variations_outputs.{object_id}."
        if output.scene_states:
            objects = self.objects(output, field)
            allowed = {o.id for o in factual} - {object_id}
            ids = {o.id for o in objects}
            if object_id in ids:
                raise self.fail(field.rstrip("."),
                                f"the variation without object {object_id} still contains object {object_id}")
            if ids - allowed:
                raise self.fail(field.rstrip("."), f"objects {_few(sorted(ids - allowed))} are not in the original "
                                                   f"scene (a variation holds the original objects less {object_id})")
        else:  # only the events were recorded: the scene is the factual one without the object
            objects = tuple(o for o in factual if o.id != object_id)
        return self.build(output, objects, field, removed=(object_id,))


def _few(values: Any, limit: int = 10) -> str:
    """At most ``limit`` values of a list, for messages."""
    items = list(values)
    shown = ", ".join(describe(v) for v in items[:limit])
    return f"[{shown}{', ...' if len(items) > limit else ''}]"


def _state(rec: ObjectRecord) -> ObjectState:
    return ObjectState(rec.coords, rec.angle, rec.linear_velocity, rec.angularVelocity, rec.awake)


def _variation_keys(variations: dict[str, BareOutput], sim: Simulation, reader: _Reader) -> dict[int, str]:
    """Object id -> key of every variation; a key that is not an object id of the scene is refused."""
    out: dict[int, str] = {}
    for key in variations:
        if not _ID_KEY.fullmatch(key) or not sim.has_object(int(key)):
            raise reader.fail("variations_outputs", f"key {describe(key)} is not an object id of the scene "
                                                    f"(ids: {list(sim.all_ids)})")
        if int(key) in out:
            raise reader.fail("variations_outputs", f"keys {out[int(key)]!r} and {key!r} name the same object")
        out[int(key)] = key
    if reader.strict:
        dynamic = sorted(o.id for o in sim.objects if o.dynamic)
        if sorted(out) != dynamic:
            raise reader.fail("variations_outputs", f"variations for objects {sorted(out)}; strict: one per dynamic "
                                                    f"object ({dynamic})")
    return out


def _variation_source(variations: dict[str, BareOutput], keys: dict[int, str], factual: tuple[SimObject, ...],
                      reader: _Reader) -> Any:
    def make(object_id: int) -> Simulation:
        if object_id not in keys:
            obj = next(o for o in factual if o.id == object_id)
            kind = "dynamic" if obj.dynamic else "static"
            available = ", ".join(keys[k] for k in sorted(keys))
            raise CounterfactualUnavailable(
                f"GetCounterfactEvents: {reader.where} has no variation for object {object_id} ({kind} {obj.size} "
                f"{obj.color} {obj.shape}); variations recorded for objects: {available or 'none'}"
            )
        return reader.variation(variations[keys[object_id]], object_id, factual)

    return make


def load_simulation(source: str | os.PathLike[str] | Mapping[str, Any], *, strict: bool = False) -> Simulation:
    """Load a recorded CRAFT simulation (path to a JSON file, or the parsed dict).

    Every variation is validated on load, so a malformed file fails here, not halfway through a run. What is
    refused by default and what ``strict`` adds is listed in docs/recorded.md; every refusal is a
    :class:`~craft_dsl.errors.SimulationFileError` naming the file, the field and what is allowed.
    """
    path: str | None = None
    if isinstance(source, Mapping):
        data: Any = source
        where = "<dict>"
    else:
        path = where = str(source)
        data = read_json(source, "simulation file", error=SimulationFileError)
    reader = _Reader(where, path, strict)
    if not isinstance(data, Mapping):
        raise reader.fail("", f"expected a JSON object, found {type(data).__name__}")
    try:
        if "original_video_output" in data:
            file = VariationsFile.model_validate(data)
            original, variations = file.original_video_output, file.variations_outputs
            field = "original_video_output."
        elif "causal_graph" in data:
            original, variations, field = BareOutput.model_validate(data), None, ""
        else:
            raise reader.fail("", "not a CRAFT simulation: expected the key 'original_video_output' (simulation with "
                                  "variations) or 'causal_graph' and 'scene_states' (bare output); found keys "
                                  f"{_few(sorted(map(str, data)))}")
    except ValidationError as err:
        raise _validation_error(err, where, path) from None
    objects = reader.objects(original, field)
    if variations is None:
        return reader.build(original, objects, field)
    holder: dict[int, str] = {}
    sim = reader.build(original, objects, field,
                       counterfactuals=_variation_source(variations, holder, objects, reader))
    holder.update(_variation_keys(variations, sim, reader))
    for object_id, key in holder.items():
        sim.provide_counterfactual(object_id, reader.variation(variations[key], object_id, objects))
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
