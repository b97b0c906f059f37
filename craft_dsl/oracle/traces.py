"""A model's intermediate outputs (a *trace*) against the oracle's, node by node.

A trace maps node numbers of the program it accompanies to the value the model computed there: an object
``{"3": [0, 2], "5": true}``, or a list with ``null`` for the nodes it does not give. Node k is node k of a node
list, the k-th module token of a token sequence, or the k-th call of DSL text in reading order. Values are
written as the dataset writes them:

============================  ===========================================================================
node type                     value
============================  ===========================================================================
Object                        an object id (``3``)
ObjectSet                     a list of object ids, in any order (``[0, 2]``)
Event                         ``{"type": "Collision", "step": 40, "objects": [3, 2]}`` (original type names
                              accepted, objects in any order), or the event's id in the simulation
EventSet                      a list of events
ObjectSetList, EventSetList   a list of those, in the order of the objects they were computed for
Bool, BoolList                ``true``/``false`` (``"yes"``/``"no"``, ``"True"`` accepted), or a list of them
Integer                       an integer (``2`` or ``"2"``)
Color, Shape, Size            the word, in any letter case (``"Red"``)
INVALID (any type)            ``"__INVALID__"`` or ``"INVALID"``
============================  ===========================================================================

A value that does not have the shape its node's type asks for is bad input (:class:`TraceError`), not a
disagreement: it is a bug in the code writing the trace, and it is reported with the node and the type.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..errors import CraftError
from ..ir import node_texts
from ..program import Program, to_json
from ..simulation import Event, Simulation
from ..types import INVALID, DslType
from ..verify.answers import normalise_answer
from ..vocabulary import EVENT_TYPE_ALIASES, EVENT_TYPES

_INVALID_WORDS = ("__INVALID__", "INVALID")
_LISTS = {DslType.OBJECT_SET_LIST: DslType.OBJECT_SET, DslType.EVENT_SET_LIST: DslType.EVENT_SET,
          DslType.BOOL_LIST: DslType.BOOL}


class TraceError(CraftError):
    """A trace names a node that does not exist, or gives a value of the wrong shape for its node."""


@dataclass(frozen=True)
class Divergence:
    """The first node (in evaluation order) where the model's output differs from the oracle's."""

    node: int
    module: str
    expression: str
    expected: Any
    found: Any

    def to_json(self) -> dict[str, Any]:
        return {"node": self.node, "module": self.module, "expression": self.expression,
                "expected": self.expected, "found": self.found}


@dataclass
class TraceComparison:
    """One trace against the oracle: nodes compared and agreeing, per module, and the first divergence."""

    compared: int = 0
    agreed: int = 0
    #: Nodes the trace gives but the answer does not use (not compared).
    unused: int = 0
    per_module: dict[str, list[int]] = field(default_factory=dict)  # module -> [compared, agreed]
    first_divergence: Divergence | None = None

    def to_json(self) -> dict[str, Any]:
        return {"compared": self.compared, "agreed": self.agreed, "unused": self.unused,
                "first_divergence": self.first_divergence.to_json() if self.first_divergence else None}


def trace_entries(trace: Any, n_nodes: int, where: str = "trace") -> dict[int, Any]:
    """The ``{node: value}`` of a trace written as an object or a list; errors name the node."""
    if isinstance(trace, Mapping):
        out: dict[int, Any] = {}
        for key, value in trace.items():
            text = str(key).strip()
            if not text.isdigit() or len(text) > 9:
                raise TraceError(f"{where}: key {key!r} is not a node number (0..{n_nodes - 1})")
            out[int(text)] = value
    elif isinstance(trace, Sequence) and not isinstance(trace, str):
        out = {k: v for k, v in enumerate(trace) if v is not None}
        if len(trace) > n_nodes:
            raise TraceError(f"{where}: the trace lists {len(trace)} values but the program has {n_nodes} nodes")
    else:
        raise TraceError(f"{where}: expected an object {{node: value}} or a list of values, found "
                         f"{type(trace).__name__}")
    for k in out:
        if k >= n_nodes:
            raise TraceError(f"{where}: node {k} does not exist (the program has nodes 0..{n_nodes - 1})")
    return out


def compare_trace(program: Program, sim: Simulation, trace: Any, where: str = "trace") -> TraceComparison:
    """Compare a model's trace of ``program`` (numbered as :attr:`Program.source_nodes`) with the oracle's."""
    sources = program.source_nodes
    entries = trace_entries(trace, len(sources), where)
    values = program.values(sim)
    nodes = program.nodes
    result = TraceComparison()
    given: dict[int, tuple[int, Any]] = {}  # canonical node -> (source node, model value)
    for k, value in entries.items():
        canonical = sources[k]
        if canonical is None:
            result.unused += 1
        else:
            given[canonical] = (k, value)
    texts: list[str] | None = None
    for i in sorted(given):
        k, value = given[i]
        node = nodes[i]
        module = str(node.module)
        agree = values_agree(values[i], value, node.type, sim, f"{where}: node {k} ({module}, {node.type})")
        counts = result.per_module.setdefault(module, [0, 0])
        counts[0] += 1
        result.compared += 1
        if agree:
            counts[1] += 1
            result.agreed += 1
        elif result.first_divergence is None:
            texts = texts or node_texts(nodes)
            result.first_divergence = Divergence(k, module, texts[i], to_json(values[i]), value)
    return result


def values_agree(oracle: Any, model: Any, typ: DslType, sim: Simulation, where: str) -> bool:
    """Whether a model's value equals the oracle's value of a node of type ``typ`` (see the module docstring)."""
    if isinstance(model, str) and model.strip() in _INVALID_WORDS:
        return oracle is INVALID
    normalised = _normalise(model, typ, sim, where)
    return oracle is not INVALID and normalised == _normalise_oracle(oracle, typ)


def _normalise_oracle(value: Any, typ: DslType) -> Any:
    if typ in _LISTS:
        return tuple(_normalise_oracle(v, _LISTS[typ]) for v in value)
    if typ == DslType.OBJECT_SET:
        return frozenset(value)
    if typ == DslType.EVENT:
        return _event_key(value)
    if typ == DslType.EVENT_SET:
        return frozenset(_event_key(e) for e in value)
    if typ in (DslType.BOOL, DslType.INTEGER, DslType.COLOR, DslType.SHAPE, DslType.SIZE):
        return normalise_answer(value)
    return value


def _event_key(event: Event) -> tuple[str, int, frozenset[int]]:
    return (event.type, event.step, frozenset(event.objects))


def _normalise(value: Any, typ: DslType, sim: Simulation, where: str) -> Any:
    if typ in _LISTS:
        if not isinstance(value, list):
            raise TraceError(f"{where}: expected a list, found {_show(value)}")
        return tuple(_normalise(v, _LISTS[typ], sim, f"{where}[{k}]") for k, v in enumerate(value))
    if typ == DslType.OBJECT:
        return _object_id(value, where)
    if typ == DslType.OBJECT_SET:
        if not isinstance(value, list):
            raise TraceError(f"{where}: expected a list of object ids, found {_show(value)}")
        return frozenset(_object_id(v, f"{where}[{k}]") for k, v in enumerate(value))
    if typ == DslType.EVENT:
        return _model_event(value, sim, where)
    if typ == DslType.EVENT_SET:
        if not isinstance(value, list):
            raise TraceError(f"{where}: expected a list of events, found {_show(value)}")
        return frozenset(_model_event(v, sim, f"{where}[{k}]") for k, v in enumerate(value))
    if typ == DslType.BOOL:
        if isinstance(value, bool) or (isinstance(value, str) and normalise_answer(value) in ("true", "false")):
            return normalise_answer(value)
        raise TraceError(f"{where}: expected true or false, found {_show(value)}")
    if typ == DslType.INTEGER:
        key = normalise_answer(value) if isinstance(value, (int, float, str)) and not isinstance(value, bool) else None
        if key is None or not key.lstrip("-").isdigit():
            raise TraceError(f"{where}: expected an integer, found {_show(value)}")
        return key
    if isinstance(value, str):
        return normalise_answer(value)
    raise TraceError(f"{where}: expected a {typ} word, found {_show(value)}")


def _object_id(value: Any, where: str) -> int:
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    raise TraceError(f"{where}: expected an object id (an integer), found {_show(value)}")


def _model_event(value: Any, sim: Simulation, where: str) -> tuple[str, int, frozenset[int]]:
    if isinstance(value, int) and not isinstance(value, bool):
        found = next((e for e in sim.events if e.id == value), None)
        if found is None:
            raise TraceError(f"{where}: event id {value} is not an event of the simulation "
                             f"(ids 0..{len(sim.events) - 1})")
        return _event_key(found)
    if not isinstance(value, Mapping) or "type" not in value or "step" not in value:
        raise TraceError(f"{where}: expected an event {{\"type\", \"step\", \"objects\"}} or an event id, "
                         f"found {_show(value)}")
    etype = EVENT_TYPE_ALIASES.get(str(value["type"]), str(value["type"]))
    if etype not in EVENT_TYPES:
        raise TraceError(f"{where}: unknown event type {value['type']!r}; allowed: "
                         f"{', '.join(EVENT_TYPES + tuple(EVENT_TYPE_ALIASES))}")
    step, objects = value["step"], value.get("objects", [])
    if not isinstance(step, int) or isinstance(step, bool):
        raise TraceError(f"{where}: field 'step' must be an integer, found {_show(step)}")
    if not isinstance(objects, list):
        raise TraceError(f"{where}: field 'objects' must be a list of object ids, found {_show(objects)}")
    return (etype, step, frozenset(_object_id(o, f"{where}.objects") for o in objects))


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
