"""Unit tests of every functional module of craft_dsl.registry.MODULES.

Values are checked on scene E1 (the worked example with the original engine's answers) and on hand-made
simulations built with ``conftest.make_sim``. Every module of the registry must appear in at least one
program written in this file (see ``test_every_registered_module_is_exercised``).

E1 in brief: static 8 wall_l, 7 wall_r, 6 ground, 5 basket, 4 platform; dynamic 3 large red cube (moving at
start), 2 small blue circle, 1 small green triangle, 0 large yellow circle (moving at start). Events (file
order): 40 red-blue, 40 yellow-platform, 80 blue enters, 82 blue-basket, 85 TouchStart basket-blue,
120 yellow-green, 140 green-ground, 145 TouchStart ground-green, 150 yellow enters, 170 blue re-enters,
170 red-ground, 200 red-yellow, End 600.
"""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path
from typing import Any

import pytest

from craft_dsl import (
    INVALID,
    MODULES,
    REGISTRY,
    CounterfactualUnavailable,
    DslType,
    EvaluationError,
    Event,
    Simulation,
    parse,
)
from craft_dsl.registry import lookup
from tests.conftest import BASIC_OBJECTS, make_sim

T = DslType

# Object expressions of E1 (the checker inserts Unique where one Object is expected).
RED = 'FilterColor(SceneAtStart(), "red")'
BLUE = 'FilterColor(SceneAtStart(), "blue")'
GREEN = 'FilterColor(SceneAtStart(), "green")'
YELLOW = 'FilterColor(SceneAtStart(), "yellow")'
# The ground, reached without a shape filter (no shape filter keeps static objects).
GROUND = "Difference(FilterObjectsFromEvents(FilterCollideGround(Events())), FilterDynamic(SceneAtStart()))"


def run(text: str, sim: Simulation) -> Any:
    return parse(text).run(sim)


def kinds(events: Any) -> list[tuple[str, int, tuple[int, ...]]]:
    """(type, step, objects) of every event of an EventSet value."""
    return [(e.type, e.step, e.objects) for e in events]


# -- scenes and steps -------------------------------------------------------------------------------


def test_scene_at_start_and_end_hold_every_object_ascending(e1: Simulation) -> None:
    assert run("SceneAtStart()", e1) == (0, 1, 2, 3, 4, 5, 6, 7, 8)
    assert run("SceneAtEnd()", e1) == (0, 1, 2, 3, 4, 5, 6, 7, 8)
    assert parse("SceneAtEnd()").type is T.OBJECT_SET


def test_start_and_end_scene_step_are_state_indexes(e1: Simulation) -> None:
    assert run("StartSceneStep()", e1) == 0
    assert run("EndSceneStep()", e1) == -1
    assert parse("EndSceneStep()").type is T.INTEGER


def test_events_include_start_and_end_in_time_order(e1: Simulation) -> None:
    evs = run("Events()", e1)
    assert isinstance(evs, tuple) and all(isinstance(e, Event) for e in evs)
    assert evs[0].type == "Start" and evs[0].step == -1 and evs[0].objects == ()
    assert evs[-1].type == "End" and evs[-1].step == 600 and evs[-1].objects == ()
    assert [(e.step, e.id) for e in evs] == sorted((e.step, e.id) for e in evs)
    assert len(evs) == 14
    # original type strings are read as the canonical names
    assert {e.type for e in evs} == {"Start", "End", "Collision", "TouchStart", "EnterBasket"}


# -- object filters ---------------------------------------------------------------------------------


def test_attribute_filters(e1: Simulation) -> None:
    assert run(RED, e1) == (3,)
    assert run('FilterShape(SceneAtStart(), "circle")', e1) == (0, 2)
    assert run('FilterSize(SceneAtStart(), "small")', e1) == (1, 2)
    # static elements are large
    assert run('FilterSize(SceneAtStart(), "large")', e1) == (0, 3, 4, 5, 6, 7, 8)
    assert run('FilterShape(FilterColor(FilterSize(SceneAtStart(), "small"), "blue"), "circle")', e1) == (2,)
    assert run('FilterColor(SceneAtStart(), "purple")', e1) == ()


@pytest.mark.parametrize("shape", ["cube", "triangle", "circle"])
def test_no_shape_filter_keeps_a_static_object(e1: Simulation, shape: str) -> None:
    kept = run(f'FilterShape(SceneAtStart(), "{shape}")', e1)
    assert set(kept) <= {0, 1, 2, 3}


def test_filter_dynamic(e1: Simulation) -> None:
    assert run("FilterDynamic(SceneAtStart())", e1) == (0, 1, 2, 3)
    assert run(f"FilterDynamic({GROUND})", e1) == ()


def test_filter_moving_and_stationary_on_e1(e1: Simulation) -> None:
    assert run("FilterMoving(SceneAtStart(), StartSceneStep())", e1) == (0, 3)
    # blue's end speed 0.0005 is below the threshold, yellow's -0.002 is above
    assert run("FilterMoving(SceneAtEnd(), EndSceneStep())", e1) == (0, 1)
    # static bodies are always stationary
    assert run("FilterStationary(SceneAtStart(), StartSceneStep())", e1) == (1, 2, 4, 5, 6, 7, 8)
    assert run("FilterStationary(SceneAtEnd(), EndSceneStep())", e1) == (2, 3, 4, 5, 6, 7, 8)


@pytest.mark.parametrize(
    ("velocity", "moving"),
    [
        ((0.001, 0.0), False),  # exactly the threshold: not moving (strict >)
        ((0.0011, 0.0), True),
        ((-0.0011, 0.0), True),  # negative values: absolute value
        ((0.0, -0.0011), True),
        ((0.0, 0.001), False),
        ((-0.001, -0.001), False),
        ((0.0009, 0.0009), False),  # per component: norm 0.00127 > 0.001 but each component is below
        ((0.0, 0.0), False),
        ((5.0, -3.0), True),
    ],
)
def test_moving_threshold_per_component(velocity: tuple[float, float], moving: bool) -> None:
    sim = make_sim([(6, "ground"), (5, "basket"), (0, "small red cube", velocity, velocity)])
    for index in ("StartSceneStep()", "EndSceneStep()", "0", "-1"):
        assert run(f"FilterMoving(SceneAtStart(), {index})", sim) == ((0,) if moving else ())
        assert run(f"FilterStationary(SceneAtStart(), {index})", sim) == ((5, 6) if moving else (0, 5, 6))


def test_static_object_with_a_velocity_is_never_moving() -> None:
    sim = make_sim([(6, "ground", (3.0, 3.0), (3.0, 3.0)), (5, "basket"), (4, "platform", (1.0, 0.0)),
                    (0, "small red cube")])
    assert run("FilterMoving(SceneAtStart(), StartSceneStep())", sim) == ()
    assert run("FilterMoving(SceneAtStart(), EndSceneStep())", sim) == ()
    assert run("FilterStationary(SceneAtStart(), StartSceneStep())", sim) == (0, 4, 5, 6)


def test_state_index_out_of_range_is_an_evaluation_error(e1: Simulation) -> None:
    with pytest.raises(EvaluationError, match="out of range"):
        run("FilterMoving(SceneAtStart(), 2)", e1)
    with pytest.raises(EvaluationError):
        run("FilterStationary(SceneAtStart(), Count(SceneAtStart()))", e1)


def test_unique(e1: Simulation) -> None:
    assert run(f"Unique({RED})", e1) == 3
    assert run('Unique(FilterColor(SceneAtStart(), "purple"))', e1) is INVALID  # 0 objects
    assert run('Unique(FilterShape(SceneAtStart(), "circle"))', e1) is INVALID  # 2 objects
    assert parse(f"Unique({RED})").type is T.OBJECT


def test_as_list(e1: Simulation) -> None:
    assert run(f"AsList({BLUE})", e1) == (2,)
    assert run(f"AsList(Unique({BLUE}))", e1) == (2,)


# -- queries ------------------------------------------------------------------------------------------


def test_queries_of_dynamic_objects(e1: Simulation) -> None:
    assert run(f"QueryColor({GREEN})", e1) == "green"
    assert run(f"QueryShape({GREEN})", e1) == "triangle"
    assert run(f"QuerySize({GREEN})", e1) == "small"
    assert parse(f"QueryColor({GREEN})").type is T.COLOR
    assert parse(f"QueryShape({GREEN})").type is T.SHAPE
    assert parse(f"QuerySize({GREEN})").type is T.SIZE


def test_queries_of_a_static_object_black_and_large(e1: Simulation) -> None:
    assert run(f"QueryColor({GROUND})", e1) == "black"
    assert run(f"QueryShape({GROUND})", e1) == "ground"
    assert run(f"QuerySize({GROUND})", e1) == "large"


# -- set algebra -------------------------------------------------------------------------------------------


def test_set_algebra(e1: Simulation) -> None:
    circles = 'FilterShape(SceneAtStart(), "circle")'  # (0, 2)
    small = 'FilterSize(SceneAtStart(), "small")'  # (1, 2)
    assert run(f"Intersect({circles}, {small})", e1) == (2,)
    assert run(f"Union({circles}, {small})", e1) == (0, 1, 2)
    assert run(f"Union(AsList({RED}), {circles})", e1) == (0, 2, 3)  # ascending, not concatenated
    assert run(f"Difference({circles}, {small})", e1) == (0,)
    assert run(f"Difference({small}, {circles})", e1) == (1,)
    assert run(f"Difference({small}, {small})", e1) == ()
    assert run(f"Intersect({circles}, AsList({RED}))", e1) == ()


def test_intersect_list(e1: Simulation) -> None:
    program = (
        "IntersectList(FilterObjectsFromEventsList(FilterEnterBasketList("
        f"GetCounterfactEventsList(FilterDynamic(SceneAtStart())))), Union(AsList({RED}), AsList({BLUE})))"
    )
    # removing 0: blue enters twice; 1: blue; 2: red enters; 3: nothing of red/blue enters
    assert run(program, e1) == ((2,), (2,), (3,), ())
    assert parse(program).type is T.OBJECT_SET_LIST


# -- counting and logic ----------------------------------------------------------------------------------------


def test_count_and_exist_overloads(e1: Simulation) -> None:
    assert run("Count(SceneAtStart())", e1) == 9
    assert run("Count(Events())", e1) == 14
    assert run("Count(FilterEnterBasket(Events()))", e1) == 3
    assert run('Count(FilterColor(SceneAtStart(), "cyan"))', e1) == 0
    assert run(f"Count(FilterCollideBasket(FilterEvents(Events(), {RED})))", e1) == 0
    assert run("Exist(SceneAtStart())", e1) is True
    assert run('Exist(FilterColor(SceneAtStart(), "cyan"))', e1) is False
    assert run("Exist(FilterEnterBasket(Events()))", e1) is True
    assert run(f"Exist(FilterEnterBasket(FilterEvents(Events(), {RED})))", e1) is False
    assert parse("Exist(Events())").type is T.BOOL
    assert parse("Count(Events())").type is T.INTEGER


def test_event_exist_alias_on_event_sets(e1: Simulation) -> None:
    assert parse("event_exist(Events())") == parse("Exist(Events())")
    assert run(f"event_exist(FilterEnterBasket(FilterEvents(Events(), {YELLOW})))", e1) is True


ALL_CF = "GetCounterfactEventsList(FilterDynamic(SceneAtStart()))"
NO_CF = 'GetCounterfactEventsList(FilterColor(SceneAtStart(), "purple"))'


def test_exist_list_on_both_list_types(e1: Simulation) -> None:
    # EventSetList: collisions with the basket when 0, 1, 2, 3 is removed
    assert run(f"ExistList(FilterCollideBasketList({ALL_CF}))", e1) == (True, True, False, False)
    # ObjectSetList: does red enter the basket when 0, 1, 2, 3 is removed
    red_enters = (f"ExistList(IntersectList(FilterObjectsFromEventsList(FilterEnterBasketList({ALL_CF})), "
                  f"AsList({RED})))")
    assert run(red_enters, e1) == (False, False, True, False)
    assert parse(red_enters).type is T.BOOL_LIST
    assert run(f"ExistList({NO_CF})", e1) == ()


def test_any_true_any_false(e1: Simulation) -> None:
    mixed = f"ExistList(FilterCollideBasketList({ALL_CF}))"  # (True, True, False, False)
    all_true = f"ExistList({ALL_CF})"  # every counterfactual has at least Start and End
    empty = f"ExistList({NO_CF})"
    assert run(f"AnyTrue({mixed})", e1) is True
    assert run(f"AnyFalse({mixed})", e1) is True
    assert run(f"AnyTrue({all_true})", e1) is True
    assert run(f"AnyFalse({all_true})", e1) is False
    assert run(f"AnyTrue(ExistList(FilterCollideBasketList({NO_CF})))", e1) is False
    # empty lists: both False
    assert run(f"AnyTrue({empty})", e1) is False
    assert run(f"AnyFalse({empty})", e1) is False


def test_comparison_modules(e1: Simulation) -> None:
    assert run(f"EqualColor(QueryColor({RED}), QueryColor({RED}))", e1) is True
    assert run(f"EqualColor(QueryColor({RED}), QueryColor({BLUE}))", e1) is False
    assert run(f"EqualShape(QueryShape({YELLOW}), QueryShape({BLUE}))", e1) is True  # both circles
    assert run(f"EqualShape(QueryShape({YELLOW}), QueryShape({RED}))", e1) is False
    assert run(f"EqualSize(QuerySize({GREEN}), QuerySize({BLUE}))", e1) is True
    assert run(f"EqualSize(QuerySize({GREEN}), QuerySize({RED}))", e1) is False
    assert run("EqualInteger(Count(FilterDynamic(SceneAtStart())), 4)", e1) is True
    assert run("EqualInteger(Count(SceneAtStart()), Count(SceneAtEnd()))", e1) is True
    assert run("EqualInteger(StartSceneStep(), EndSceneStep())", e1) is False
    first_partner_of_red = f"EventPartner(FilterFirst(FilterEvents(Events(), {RED})), {RED})"
    assert run(f"EqualObject({first_partner_of_red}, {BLUE})", e1) is True
    assert run(f"EqualObject({first_partner_of_red}, {GREEN})", e1) is False
    assert run("LessThan(Count(FilterDynamic(SceneAtStart())), Count(SceneAtStart()))", e1) is True
    assert run("LessThan(4, 4)", e1) is False
    assert run("LessThan(-1, 0)", e1) is True
    assert run("GreaterThan(Count(Events()), 13)", e1) is True
    assert run("GreaterThan(3, 3)", e1) is False
    for name in ("EqualColor", "EqualShape", "EqualSize", "EqualInteger", "EqualObject", "LessThan",
                 "GreaterThan"):
        assert REGISTRY[name].overloads[0].output is T.BOOL


def test_comparisons_propagate_invalid(e1: Simulation) -> None:
    nobody = 'FilterColor(SceneAtStart(), "purple")'
    # INVALID == INVALID must not answer True
    assert run(f"EqualObject({nobody}, {nobody})", e1) is INVALID
    assert run(f"EqualColor(QueryColor({nobody}), QueryColor({nobody}))", e1) is INVALID


# -- events -------------------------------------------------------------------------------------------


def test_filter_events(e1: Simulation) -> None:
    assert kinds(run(f"FilterEvents(Events(), {GREEN})", e1)) == [
        ("Collision", 120, (0, 1)), ("Collision", 140, (1, 6)), ("TouchStart", 145, (6, 1))]
    # a static object's events: the basket takes part in entries, collisions and touches
    basket = "Difference(FilterObjectsFromEvents(FilterEnterBasket(Events())), FilterDynamic(SceneAtStart()))"
    assert [e.step for e in run(f"FilterEvents(Events(), {basket})", e1)] == [80, 82, 85, 150, 170]
    # Start/End never match
    evs = run(f"FilterEvents(Events(), {BLUE})", e1)
    assert all(e.type not in ("Start", "End") for e in evs)
    assert [e.step for e in evs] == [40, 80, 82, 85, 170]


def test_filter_collision_only_collisions(e1: Simulation) -> None:
    evs = run("FilterCollision(Events())", e1)
    assert {e.type for e in evs} == {"Collision"}
    assert [e.step for e in evs] == [40, 40, 82, 120, 140, 170, 200]


def test_filter_collision_with_dynamics_only_dynamic_pairs(e1: Simulation) -> None:
    assert kinds(run("FilterCollisionWithDynamics(Events())", e1)) == [
        ("Collision", 40, (3, 2)), ("Collision", 120, (0, 1)), ("Collision", 200, (3, 0))]
    # a long contact between two dynamic objects is not a collision
    sim = make_sim(BASIC_OBJECTS, [(10, "TouchStart", 3, 2), (50, "TouchEnd", 3, 2), (60, "Collision", 2, 4)])
    assert run("FilterCollisionWithDynamics(Events())", sim) == ()


def test_filter_collide_ground_counts_only_collisions(e1: Simulation) -> None:
    # green has Collision@140 and TouchStart@145 with the ground: only the collision counts
    assert kinds(run("FilterCollideGround(Events())", e1)) == [("Collision", 140, (1, 6)), ("Collision", 170, (3, 6))]
    sim = make_sim(BASIC_OBJECTS, [(30, "TouchStart", 6, 0), (90, "TouchEnd", 6, 0), (95, "Collision", 1, 4)])
    assert run("FilterCollideGround(Events())", sim) == ()
    assert run("Count(FilterObjectsFromEvents(FilterCollideGround(Events())))", sim) == 0


def test_filter_collide_basket_counts_only_collisions(e1: Simulation) -> None:
    # blue: enters@80, Collision with the basket@82, TouchStart@85: only @82 counts
    assert kinds(run("FilterCollideBasket(Events())", e1)) == [("Collision", 82, (2, 5))]


def test_filter_enter_basket_and_re_entries(e1: Simulation) -> None:
    entries = run("FilterEnterBasket(Events())", e1)
    assert kinds(entries) == [("EnterBasket", 80, (5, 2)), ("EnterBasket", 150, (5, 0)),
                              ("EnterBasket", 170, (5, 2))]
    assert run(f"Count(FilterEnterBasket(FilterEvents(Events(), {BLUE})))", e1) == 2
    assert run(f"FilterLast(FilterEnterBasket(FilterEvents(Events(), {BLUE})))", e1).step == 170
    # entries after blue's first entry include blue itself again (descriptive_16's surprise)
    after = f"FilterAfter(FilterEnterBasket(Events()), FilterFirst(FilterEnterBasket(FilterEvents(Events(), {BLUE}))))"
    assert run(f"FilterObjectsFromEvents({after})", e1) == (0, 2, 5)


def test_list_versions_of_event_filters(e1: Simulation) -> None:
    assert [len(s) for s in run(f"FilterCollideGroundList({ALL_CF})", e1)] == [1, 2, 1, 1]
    assert [len(s) for s in run(f"FilterCollideBasketList({ALL_CF})", e1)] == [1, 1, 0, 0]
    assert [len(s) for s in run(f"FilterEnterBasketList({ALL_CF})", e1)] == [2, 1, 2, 1]
    assert run(f"FilterObjectsFromEventsList(FilterEnterBasketList({ALL_CF}))", e1) == (
        (2, 5), (2, 5), (0, 3, 5), (0, 5))
    assert run(f"FilterEnterBasketList({NO_CF})", e1) == ()


TIES = make_sim(
    BASIC_OBJECTS,
    [(40, "Collision", 3, 2), (40, "Collision", 0, 4), (60, "Collision", 1, 6), (60, "Collision", 3, 6),
     (80, "EnterBasket", 5, 0)],
)
FIRST = "FilterFirst(FilterCollision(Events()))"  # red-blue@40 (listed first)
SECOND = "FilterLast(FilterCollideGround(FilterBefore(Events(), FilterLast(FilterEnterBasket(Events())))))"


def test_filter_first_and_last_follow_the_order_among_ties() -> None:
    assert kinds([run(FIRST, TIES)]) == [("Collision", 40, (3, 2))]
    assert kinds([run("FilterLast(FilterCollisionWithDynamics(Events()))", TIES)]) == [("Collision", 40, (3, 2))]
    assert kinds([run("FilterLast(FilterBefore(Events(), FilterFirst(FilterCollideGround(Events()))))", TIES)]) == [
        ("Collision", 40, (0, 4))]
    assert kinds([run("FilterFirst(FilterCollideGround(Events()))", TIES)]) == [("Collision", 60, (1, 6))]
    assert kinds([run("FilterLast(FilterCollideGround(Events()))", TIES)]) == [("Collision", 60, (3, 6))]


def test_filter_first_last_of_e1_ties(e1: Simulation) -> None:
    # red-blue and yellow-platform are both at step 40; the file lists red-blue first
    assert kinds([run("FilterFirst(FilterCollision(Events()))", e1)]) == [("Collision", 40, (3, 2))]
    assert kinds([run("FilterFirst(Events())", e1)]) == [("Start", -1, ())]
    assert kinds([run("FilterLast(Events())", e1)]) == [("End", 600, ())]


def test_filter_first_last_of_empty_are_invalid(e1: Simulation) -> None:
    empty = f"FilterEnterBasket(FilterEvents(Events(), {RED}))"
    assert run(empty, e1) == ()
    assert run(f"FilterFirst({empty})", e1) is INVALID
    assert run(f"FilterLast({empty})", e1) is INVALID
    # ... and the INVALID reaches the answer
    assert run(f"Exist(FilterAfter(Events(), FilterFirst({empty})))", e1) is INVALID
    assert run(f"Count(FilterBefore(Events(), FilterLast({empty})))", e1) is INVALID


def test_filter_before_after_are_strict_on_ties() -> None:
    # reference: the first collision, red-blue@40; yellow-platform@40 is neither before nor after
    before = run(f"FilterBefore(Events(), {FIRST})", TIES)
    after = run(f"FilterAfter(Events(), {FIRST})", TIES)
    assert kinds(before) == [("Start", -1, ())]
    assert [e.step for e in after] == [60, 60, 80, 600]
    assert all(e.step != 40 for e in before + after)
    # ties at 60: neither ground collision is before the other
    first_ground = "FilterFirst(FilterCollideGround(Events()))"
    last_ground = "FilterLast(FilterCollideGround(Events()))"
    assert run(f"FilterBefore(FilterCollideGround(Events()), {last_ground})", TIES) == ()
    assert run(f"FilterAfter(FilterCollideGround(Events()), {first_ground})", TIES) == ()


def test_is_before_is_after(e1: Simulation) -> None:
    blue_in = f"FilterFirst(FilterEnterBasket(FilterEvents(Events(), {BLUE})))"  # @80
    yellow_in = f"FilterFirst(FilterEnterBasket(FilterEvents(Events(), {YELLOW})))"  # @150
    assert run(f"IsBefore({blue_in}, {yellow_in})", e1) is True
    assert run(f"IsBefore({yellow_in}, {blue_in})", e1) is False
    assert run(f"IsAfter({yellow_in}, {blue_in})", e1) is True
    assert run(f"IsAfter({blue_in}, {yellow_in})", e1) is False
    # an event is neither before nor after itself
    assert run(f"IsBefore({blue_in}, {blue_in})", e1) is False
    assert run(f"IsAfter({blue_in}, {blue_in})", e1) is False


def test_is_before_tie_is_false_both_ways() -> None:
    a = "FilterFirst(FilterCollideGround(Events()))"
    b = "FilterLast(FilterCollideGround(Events()))"
    assert run(f"IsBefore({a}, {b})", TIES) is False
    assert run(f"IsBefore({b}, {a})", TIES) is False
    assert run(f"IsAfter({a}, {b})", TIES) is False
    assert run(f"IsAfter({b}, {a})", TIES) is False
    # same-step first entries of two objects: False both ways
    sim = make_sim(BASIC_OBJECTS, [(80, "EnterBasket", 5, 0), (80, "EnterBasket", 5, 2)])
    zero_in = 'FilterFirst(FilterEnterBasket(FilterEvents(Events(), FilterColor(SceneAtStart(), "yellow"))))'
    two_in = 'FilterFirst(FilterEnterBasket(FilterEvents(Events(), FilterColor(SceneAtStart(), "blue"))))'
    assert run(f"IsBefore({zero_in}, {two_in})", sim) is False
    assert run(f"IsBefore({two_in}, {zero_in})", sim) is False


def test_event_partner(e1: Simulation) -> None:
    red_first = f"FilterFirst(FilterCollisionWithDynamics(FilterEvents(Events(), {RED})))"  # red-blue@40
    assert run(f"EventPartner({red_first}, {RED})", e1) == 2  # blue
    assert run(f"EventPartner({red_first}, {BLUE})", e1) == 3  # either position
    assert run(f"QueryColor(EventPartner({red_first}, {RED}))", e1) == "blue"
    # a static partner: yellow's first collision is with the platform
    yellow_first = f"FilterFirst(FilterCollision(FilterEvents(Events(), {YELLOW})))"
    assert run(f"EventPartner({yellow_first}, {YELLOW})", e1) == 4
    assert parse(f"EventPartner({red_first}, {RED})").type is T.OBJECT


def test_event_partner_of_an_event_without_the_object_is_invalid(e1: Simulation) -> None:
    red_first = f"FilterFirst(FilterEvents(Events(), {RED}))"  # red-blue@40
    assert run(f"EventPartner({red_first}, {GREEN})", e1) is INVALID
    assert run(f"QueryColor(EventPartner({red_first}, {GREEN}))", e1) is INVALID
    # Start has no objects
    assert run(f"EventPartner(FilterFirst(Events()), {GREEN})", e1) is INVALID


def test_filter_objects_from_events(e1: Simulation) -> None:
    # static partners included, ascending ids
    assert run("FilterObjectsFromEvents(FilterCollideGround(Events()))", e1) == (1, 3, 6)
    assert run("FilterObjectsFromEvents(FilterEnterBasket(Events()))", e1) == (0, 2, 5)
    assert run("FilterObjectsFromEvents(FilterCollision(Events()))", e1) == (0, 1, 2, 3, 4, 5, 6)
    # Start and End carry no objects and do not crash
    assert run("FilterObjectsFromEvents(Events())", e1) == (0, 1, 2, 3, 4, 5, 6)
    assert run(f"FilterObjectsFromEvents(FilterEvents(Events(), {RED}))", e1) == (0, 2, 3, 6)
    sim = make_sim(BASIC_OBJECTS, [(10, "Collision", 3, 0), (20, "Collision", 2, 1), (30, "Collision", 6, 0)])
    assert run("FilterObjectsFromEvents(Events())", sim) == (0, 1, 2, 3, 6)


def test_filter_objects_from_events_list(e1: Simulation) -> None:
    value = run(f"FilterObjectsFromEventsList(FilterCollideGroundList({ALL_CF}))", e1)
    assert value == ((3, 6), (0, 3, 6), (1, 6), (1, 6))
    assert all(list(s) == sorted(s) for s in value)


# -- counterfactuals ---------------------------------------------------------------------------------------------


def test_get_counterfact_events(e1: Simulation) -> None:
    without_blue = run(f"GetCounterfactEvents({BLUE})", e1)
    assert kinds(without_blue) == [
        ("Start", -1, ()), ("Collision", 40, (0, 4)), ("EnterBasket", 85, (5, 3)), ("Collision", 120, (0, 1)),
        ("Collision", 140, (1, 6)), ("EnterBasket", 150, (5, 0)), ("End", 600, ())]
    assert run(f"FilterObjectsFromEvents(FilterEnterBasket(GetCounterfactEvents({BLUE})))", e1) == (0, 3, 5)
    assert run(f"Count(FilterCollideGround(GetCounterfactEvents({GREEN})))", e1) == 2
    assert parse(f"GetCounterfactEvents({BLUE})").type is T.EVENT_SET


def test_get_counterfact_events_list_in_input_order(e1: Simulation) -> None:
    lists = run(f"GetCounterfactEventsList({ALL_CF[len('GetCounterfactEventsList('):-1]})", e1)
    assert [len(s) for s in lists] == [7, 8, 7, 6]  # removing 0, 1, 2, 3
    assert run(f"GetCounterfactEventsList({NO_CF[len('GetCounterfactEventsList('):-1]})", e1) == ()


def test_counterfactual_of_a_static_object_names_it(e1: Simulation) -> None:
    with pytest.raises(CounterfactualUnavailable, match=r"\b6\b.*ground|ground.*\b6\b"):
        run(f"GetCounterfactEvents({GROUND})", e1)
    with pytest.raises(CounterfactualUnavailable, match="4"):
        run("GetCounterfactEventsList(SceneAtStart())", e1)


def test_counterfactual_unavailable_without_variations() -> None:
    sim = make_sim(BASIC_OBJECTS, [(40, "Collision", 3, 2)])  # no counterfactuals at all
    # descriptive programs run
    assert run("Count(FilterCollisionWithDynamics(Events()))", sim) == 1
    with pytest.raises(CounterfactualUnavailable, match=r"\b3\b.*red|red.*\b3\b"):
        run(f"GetCounterfactEvents({RED})", sim)
    with pytest.raises(CounterfactualUnavailable):
        run("GetCounterfactEventsList(FilterDynamic(SceneAtStart()))", sim)


def test_counterfactuals_on_a_hand_made_scene(basic_sim: Simulation) -> None:
    assert run(f"FilterObjectsFromEvents(FilterEnterBasket(GetCounterfactEvents({BLUE})))", basic_sim) == (3, 5)
    assert run(f"Count(GetCounterfactEvents({GREEN}))", basic_sim) == 2  # Start and End only


# -- INVALID propagation through every module ---------------------------------------------------------------

VALID: dict[DslType, str] = {
    T.OBJECT: f"Unique({RED})",
    T.OBJECT_SET: RED,  # one object, so that Unique of it is valid
    T.OBJECT_SET_LIST: f"FilterObjectsFromEventsList({ALL_CF})",
    T.EVENT: f"FilterFirst(FilterEvents(Events(), {RED}))",
    T.EVENT_SET: "Events()",
    T.EVENT_SET_LIST: ALL_CF,
    T.INTEGER: "StartSceneStep()",
    T.BOOL_LIST: f"ExistList({ALL_CF})",
    T.COLOR: f"QueryColor({RED})",
    T.SHAPE: f"QueryShape({RED})",
    T.SIZE: f"QuerySize({RED})",
}
NOBODY = "Unique(SceneAtStart())"  # nine objects: INVALID
INVALID_OF: dict[DslType, str] = {
    T.OBJECT: NOBODY,
    T.OBJECT_SET: f"AsList({NOBODY})",
    T.OBJECT_SET_LIST: f"FilterObjectsFromEventsList(GetCounterfactEventsList(AsList({NOBODY})))",
    T.EVENT: f"FilterFirst(FilterEnterBasket(FilterEvents(Events(), {RED})))",  # genuinely empty
    T.EVENT_SET: f"FilterEvents(Events(), {NOBODY})",
    T.EVENT_SET_LIST: f"GetCounterfactEventsList(AsList({NOBODY}))",
    T.INTEGER: f"Count(AsList({NOBODY}))",
    T.BOOL_LIST: f"ExistList(GetCounterfactEventsList(AsList({NOBODY})))",
    T.COLOR: f"QueryColor({NOBODY})",
    T.SHAPE: f"QueryShape({NOBODY})",
    T.SIZE: f"QuerySize({NOBODY})",
}
SIDE_VALUE = {T.COLOR: '"red"', T.SHAPE: '"cube"', T.SIZE: '"large"'}


def _call(name: str, inputs: list[str], sides: tuple[DslType, ...]) -> str:
    return f"{name}({', '.join(inputs + [SIDE_VALUE[s] for s in sides])})"


def _invalid_cases() -> list[tuple[str, str]]:
    cases = []
    for spec in MODULES:
        for ov in spec.overloads:
            for i in range(len(ov.inputs)):
                args = [INVALID_OF[t] if k == i else VALID[t] for k, t in enumerate(ov.inputs)]
                cases.append((f"{spec.name}[{','.join(map(str, ov.inputs))}]#{i + 1}",
                              _call(spec.name, args, spec.side_inputs)))
    return cases


@pytest.mark.parametrize("typ", list(INVALID_OF))
def test_invalid_fixtures_are_invalid_and_valid_ones_are_not(e1: Simulation, typ: DslType) -> None:
    assert parse(INVALID_OF[typ]).type is typ
    assert parse(VALID[typ]).type is typ
    assert run(INVALID_OF[typ], e1) is INVALID
    assert run(VALID[typ], e1) is not INVALID


@pytest.mark.parametrize(("case", "program"), _invalid_cases(), ids=[c for c, _ in _invalid_cases()])
def test_invalid_propagates_through_every_module(e1: Simulation, case: str, program: str) -> None:
    p = parse(program)
    assert p.run(e1) is INVALID
    # the trace agrees, and the final node is INVALID too
    assert p.trace(e1)[-1].value is INVALID


@pytest.mark.parametrize("spec", [m for m in MODULES if m.overloads[0].inputs], ids=lambda m: m.name)
def test_every_module_with_valid_inputs_is_not_invalid(e1: Simulation, spec: Any) -> None:
    for ov in spec.overloads:
        program = _call(spec.name, [VALID[t] for t in ov.inputs], spec.side_inputs)
        assert parse(program).run(e1) is not INVALID, program


def test_invalid_value_itself() -> None:
    assert repr(INVALID) == "INVALID"
    assert not INVALID
    assert INVALID == INVALID and INVALID is type(INVALID)()
    assert INVALID != "__INVALID__" and INVALID is not None


# -- aliases and overloads ------------------------------------------------------------------------------------


def _alias_cases() -> list[tuple[str, str, str]]:
    cases = []
    for spec in MODULES:
        for alias in spec.aliases:
            for ov in spec.overloads:
                args = [VALID[t] for t in ov.inputs]
                cases.append((alias, _call(alias, args, spec.side_inputs), _call(spec.name, args, spec.side_inputs)))
    return cases


@pytest.mark.parametrize(("alias", "aliased", "canonical"), _alias_cases(),
                         ids=[f"{a}-{i}" for i, (a, _, _) in enumerate(_alias_cases())])
def test_every_original_name_is_an_alias(e1: Simulation, alias: str, aliased: str, canonical: str) -> None:
    p, q = parse(aliased), parse(canonical)
    assert p == q
    assert str(p) == str(q)  # printed with the canonical name
    assert p.type == q.type
    assert p.run(e1) == q.run(e1)


# The original engine's snake_case names , mapped to the paper's.
ORIGINAL_NAMES = {
    "start_scene": "SceneAtStart", "end_scene": "SceneAtEnd", "start_scene_step": "StartSceneStep",
    "end_scene_step": "EndSceneStep", "filter_color": "FilterColor", "filter_shape": "FilterShape",
    "filter_size": "FilterSize", "unique": "Unique", "union": "Union", "intersect": "Intersect",
    "intersect_list": "IntersectList", "difference": "Difference", "count": "Count", "query_color": "QueryColor",
    "query_shape": "QueryShape", "query_size": "QuerySize", "exist": "Exist", "event_exist": "Exist",
    "exist_list": "ExistList", "any_false": "AnyFalse", "any_true": "AnyTrue", "equal_color": "EqualColor",
    "equal_shape": "EqualShape", "equal_integer": "EqualInteger", "equal_size": "EqualSize",
    "equal_object": "EqualObject", "less_than": "LessThan", "greater_than": "GreaterThan", "events": "Events",
    "filter_events": "FilterEvents", "filter_collision": "FilterCollision",
    "filter_collision_with_dynamics": "FilterCollisionWithDynamics",
    "filter_enter_container": "FilterEnterBasket", "filter_enter_container_list": "FilterEnterBasketList",
    "filter_collide_ground": "FilterCollideGround", "filter_collide_ground_list": "FilterCollideGroundList",
    "filter_collide_basket": "FilterCollideBasket", "filter_collide_basket_list": "FilterCollideBasketList",
    "filter_first": "FilterFirst", "filter_last": "FilterLast", "event_partner": "EventPartner",
    "filter_moving_objects": "FilterMoving", "filter_stationary_objects": "FilterStationary",
    "filter_dynamic_objects": "FilterDynamic", "filter_objects_from_events": "FilterObjectsFromEvents",
    "filter_objects_from_events_list": "FilterObjectsFromEventsList", "counterfact_events": "GetCounterfactEvents",
    "counterfact_events_list": "GetCounterfactEventsList", "filter_before": "FilterBefore",
    "filter_after": "FilterAfter", "is_before": "IsBefore", "is_after": "IsAfter", "as_list": "AsList",
}


@pytest.mark.parametrize(("original", "canonical"), sorted(ORIGINAL_NAMES.items()))
def test_original_name_table(original: str, canonical: str) -> None:
    spec = lookup(original)
    assert spec is not None, f"{original} is not accepted"
    assert spec.name == canonical


def test_alias_programs_mean_the_same(e1: Simulation) -> None:
    aliased = ("count(filter_dynamic_objects(filter_objects_from_events(filter_collide_ground(events()))))")
    assert parse(aliased) == parse("Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))")
    assert parse(aliased).run(e1) == 2
    # the alias takes the text form's argument order (Event, Object), like the canonical name
    partner = ('event_partner(filter_first(filter_events(events(), filter_color(start_scene(), "red"))), '
               'filter_color(start_scene(), "red"))')
    assert parse(partner).run(e1) == 2


def test_overloads_are_resolved_by_the_argument_type(e1: Simulation) -> None:
    assert parse("Count(SceneAtStart())").type is T.INTEGER
    assert parse("Count(Events())").type is T.INTEGER
    # exist on an EventSet and event_exist on an ObjectSet are the same overloaded module
    assert parse("exist(Events())") == parse("Exist(Events())")
    assert parse("event_exist(SceneAtStart())").run(e1) is True
    assert parse("Count(FilterEnterBasket(Events()))").run(e1) == 3
    assert {ov.inputs for ov in REGISTRY["Count"].overloads} == {(T.OBJECT_SET,), (T.EVENT_SET,)}
    assert {ov.inputs for ov in REGISTRY["Exist"].overloads} == {(T.OBJECT_SET,), (T.EVENT_SET,)}
    assert {ov.inputs for ov in REGISTRY["ExistList"].overloads} == {(T.OBJECT_SET_LIST,), (T.EVENT_SET_LIST,)}


# -- coverage of the registry --------------------------------------------------------------------------------


def _modules_used_in_this_file() -> set[str]:
    """Canonical names of modules called inside the string literals of this file's programs."""
    source = Path(__file__).read_text(encoding="utf-8")
    used: set[str] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type != tokenize.STRING:
            continue
        for name in re.findall(r"\b([A-Za-z_]\w*)\(", tok.string):
            spec = lookup(name)
            if spec is not None:
                used.add(spec.name)
    return used


def test_every_registered_module_is_exercised() -> None:
    missing = sorted(set(REGISTRY) - _modules_used_in_this_file())
    assert not missing, f"modules never called in a program of test_modules.py: {missing}"
