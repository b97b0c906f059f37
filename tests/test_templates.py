"""The 67 CRAFT templates: node lists, types, round trips, the worked example's answers and the dropped 19."""

from __future__ import annotations

import json
from typing import Any

import pytest

from craft_dsl import INVALID, DslType, NodeListError, Program, Simulation, parse
from craft_dsl.program import to_json
from craft_dsl.templates import DROPPED, Template, templates
from craft_dsl.types import INVALID_JSON
from tests.conftest import E1_EXPECTED_PATH

ALL = templates()
IDS = list(ALL)
EXPECTED: list[dict[str, Any]] = json.loads(E1_EXPECTED_PATH.read_text(encoding="utf-8"))

# any binding will do for static checks
DEFAULT_PARAMS = {"<Z>": "small", "<C>": "red", "<S>": "cube", "<Z2>": "large", "<C2>": "blue", "<S2>": "circle"}


def _answer_type(tid: str) -> DslType:
    """Answer types of the templates."""
    family, index = tid.rsplit("_", 1)
    i = int(index)
    if family == "descriptive":
        if i <= 21:
            return DslType.INTEGER
        if i <= 23:
            return DslType.COLOR
        if i <= 25:
            return DslType.SHAPE
        return DslType.BOOL
    if family == "counterfactual":
        return DslType.INTEGER if 3 <= i <= 5 else DslType.BOOL
    return DslType.INTEGER if 3 <= i <= 5 else DslType.BOOL


def _program(t: Template) -> Program:
    return t.program({k: v for k, v in DEFAULT_PARAMS.items() if k in t.placeholders})


def test_there_are_67_templates_in_file_order() -> None:
    assert len(ALL) == 67
    counts = {f: sum(1 for t in ALL.values() if t.family == f)
              for f in ("descriptive", "counterfactual", "cause", "enable", "prevent")}
    assert counts == {"descriptive": 40, "counterfactual": 9, "cause": 6, "enable": 6, "prevent": 6}
    families = [t.family for t in ALL.values()]
    assert families == sorted(families, key=["descriptive", "counterfactual", "cause", "enable", "prevent"].index)
    for t in ALL.values():
        assert t.id == f"{t.family}_{t.index}"


@pytest.mark.parametrize("tid", IDS)
def test_template_parses_type_checks_and_round_trips(tid: str) -> None:
    t = ALL[tid]
    p = _program(t)
    assert p.type is _answer_type(tid)
    # text round trip
    assert parse(str(p)) == p
    assert str(parse(str(p))) == str(p)
    # node-list round trip
    nodes = p.to_nodes()
    assert Program.from_nodes(nodes) == p
    assert Program.from_nodes(json.loads(json.dumps(nodes))) == p
    # the node list is in the original vocabulary: snake_case names, earlier inputs only, value_inputs
    for k, node in enumerate(nodes):
        assert node["type"] == node["type"].lower()
        assert all(0 <= i < k for i in node["inputs"])
        assert isinstance(node["value_inputs"], list)


@pytest.mark.parametrize("tid", IDS)
def test_template_placeholders_are_bound_and_required(tid: str) -> None:
    t = ALL[tid]
    assert set(t.placeholders) <= set(DEFAULT_PARAMS)
    if t.placeholders:
        missing = t.placeholders[-1]
        params = {k: DEFAULT_PARAMS[k] for k in t.placeholders if k != missing}
        with pytest.raises(NodeListError, match=missing):
            t.program(params)


def test_descriptive_templates_drop_the_unused_start_scene_node() -> None:
    t = ALL["descriptive_4"]
    assert t.nodes[0]["type"] == "start_scene"
    assert all(0 not in n["inputs"] for n in t.nodes)
    p = _program(t)
    assert "SceneAtStart" not in str(p)
    assert all(n["type"] != "start_scene" for n in p.to_nodes())


def _expected_cases() -> list[tuple[str, dict[str, str], Any]]:
    return [(e["template"], e["params"], e["answer"]) for e in EXPECTED]


def test_there_are_65_expected_answers() -> None:
    assert len(EXPECTED) == 65


@pytest.mark.parametrize(("tid", "params", "answer"), _expected_cases(),
                         ids=[f"{e['template']}-{i}" for i, e in enumerate(EXPECTED)])
def test_appendix_c_answers(e1: Simulation, tid: str, params: dict[str, str], answer: Any) -> None:
    got = ALL[tid].program(params).run(e1)
    if answer == INVALID_JSON:
        assert got is INVALID
    else:
        assert got is not INVALID
        assert type(got) is type(answer)
        assert got == answer


def test_event_partner_original_order_is_mapped(e1: Simulation) -> None:
    t = ALL["descriptive_22"]
    partner = next(n for n in t.nodes if n["type"] == "event_partner")
    obj_node, event_node = (t.nodes[i] for i in partner["inputs"])
    assert obj_node["type"] == "unique" and event_node["type"] == "filter_first"  # object first in the original
    p = _program(t)
    assert "EventPartner(FilterFirst(" in str(p)  # event first in the text form
    exported = p.to_nodes()
    node = next(n for n in exported if n["type"] == "event_partner")
    assert [exported[i]["type"] for i in node["inputs"]] == ["unique", "filter_first"]


def test_canonical_node_names_use_the_canonical_order(e1: Simulation) -> None:
    nodes: list[dict[str, Any]] = [
        {"type": "Events", "inputs": []},
        {"type": "SceneAtStart", "inputs": []},
        {"type": "FilterColor", "inputs": [1], "value_inputs": ["Red"]},
        {"type": "Unique", "inputs": [2]},
        {"type": "FilterEvents", "inputs": [0, 3]},
        {"type": "FilterFirst", "inputs": [4]},
        {"type": "EventPartner", "inputs": [5, 3]},
        {"type": "QueryColor", "inputs": [6]},
    ]
    p = Program.from_nodes(nodes)
    assert p.run(e1) == "blue"
    original = [dict(n) for n in nodes]
    original[6] = {"type": "event_partner", "inputs": [3, 5]}
    assert Program.from_nodes(original) == p


def test_to_nodes_with_outputs_writes_the_cached_values(e1: Simulation) -> None:
    p = ALL["descriptive_22"].program({"<Z>": "large", "<C>": "red", "<S>": "cube"})
    nodes = p.to_nodes(outputs=e1)
    assert all("_output" in n for n in nodes)
    assert nodes[-1]["type"] == "query_color" and nodes[-1]["_output"] == "blue"
    by_type = {n["type"]: n["_output"] for n in nodes}
    assert by_type["unique"] == 3
    assert by_type["event_partner"] == 2
    assert by_type["filter_objects_from_events"] == [0, 1, 2, 3]
    first = by_type["filter_first"]
    assert first["step"] == 40 and first["objects"] == [3, 2] and first["type"] == "Collision"
    json.dumps(nodes)  # JSON-ready
    # reading the list back ignores _output
    assert Program.from_nodes(nodes) == p


def test_to_nodes_outputs_of_an_invalid_program(e1: Simulation) -> None:
    p = ALL["descriptive_26"].program({"<Z>": "large", "<C>": "red", "<S>": "cube"})
    nodes = p.to_nodes(outputs=e1)
    assert nodes[-1]["_output"] == INVALID_JSON
    assert next(n for n in nodes if n["type"] == "unique")["_output"] == INVALID_JSON
    assert to_json(p.run(e1)) == INVALID_JSON


def test_to_nodes_outputs_use_the_original_event_type_strings(e1: Simulation) -> None:
    p = parse("FilterEnterBasket(Events())")
    nodes = p.to_nodes(outputs=e1)
    assert {e["type"] for e in nodes[-1]["_output"]} == {"ContainerEndUp"}


@pytest.mark.parametrize(("tid", "params"), [(e["template"], e["params"]) for e in EXPECTED[:20]])
def test_node_outputs_agree_with_run(e1: Simulation, tid: str, params: dict[str, str]) -> None:
    p = ALL[tid].program(params)
    assert p.to_nodes(outputs=e1)[-1]["_output"] == to_json(p.run(e1), original=True)


def test_the_19_dropped_templates() -> None:
    expected = {f"descriptive_{i}" for i in (12, 13, 14, 15, 20, 21, 30, 31, 36, 37)} | {
        "counterfactual_2", "counterfactual_5", "counterfactual_8",
        "cause_2", "cause_5", "enable_2", "enable_5", "prevent_2", "prevent_5"}
    assert len(expected) == 19
    assert set(DROPPED) == expected
    assert {t.id for t in ALL.values() if t.dropped} == expected
    kept = [t for t in ALL.values() if not t.dropped]
    assert len(kept) == 48
    # the dropped ones are exactly the basket-collision questions
    for t in ALL.values():
        uses_basket_collision = any(n["type"].startswith("filter_collide_basket") for n in t.nodes)
        assert uses_basket_collision == t.dropped, t.id


def test_from_nodes_rejects_malformed_node_lists() -> None:
    with pytest.raises(NodeListError):
        Program.from_nodes([])
    with pytest.raises(NodeListError, match="earlier node"):
        Program.from_nodes([{"type": "count", "inputs": [0]}])
    with pytest.raises(NodeListError, match="input"):
        Program.from_nodes([{"type": "start_scene", "inputs": []}, {"type": "count", "inputs": []}])
    with pytest.raises(NodeListError, match="filter_colour|FilterColor"):
        Program.from_nodes([{"type": "start_scene", "inputs": []},
                            {"type": "filter_colour", "inputs": [0], "side_inputs": ["red"]}])
    with pytest.raises(NodeListError, match="type"):
        Program.from_nodes([{"inputs": []}])
