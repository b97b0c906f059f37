"""Recorded CRAFT files: loading, validation, event numbering, saving."""

from __future__ import annotations

import contextlib
import copy
import itertools
import json
import random
from pathlib import Path
from typing import Any

import pytest

from craft_dsl import (
    INVALID,
    CounterfactualUnavailable,
    CraftError,
    Simulation,
    SimulationFileError,
    load_simulation,
    parse,
    save_simulation,
)
from craft_dsl import atomic as atomic_module
from craft_dsl.templates import templates
from craft_dsl.types import INVALID_JSON
from tests.conftest import BASIC_OBJECTS, E1_PATH, e1_data, make_sim

FIRST_COLLISION = "FilterFirst(FilterCollision(Events()))"
RED = 'FilterColor(SceneAtStart(), "red")'


def _same(a: Any, b: Any) -> bool:
    return a is b if a is INVALID or b is INVALID else bool(a == b)


def _expected_answers(sim: Simulation, expected: list[dict[str, Any]]) -> None:
    for e in expected:
        got = templates()[e["template"]].program(e["params"]).run(sim)
        want = INVALID if e["answer"] == INVALID_JSON else e["answer"]
        assert _same(got, want), (e["template"], e["params"], got, want)


def _bindings(sim: Simulation) -> list[dict[str, str]]:
    """Parameter sets naming every dynamic object of ``sim`` as A, and every ordered pair as (A, B)."""
    dyn = [o for o in sim.objects if o.dynamic]
    out: list[dict[str, str]] = []
    for a, b in itertools.product(dyn, dyn):
        out.append({"<Z>": a.size, "<C>": a.color, "<S>": a.shape, "<Z2>": b.size, "<C2>": b.color, "<S2>": b.shape})
    return out


def _all_answers(sim: Simulation) -> dict[tuple[str, int], Any]:
    answers: dict[tuple[str, int], Any] = {}
    for tid, t in templates().items():
        for k, params in enumerate(_bindings(sim)):
            answers[tid, k] = t.program({p: params[p] for p in t.placeholders}).run(sim)
    return answers


def _load_error(data: Any) -> str:
    with pytest.raises(SimulationFileError) as info:
        load_simulation(data)
    return str(info.value)


def _strip_object(output: dict[str, Any], oid: int) -> None:
    """Remove an object and every event naming it (and their edges) from a bare output."""
    for state in output.get("scene_states") or []:
        state["scene"]["objects"] = [o for o in state["scene"]["objects"] if o["uniqueID"] != oid]
    graph = output["causal_graph"]
    graph["nodes"] = [n for n in graph["nodes"] if oid not in n["objects"]]
    ids = {n["id"] for n in graph["nodes"]}
    graph["edges"] = [{"from": e["from"], "to": [t for t in e["to"] if t in ids]}
                      for e in graph["edges"] if e["from"] in ids]


# -- loading ----------------------------------------------------------------------------------------------------


def test_e1_loads(e1: Simulation) -> None:
    assert [o.id for o in e1.objects] == list(range(9))
    assert sorted(o.id for o in e1.objects if o.dynamic) == [0, 1, 2, 3]
    assert e1.ground_id == 6 and e1.basket_id == 5
    assert e1.steps == 600
    assert len(e1.events) == 14
    assert [e.id for e in e1.events] == list(range(14))  # numbered in (step, file order)
    red = e1.object(3)
    assert (red.shape, red.color, red.size, red.dynamic) == ("cube", "red", "large", True)
    assert red.start.velocity == (-10.0, -4.0) and red.end.velocity == (0.0, 0.0)
    assert e1.object(5).color == "black" and e1.object(5).size == "large" and not e1.object(5).dynamic
    assert e1.meta["video_filename"] == "./videos/sid_1/000007.mpg"


def test_e1_loads_from_a_dict_and_a_path_alike(e1: Simulation, e1_expected: list[dict[str, Any]]) -> None:
    from_dict = load_simulation(e1_data())
    assert from_dict.events == e1.events
    _expected_answers(from_dict, e1_expected)


def test_every_variation_is_a_counterfactual(e1: Simulation) -> None:
    for oid, n_events in ((0, 7), (1, 8), (2, 7), (3, 6)):
        cf = e1.counterfactual(oid)
        assert len(cf.events) == n_events
        assert not cf.has_object(oid)
        assert cf.removed == (oid,)


def test_bare_output_loads_and_counterfactuals_name_the_object(tmp_path: Path) -> None:
    bare = e1_data()["original_video_output"]
    path = tmp_path / "bare.json"
    path.write_text(json.dumps(bare), encoding="utf-8")
    for sim in (load_simulation(bare), load_simulation(path)):
        assert parse("Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))").run(sim) == 2
        with pytest.raises(CounterfactualUnavailable) as info:
            parse(f"GetCounterfactEvents({RED})").run(sim)
        message = str(info.value)
        assert "3" in message and "red" in message and "cube" in message


def test_missing_variation_of_a_static_object_names_it(e1: Simulation) -> None:
    with pytest.raises(CounterfactualUnavailable) as info:
        e1.counterfactual(4)
    assert "4" in str(info.value) and "platform" in str(info.value)


def test_missing_variation_of_a_dynamic_object_names_it() -> None:
    data = e1_data()
    del data["variations_outputs"]["1"]
    sim = load_simulation(data)
    assert parse(f"Count(GetCounterfactEvents({RED}))").run(sim) == 6
    with pytest.raises(CounterfactualUnavailable) as info:
        parse('GetCounterfactEvents(FilterColor(SceneAtStart(), "green"))').run(sim)
    assert "1" in str(info.value) and "green" in str(info.value) and "triangle" in str(info.value)


def test_a_run_without_events_loads(e1_dict: dict[str, Any]) -> None:
    graph = e1_dict["original_video_output"]["causal_graph"]
    graph["nodes"] = [graph["nodes"][0], graph["nodes"][-1]]
    graph["edges"] = [{"from": 100, "to": [199]}, {"from": 199, "to": []}]
    sim = load_simulation(e1_dict)
    assert [e.type for e in sim.events] == ["Start", "End"]
    assert parse("Count(FilterCollision(Events()))").run(sim) == 0
    assert parse("Exist(FilterObjectsFromEvents(Events()))").run(sim) is False
    assert parse("FilterFirst(FilterCollision(Events()))").run(sim) is INVALID


def test_original_type_strings_are_aliases(e1: Simulation) -> None:
    data = e1_data()
    canonical = {"StartTouching": "TouchStart", "EndTouching": "TouchEnd", "ContainerEndUp": "EnterBasket"}
    for node in data["original_video_output"]["causal_graph"]["nodes"]:
        node["type"] = canonical.get(node["type"], node["type"])
    assert load_simulation(data).events == e1.events
    # EndTouching too
    data = e1_data()
    graph = data["original_video_output"]["causal_graph"]
    graph["nodes"].insert(9, {"id": 150, "type": "EndTouching", "step": 148, "objects": [6, 1]})
    graph["edges"][0]["to"].append(150)
    sim = load_simulation(data)
    assert [e.type for e in sim.events if e.step == 148] == ["TouchEnd"]


# -- validation ---------------------------------------------------------------------------------------------------


def test_duplicate_object_ids(e1_dict: dict[str, Any]) -> None:
    e1_dict["original_video_output"]["scene_states"][0]["scene"]["objects"][1]["uniqueID"] = 8
    assert "uniqueID 8 appears twice" in _load_error(e1_dict)


def test_event_naming_a_missing_object(e1_dict: dict[str, Any]) -> None:
    e1_dict["original_video_output"]["causal_graph"]["nodes"][1]["objects"] = [3, 42]
    message = _load_error(e1_dict)
    assert "42" in message and "not in the scene" in message


def test_variation_event_naming_its_removed_object(e1_dict: dict[str, Any]) -> None:
    e1_dict["variations_outputs"]["3"]["causal_graph"]["nodes"][1]["objects"] = [3, 4]
    message = _load_error(e1_dict)
    assert "variations_outputs" in message and "3" in message


def test_no_ground(e1_dict: dict[str, Any]) -> None:
    _strip_object(e1_dict["original_video_output"], 6)
    for variation in e1_dict["variations_outputs"].values():
        _strip_object(variation, 6)
    message = _load_error(e1_dict)
    assert "ground" in message and "found 0" in message


def test_two_baskets(e1_dict: dict[str, Any]) -> None:
    for state in e1_dict["original_video_output"]["scene_states"]:
        extra = copy.deepcopy(state["scene"]["objects"][3])
        assert extra["shape"] == "basket"
        extra["uniqueID"] = 9
        state["scene"]["objects"].append(extra)
    message = _load_error(e1_dict)
    assert "basket" in message and "found 2" in message


def test_missing_end_state(e1_dict: dict[str, Any]) -> None:
    e1_dict["original_video_output"]["scene_states"].pop()
    assert "no end state" in _load_error(e1_dict)


def test_missing_start_state(e1_dict: dict[str, Any]) -> None:
    e1_dict["original_video_output"]["scene_states"][0]["step"] = 5
    assert "step 0" in _load_error(e1_dict)


def test_object_missing_from_the_end_state(e1_dict: dict[str, Any]) -> None:
    e1_dict["original_video_output"]["scene_states"][1]["scene"]["objects"].pop()
    message = _load_error(e1_dict)
    assert "object 0" in message and "end state" in message


def test_missing_field_is_named(e1_dict: dict[str, Any]) -> None:
    del e1_dict["original_video_output"]["scene_states"][0]["scene"]["objects"][0]["2dLinearVelocity"]
    assert "2dLinearVelocity" in _load_error(e1_dict)


def test_unknown_event_type_lists_the_allowed_ones(e1_dict: dict[str, Any]) -> None:
    e1_dict["original_video_output"]["causal_graph"]["nodes"][1]["type"] = "Bump"
    message = _load_error(e1_dict)
    assert "Bump" in message and "ContainerEndUp" in message and "Collision" in message


def test_duplicate_event_id(e1_dict: dict[str, Any]) -> None:
    e1_dict["original_video_output"]["causal_graph"]["nodes"][1]["id"] = 102
    assert "102" in _load_error(e1_dict)


def test_edge_naming_a_missing_event(e1_dict: dict[str, Any]) -> None:
    e1_dict["original_video_output"]["causal_graph"]["edges"][1]["to"] = [777]
    assert "777" in _load_error(e1_dict)


def test_truncated_json(tmp_path: Path) -> None:
    text = E1_PATH.read_text(encoding="utf-8")
    path = tmp_path / "truncated.json"
    path.write_text(text[: len(text) // 2], encoding="utf-8")
    message = _load_error(path)
    assert "JSON" in message and "truncated" in message and str(path) in message


def test_not_a_craft_file(tmp_path: Path) -> None:
    assert "not a CRAFT simulation" in _load_error({"foo": 1, "bar": []})
    path = tmp_path / "list.json"
    path.write_text("[1, 2, 3]", encoding="utf-8")
    assert "JSON object" in _load_error(path)
    assert "no such file" in _load_error(tmp_path / "absent.json")


@pytest.mark.parametrize("key", ["red", "42", "", "3.0"])
def test_variation_key_that_is_not_an_object_id(e1_dict: dict[str, Any], key: str) -> None:
    e1_dict["variations_outputs"][key] = e1_dict["variations_outputs"]["3"]
    message = _load_error(e1_dict)
    assert repr(key) in message and "not an object id" in message


def _variation_with_scene(data: dict[str, Any], removed: int) -> dict[str, Any]:
    variation: dict[str, Any] = data["variations_outputs"][str(removed)]
    variation["scene_states"] = copy.deepcopy(data["original_video_output"]["scene_states"])
    return variation


def test_variation_with_an_object_foreign_to_the_scene(e1_dict: dict[str, Any]) -> None:
    variation = _variation_with_scene(e1_dict, 3)
    for state in variation["scene_states"]:
        state["scene"]["objects"] = [o for o in state["scene"]["objects"] if o["uniqueID"] != 3]
        stranger = dict(state["scene"]["objects"][-1], uniqueID=9, color="purple")
        state["scene"]["objects"].append(stranger)
    variation["causal_graph"]["nodes"].insert(1, {"id": 305, "type": "Collision", "step": 30, "objects": [9, 6]})
    variation["causal_graph"]["edges"][0]["to"].append(305)
    try:
        sim = load_simulation(e1_dict)
    except SimulationFileError as err:
        assert "9" in str(err)
        return
    # if such a file is accepted, programs over it must still not crash
    program = parse(f'Count(FilterColor(FilterObjectsFromEvents(GetCounterfactEvents({RED})), "red"))')
    with contextlib.suppress(CraftError):
        program.run(sim)


def test_variation_that_still_contains_its_removed_object(e1_dict: dict[str, Any]) -> None:
    variation = _variation_with_scene(e1_dict, 3)
    variation["causal_graph"]["nodes"].insert(1, {"id": 305, "type": "Collision", "step": 30, "objects": [3, 6]})
    variation["causal_graph"]["edges"][0]["to"].append(305)
    message = _load_error(e1_dict)
    assert "3" in message


# -- start and end states, event numbering ---------------------------------------------------------------------------


def test_start_and_end_are_chosen_by_step(e1: Simulation, e1_expected: list[dict[str, Any]]) -> None:
    data = e1_data()
    data["original_video_output"]["scene_states"].reverse()
    sim = load_simulation(data)
    assert [o.start for o in sim.objects] == [o.start for o in e1.objects]
    assert [o.end for o in sim.objects] == [o.end for o in e1.objects]
    assert parse("FilterMoving(SceneAtStart(), StartSceneStep())").run(sim) == (0, 3)
    assert parse("FilterMoving(SceneAtStart(), EndSceneStep())").run(sim) == (0, 1)
    _expected_answers(sim, e1_expected)


def test_ties_follow_the_file_order(e1: Simulation) -> None:
    assert parse(FIRST_COLLISION).run(e1).objects == (3, 2)
    data = e1_data()
    nodes = data["original_video_output"]["causal_graph"]["nodes"]
    nodes[1], nodes[2] = nodes[2], nodes[1]  # yellow-platform now listed before red-blue (both step 40)
    sim = load_simulation(data)
    assert parse(FIRST_COLLISION).run(sim).objects == (0, 4)
    # answers depend on it: the first collision partner of the yellow circle's first collision is no longer
    # reachable through the red cube's first collision
    partner = f"QueryColor(EventPartner({FIRST_COLLISION}, {RED}))"
    assert parse(partner).run(e1) == "blue"
    assert parse(partner).run(sim) is INVALID
    # ties at 170 (blue re-enters, red hits the ground): the last event before End follows the file order too
    last = "FilterLast(FilterBefore(Events(), FilterLast(Events())))"
    assert parse(last).run(e1).objects == (3, 0)  # step 200
    before_200 = "FilterLast(FilterBefore(Events(), FilterLast(FilterBefore(Events(), FilterLast(Events())))))"
    assert parse(before_200).run(e1).objects == (3, 6)  # the later of the two step-170 events in file order
    nodes = data["original_video_output"]["causal_graph"]["nodes"]
    nodes[10], nodes[11] = nodes[11], nodes[10]
    assert parse(before_200).run(load_simulation(data)).objects == (5, 2)


def test_variation_ties_follow_the_file_order(e1: Simulation) -> None:
    program = 'FilterFirst(GetCounterfactEvents(FilterColor(SceneAtStart(), "green")))'
    first = 'FilterFirst(FilterCollision(GetCounterfactEvents(FilterColor(SceneAtStart(), "green"))))'
    assert parse(program).run(e1).type == "Start"
    assert parse(first).run(e1).objects == (3, 2)
    data = e1_data()
    nodes = data["variations_outputs"]["1"]["causal_graph"]["nodes"]
    nodes[1], nodes[2] = nodes[2], nodes[1]
    assert parse(first).run(load_simulation(data)).objects == (0, 4)


def test_numbering_is_a_stable_sort_on_step(e1: Simulation, e1_expected: list[dict[str, Any]]) -> None:
    """Shuffling the node list while keeping the relative order of same-step events changes nothing."""
    rng = random.Random(7)
    for _ in range(5):
        data = e1_data()
        graph = data["original_video_output"]["causal_graph"]
        by_step: dict[int, list[dict[str, Any]]] = {}
        for node in graph["nodes"]:
            by_step.setdefault(node["step"], []).append(node)
        # a random interleaving of the per-step queues
        queues = [list(q) for q in by_step.values()]
        shuffled: list[dict[str, Any]] = []
        while queues:
            q = rng.choice(queues)
            shuffled.append(q.pop(0))
            if not q:
                queues.remove(q)
        graph["nodes"] = shuffled
        sim = load_simulation(data)
        assert [(e.type, e.step, e.objects) for e in sim.events] == [(e.type, e.step, e.objects) for e in e1.events]
        _expected_answers(sim, e1_expected)


# -- saving ------------------------------------------------------------------------------------------------------------


def test_save_load_round_trip_gives_every_template_the_same_answer(e1: Simulation, tmp_path: Path) -> None:
    path = tmp_path / "e1_saved.json"
    save_simulation(e1, path)
    again = load_simulation(path)
    assert [(e.type, e.step, e.objects) for e in again.events] == [(e.type, e.step, e.objects) for e in e1.events]
    assert again.objects == e1.objects
    for oid in (0, 1, 2, 3):
        assert ([(e.type, e.step, e.objects) for e in again.counterfactual(oid).events]
                == [(e.type, e.step, e.objects) for e in e1.counterfactual(oid).events])
    before, after = _all_answers(e1), _all_answers(again)
    assert len(before) == 67 * 16
    assert all(_same(before[k], after[k]) for k in before), [k for k in before if not _same(before[k], after[k])]
    # and once more: saving the loaded copy gives the same file content
    path2 = tmp_path / "e1_saved_again.json"
    save_simulation(again, path2)
    assert json.loads(path.read_text()) == json.loads(path2.read_text())


def test_saved_file_uses_the_original_format(e1: Simulation, tmp_path: Path) -> None:
    path = tmp_path / "out.json"
    save_simulation(e1, path)
    data = json.loads(path.read_text(encoding="utf-8"))
    assert set(data) >= {"original_video_output", "variations_outputs"}
    assert sorted(data["variations_outputs"]) == ["0", "1", "2", "3"]
    original = data["original_video_output"]
    types = {n["type"] for n in original["causal_graph"]["nodes"]}
    assert types == {"Start", "End", "Collision", "StartTouching", "ContainerEndUp"}
    assert [s["step"] for s in original["scene_states"]] == [0, 600]
    record = original["scene_states"][0]["scene"]["objects"][0]
    assert {"uniqueID", "shape", "color", "size", "bodyType", "2dLinearVelocity"} <= set(record)
    node_ids = {n["id"] for n in original["causal_graph"]["nodes"]}
    assert {e["from"] for e in original["causal_graph"]["edges"]} == node_ids  # every node is a 'from'


def test_save_bare_has_no_counterfactuals(e1: Simulation, tmp_path: Path) -> None:
    path = tmp_path / "bare.json"
    save_simulation(e1, path, variations=False)
    sim = load_simulation(path)
    assert [(e.type, e.step, e.objects) for e in sim.events] == [(e.type, e.step, e.objects) for e in e1.events]
    with pytest.raises(CounterfactualUnavailable):
        sim.counterfactual(0)


def test_save_a_hand_made_simulation(tmp_path: Path) -> None:
    sim = make_sim(BASIC_OBJECTS, [(40, "Collision", 3, 2), (40, "Collision", 0, 4), (80, "EnterBasket", 5, 2),
                                   (90, "TouchStart", 2, 5), (120, "TouchEnd", 2, 5)],
                   {3: [(40, "Collision", 0, 4)], 2: [(85, "EnterBasket", 5, 3)], 1: [], 0: []})
    path = tmp_path / "hand.json"
    save_simulation(sim, path)
    again = load_simulation(path)
    assert [(e.type, e.step, e.objects) for e in again.events] == [(e.type, e.step, e.objects) for e in sim.events]
    for o in sim.objects:
        assert again.object(o.id).start.velocity == o.start.velocity
        assert again.object(o.id).end.velocity == o.end.velocity
    program = 'FilterObjectsFromEvents(FilterEnterBasket(GetCounterfactEvents(FilterColor(SceneAtStart(), "blue"))))'
    assert parse(program).run(again) == parse(program).run(sim) == (3, 5)


def test_save_is_atomic(e1: Simulation, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    target = tmp_path / "sim.json"

    def broken_dump(*args: Any, **kwargs: Any) -> None:
        fh = args[1]
        fh.write('{"original_video_output": {')  # a partial write before the failure
        raise OSError("disk full")

    monkeypatch.setattr(atomic_module.json, "dump", broken_dump)
    with pytest.raises(OSError, match="disk full"):
        save_simulation(e1, target)
    assert list(tmp_path.iterdir()) == []  # neither the target nor a temporary file
    # an existing file is left untouched
    monkeypatch.undo()
    save_simulation(e1, target)
    content = target.read_bytes()
    monkeypatch.setattr(atomic_module.json, "dump", broken_dump)
    with pytest.raises(OSError):
        save_simulation(e1, target)
    assert target.read_bytes() == content
    assert [p.name for p in tmp_path.iterdir()] == ["sim.json"]
    monkeypatch.undo()
    assert load_simulation(target).events == e1.events


def test_save_fails_cleanly_when_a_counterfactual_is_missing(tmp_path: Path) -> None:
    sim = make_sim(BASIC_OBJECTS, [(40, "Collision", 3, 2)], {3: []})  # no counterfactual for 0, 1, 2
    target = tmp_path / "partial.json"
    with pytest.raises(CounterfactualUnavailable):
        save_simulation(sim, target)
    assert not target.exists()
