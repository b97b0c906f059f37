"""Whether a value is a value of a DSL type over a simulation, and the soundness check of one program run."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from craft_dsl import INVALID, CounterfactualUnavailable, DslType, EvaluationError, Event, Program, Simulation
from craft_dsl.program import to_json
from craft_dsl.vocabulary import COLORS, SHAPES, SIZES, STATIC_COLOR, STATIC_SHAPES

T = DslType
#: The only errors a well-typed program may raise at run time: the simulation cannot provide what is asked.
ALLOWED_ERRORS = (CounterfactualUnavailable, EvaluationError)


def ascending_ids(value: Any, sim: Simulation) -> bool:
    return (isinstance(value, tuple) and all(type(o) is int and sim.has_object(o) for o in value)
            and all(a < b for a, b in zip(value, value[1:])))


def event_set(value: Any) -> bool:
    return (isinstance(value, tuple) and all(isinstance(e, Event) for e in value)
            and [(e.step, e.id) for e in value] == sorted((e.step, e.id) for e in value)
            and len({e.id for e in value}) == len(value))


def conforms(value: Any, typ: DslType, sim: Simulation) -> bool:
    """Whether ``value`` is INVALID or a value of DSL type ``typ`` over ``sim`` (the documented Python types)."""
    if value is INVALID:
        return True
    checks: dict[DslType, Callable[[Any], bool]] = {
        T.BOOL: lambda v: type(v) is bool,
        T.INTEGER: lambda v: type(v) is int,
        T.COLOR: lambda v: v in COLORS or v == STATIC_COLOR,
        T.SHAPE: lambda v: v in SHAPES or v in STATIC_SHAPES,
        T.SIZE: lambda v: v in SIZES,
        T.OBJECT: lambda v: type(v) is int and sim.has_object(v),
        T.OBJECT_SET: lambda v: ascending_ids(v, sim),
        T.EVENT: lambda v: isinstance(v, Event),
        T.EVENT_SET: event_set,
        T.OBJECT_SET_LIST: lambda v: isinstance(v, tuple) and all(ascending_ids(s, sim) for s in v),
        T.EVENT_SET_LIST: lambda v: isinstance(v, tuple) and all(event_set(s) for s in v),
        T.BOOL_LIST: lambda v: isinstance(v, tuple) and all(type(b) is bool for b in v),
    }
    return checks[typ](value)


def same(a: Any, b: Any) -> bool:
    return a is b if a is INVALID or b is INVALID else bool(a == b)


def check_run(p: Program, sim: Simulation) -> None:
    """Soundness of one run: the answer and every trace value conform to their types, the last trace entry is
    the answer, and the only errors are the allowed ones (raised by run and trace alike)."""
    try:
        answer = p.run(sim)
    except ALLOWED_ERRORS as err:
        assert str(err), "an error without a message"
        with pytest.raises(ALLOWED_ERRORS):
            p.trace(sim)
        return
    assert conforms(answer, p.type, sim), (str(p), answer)
    trace = p.trace(sim)
    for entry in trace:
        assert conforms(entry.value, entry.type, sim), (entry.expression, entry.type, entry.value)
    assert trace, str(p)
    assert same(trace[-1].value, answer), (str(p), trace[-1].value, answer)
    assert trace[-1].type == p.type
    json_answer = to_json(answer)
    assert json_answer == to_json(trace[-1].value)
