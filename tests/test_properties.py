"""Laws of the DSL checked with hypothesis over the public strategies (craft_dsl.strategies).

1. parse(str(p)) == p, the printed form is stable, and every other spelling of p (original module names,
   value synonyms, letter case, typographic quotes, the implicit Unique) parses to p;
2. set laws of Intersect / Union / Difference, and ascending results;
3. soundness of the type checker: a run returns INVALID or a value of the declared type (every node of the
   trace too), and raises nothing but CounterfactualUnavailable / EvaluationError (over the recorded scene E1
   here; over drawn and live simulations in tests/test_strategies.py);
4. Program.from_nodes(p.to_nodes()) == p for programs without literals (with Var bindings: its inlined form),
   and the last node's output is the answer;
5. the last trace entry's value is run()'s answer.
"""

from __future__ import annotations

import re
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import INVALID, MODULES, DslType, Program, Simulation
from craft_dsl.program import to_json
from craft_dsl.strategies import programs, simulations
from tests.dsl_values import ALLOWED_ERRORS, ascending_ids, check_run, conforms
from tests.program_text import inlined, read, respelled

T = DslType
SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# -- 1. round trip of the text form --------------------------------------------------------------------------


@SETTINGS
@given(programs())
def test_text_round_trip(p: Program) -> None:
    text = str(p)
    q = Program.parse(text)
    assert q == p
    assert str(q) == text
    assert q.type == p.type
    assert hash(q) == hash(p)


@SETTINGS
@given(programs(), st.data())
def test_every_spelling_parses_to_the_same_program(p: Program, data: st.DataObject) -> None:
    text = respelled(p, lambda options: data.draw(st.sampled_from(options)))
    assert Program.parse(text) == p, text


# -- 2. set laws ----------------------------------------------------------------------------------------------

#: Operands that always evaluate on a drawn simulation: no counterfactual (static objects have none) and no
#: Count, so that the only Integers are valid state indexes (StartSceneStep, EndSceneStep).
SET_MODULES = [m.name for m in MODULES if m.category != "counterfactual" and m.name != "Count"]
OPERANDS = programs(T.OBJECT_SET, max_depth=4, max_bindings=0, literals=False, modules=SET_MODULES)


@SETTINGS
@given(simulations(), OPERANDS, OPERANDS, OPERANDS)
def test_set_laws(sim: Simulation, pa: Program, pb: Program, pc: Program) -> None:
    binds = f"Var A = {pa}\nVar B = {pb}\nVar C = {pc}\n"

    def value(body: str) -> Any:
        return Program.parse(binds + body).run(sim)

    a, b, c = value("A"), value("B"), value("C")
    for v in (a, b, c):
        assert conforms(v, T.OBJECT_SET, sim)
    operand = {"A": a, "B": b, "C": c}

    def law(left: str, right: str, operands: tuple[Any, ...], expected: Any = None) -> None:
        values = []
        for side in (left, right):
            v = value(side)
            names = set(re.findall(r"\b[ABC]\b", side))
            if any(operand[n] is INVALID for n in names):
                assert v is INVALID, (side, v)  # INVALID in, INVALID out
            else:
                assert ascending_ids(v, sim), (side, v)
            values.append(v)
        if all(o is not INVALID for o in operands):
            assert values[0] == values[1], (left, right, values)
            if expected is not None:
                assert values[0] == expected, (left, values[0], expected)

    def ascending(s: set[int]) -> tuple[int, ...]:
        return tuple(sorted(s))

    valid = a is not INVALID and b is not INVALID and c is not INVALID
    law("Intersect(A, B)", "Intersect(B, A)", (a, b), ascending(set(a) & set(b)) if valid else None)
    law("Union(A, B)", "Union(B, A)", (a, b), ascending(set(a) | set(b)) if valid else None)
    law("Difference(A, B)", "Difference(A, Intersect(A, B))", (a, b), ascending(set(a) - set(b)) if valid else None)
    law("Intersect(Intersect(A, B), C)", "Intersect(A, Intersect(B, C))", (a, b, c))
    law("Union(Union(A, B), C)", "Union(A, Union(B, C))", (a, b, c))
    law("Difference(A, A)", "Difference(A, Union(A, A))", (a,), ())
    law("Intersect(A, Difference(B, A))", "Difference(Intersect(B, A), A)", (a, b), ())
    law("Union(Difference(A, B), Intersect(A, B))", "A", (a, b), a if valid else None)
    law("Union(A, A)", "Intersect(A, A)", (a,), a if valid else None)
    law("Intersect(A, Union(B, C))", "Union(Intersect(A, B), Intersect(A, C))", (a, b, c))


# -- 3. soundness of the type checker (and 5. trace) --------------------------------------------------------------


@SETTINGS
@given(programs())
def test_well_typed_programs_run_soundly_on_e1(e1: Simulation, p: Program) -> None:
    check_run(p, e1)


@settings(max_examples=100, deadline=None)
@given(st.sampled_from(list(T)), st.data())
def test_programs_of_each_declared_type(e1: Simulation, typ: DslType, data: st.DataObject) -> None:
    p = data.draw(programs(typ, max_depth=4))
    assert p.type is typ
    check_run(p, e1)


# -- 4. node lists ----------------------------------------------------------------------------------------------


@SETTINGS
@given(programs(max_bindings=0, literals=False))
def test_node_list_round_trip(p: Program) -> None:
    nodes = p.to_nodes()
    assert Program.from_nodes(nodes) == p
    # every node names an original module and only earlier nodes
    for k, node in enumerate(nodes):
        assert node["type"][0].islower()
        assert all(0 <= i < k for i in node["inputs"])


@SETTINGS
@given(programs(literals=False))
def test_node_list_of_a_program_with_bindings_is_its_inlined_form(p: Program) -> None:
    assert Program.from_nodes(p.to_nodes()) == inlined(p)
    if read(str(p)).bindings:
        assert "Var" not in str(inlined(p))


@settings(max_examples=60, deadline=None)
@given(programs(max_bindings=0, literals=False))
def test_node_outputs_end_with_the_answer(e1: Simulation, p: Program) -> None:
    try:
        answer = p.run(e1)
    except ALLOWED_ERRORS:
        return
    nodes = p.to_nodes(outputs=e1)
    assert nodes[-1]["_output"] == to_json(answer, original=True)
