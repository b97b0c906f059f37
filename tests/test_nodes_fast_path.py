"""The one-pass reading of common node lists (craft_dsl.nodes._check_common) against the general reading.

``check_nodes`` reads a node list of the common exact shape in one pass and leaves everything else to the
general node-by-node reading. Over drawn node lists and drawn edits of them (other names, letter case,
placeholders, bad indexes, other keys, other container types), both must give the same checked program, or
the same error with the same message and location; and the one-pass reading must never accept what the
general reading refuses.
"""

from __future__ import annotations

import copy
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import MODULES, Program, Simulation
from craft_dsl.checker import CheckedProgram
from craft_dsl.errors import CraftError
from craft_dsl.nodes import _check_common, _check_general, check_nodes
from craft_dsl.strategies import node_lists
from craft_dsl.templates import first_instances

SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
NAMES = sorted({name for m in MODULES for name in (m.name, *m.aliases)})


def outcome(read: Any, *args: Any) -> tuple[Any, ...]:
    try:
        checked: CheckedProgram = read(*args)
    except CraftError as err:
        return ("error", type(err).__name__, str(err))
    return ("program", list(checked.raw), checked.root, checked.raw_sources, checked.tree, checked.binding_types)


EDITS = ("canonical name", "case", "placeholder", "int value", "no values", "extra value", "side_inputs", "_output",
         "extra key", "no inputs", "tuple inputs", "bool input", "late input", "negative input", "swap inputs",
         "values null", "not a dict", "duplicate node")


def edited(nodes: list[dict[str, Any]], k: int, kind: str, new_type: str = "Count") -> list[Any]:
    """``nodes`` with node ``k`` edited (``new_type``: the module name of the "type" edit)."""
    out: list[Any] = copy.deepcopy(nodes)
    node = out[k]
    if kind == "type":
        node["type"] = new_type
    elif kind == "canonical name":
        node["type"] = Program.from_nodes(nodes).nodes[-1].module if k == len(nodes) - 1 else node["type"]
    elif kind == "case" and node["value_inputs"]:
        node["value_inputs"] = [v.upper() for v in node["value_inputs"]]
    elif kind == "placeholder" and node["value_inputs"]:
        node["value_inputs"] = ["<C>"]
    elif kind == "int value":
        node["value_inputs"] = [3]
    elif kind == "no values":
        node["value_inputs"] = []
    elif kind == "extra value":
        node["value_inputs"] = [*node["value_inputs"], "red"]
    elif kind == "side_inputs":
        node["side_inputs"] = node.pop("value_inputs")
    elif kind == "_output":
        node["_output"] = 1
    elif kind == "extra key":
        node["note"] = "x"
    elif kind == "no inputs":
        del node["inputs"]
    elif kind == "tuple inputs":
        node["inputs"] = tuple(node["inputs"])
    elif kind == "bool input" and node["inputs"]:
        node["inputs"][0] = bool(node["inputs"][0])
    elif kind == "late input" and node["inputs"]:
        node["inputs"][-1] = k
    elif kind == "negative input" and node["inputs"]:
        node["inputs"][0] = -1
    elif kind == "swap inputs":
        node["inputs"] = node["inputs"][::-1]
    elif kind == "values null":
        node["value_inputs"] = None
    elif kind == "not a dict":
        out[k] = list(node.items())
    elif kind == "duplicate node":
        out.append(copy.deepcopy(node))
    return out


@st.composite
def edited_node_lists(draw: st.DrawFn) -> list[Any]:
    nodes = draw(node_lists())
    if not draw(st.booleans()):
        return nodes
    return edited(nodes, draw(st.integers(0, len(nodes) - 1)), draw(st.sampled_from(("type", *EDITS))),
                  draw(st.sampled_from(NAMES)))


def same_reading(nodes: list[Any], params: dict[str, str] | None = None) -> bool:
    """Whether check_nodes and the one-pass reading agree with the general reading; True if the one-pass
    reading took the list."""
    general = outcome(_check_general, nodes, params)
    assert outcome(check_nodes, nodes, params) == general
    common = _check_common(nodes)
    if common is not None:
        assert general[0] == "program", general
        assert outcome(lambda: common) == general
    return common is not None


@SETTINGS
@given(edited_node_lists(), st.sampled_from([None, {"<C>": "red"}]))
def test_one_pass_reading_matches_the_general_one(nodes: list[Any], params: dict[str, str] | None) -> None:
    same_reading(nodes, params)


def test_every_template_and_edit(e1: Simulation) -> None:
    """Every template's node list over E1, as it is and with every edit at every node."""
    taken = 0
    for _t, _params, program, _answer in first_instances(e1, include_dropped=True):
        nodes = program.to_nodes()
        taken += same_reading(nodes)
        for k in range(len(nodes)):
            for kind in EDITS:
                same_reading(edited(nodes, k, kind))
    assert taken > 60  # nearly every template's list is read in one pass


def test_reordered_inputs() -> None:
    """EventPartner takes (event, object); its original name event_partner takes (object, event)."""
    nodes = Program.parse("EventPartner(FilterFirst(FilterCollision(Events())), Unique(SceneAtStart()))").to_nodes()
    assert nodes[-1]["type"] == "event_partner"
    assert same_reading(nodes)
    canonical = [*nodes[:-1], {**nodes[-1], "type": "EventPartner", "inputs": nodes[-1]["inputs"][::-1]}]
    assert same_reading(canonical)
    assert _check_common(canonical).raw == _check_common(nodes).raw  # type: ignore[union-attr]
    assert not same_reading(edited(nodes, len(nodes) - 1, "swap inputs"))


def test_common_lists_take_the_one_pass_reading() -> None:
    nodes = Program.parse('Count(FilterColor(SceneAtStart(), "red"))').to_nodes()
    check_nodes(nodes)  # the overloads are resolved (and cached) on the first reading
    assert _check_common(nodes) is not None
    assert _check_common([*nodes[:-1], {**nodes[-1], "note": 1}]) is None
