"""The one evaluation path: a plan's runs, before and after it is compiled, and its node values agree; a module
that fails raises from a plan and makes a node INVALID in a batch's run."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings

from craft_dsl import Program, Simulation, load_simulation
from craft_dsl.errors import CounterfactualUnavailable, EvaluationError
from craft_dsl.evaluator import (
    COMPILE_AFTER_RUNS,
    LITERAL,
    NO_INPUT,
    ONE,
    ONE_SIDE,
    OTHER,
    TWO,
    Plan,
    needed_nodes,
    operation,
    run_operations,
)
from craft_dsl.ir import RawNode
from craft_dsl.recorded import simulation_dict
from craft_dsl.strategies import programs
from craft_dsl.templates import first_instances
from craft_dsl.types import INVALID, DslType


@pytest.fixture(scope="module")
def sims(e1: Simulation) -> list[Simulation]:
    from craft_dsl.physics import simulate

    return [e1, load_simulation(simulation_dict(simulate(3, seed=1)))]


def _runs(program: Program, sim: Simulation) -> list[object]:
    """Every run of a fresh plan of ``program`` up to two past its compilation."""
    plan = Plan(program._checked.nodes)
    return [plan.run(sim) for _ in range(COMPILE_AFTER_RUNS + 2)]


def test_every_run_of_a_plan_gives_the_first_run_s_answer(sims: list[Simulation]) -> None:
    compared = 0
    for sim in sims:
        for _t, _p, program, _answer in first_instances(sim, include_dropped=True):
            runs = _runs(program, sim)
            assert all(r == runs[0] and type(r) is type(runs[0]) for r in runs), str(program)
            assert runs[0] == program.values(sim)[-1]
            compared += 1
    assert compared > 60


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(program=programs())
def test_drawn_programs_answer_alike_interpreted_and_compiled(e1: Simulation, program: Program) -> None:
    plan = Plan(program._checked.nodes)
    runs: list[object] = []
    for _ in range(COMPILE_AFTER_RUNS + 2):
        try:
            runs.append(plan.run(e1))
        except (CounterfactualUnavailable, EvaluationError) as err:  # E1 records some counterfactuals, 2 states
            runs.append(type(err))
    assert all(r is INVALID for r in runs) or all(r == runs[0] for r in runs)


def _node(module: str | None, inputs: tuple[int, ...] = (), values: tuple[str, ...] = ()) -> RawNode:
    return (module, inputs, values, DslType.OBJECT_SET, 0)


def test_each_call_shape_has_its_operation() -> None:
    assert operation(_node(None, values=("red",)))[0] == LITERAL
    assert operation(_node("SceneAtStart"))[0] == NO_INPUT
    assert operation(_node("Count", (0,)))[0] == ONE
    assert operation(_node("FilterColor", (0,), ("red",)))[0] == ONE_SIDE
    assert operation(_node("Union", (0, 1)))[0] == TWO
    assert operation(_node("Union", (0, 1), ("x",)))[0] == OTHER


def test_a_failing_module_raises_from_a_plan_and_is_invalid_in_a_batch(e1: Simulation) -> None:
    program = Program.parse("Count(SceneAtStart())")
    nodes = program._checked.nodes

    def fails(_sim: Simulation) -> object:
        raise CounterfactualUnavailable("no such run")

    ops = [operation(node) for node in nodes]
    ops[0] = (NO_INPUT, fails, 0, 0, ())
    order = needed_nodes(nodes, len(nodes) - 1)
    with pytest.raises(CounterfactualUnavailable):
        run_operations(ops, order, e1, [None] * len(nodes))
    slots: dict[int, object] = {}
    run_operations(ops, order, e1, slots, failure_is_invalid=True)
    assert slots[0] is INVALID and slots[len(nodes) - 1] is INVALID  # and the INVALID input is not called on


def test_only_the_needed_nodes_run() -> None:
    nodes = (_node("SceneAtStart"), _node("Events"), _node("Count", (0,)))
    assert needed_nodes(nodes, 2) == [0, 2]
    assert needed_nodes(nodes, 1) == [1]
