"""Fuzz: the JSON readers, recorded simulations (mutations of tests/data/e1.json, as data and as file bytes) and
node lists (mutations of the templates'). The only exceptions are the documented CraftErrors, whose messages name
the file; what loads can be run.

Long run: python -m pytest tests/ -k fuzz --hypothesis-profile=long
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import CraftError, Program, Simulation, load_simulation, parse
from craft_dsl.errors import InputFileError, ProgramError, SimulationFileError
from craft_dsl.files import MAX_JSON_DEPTH, read_json
from craft_dsl.jsonstream import iter_lines, iter_members
from craft_dsl.templates import templates
from tests.conftest import E1_PATH, e1_data
from tests.fuzz.hostile import expect_only_craft_errors, file_bytes, json_texts, mutated, write

SLOW = settings(suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
PROGRAMS = [parse(t) for t in ("Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))",
                               'FilterObjectsFromEvents(FilterEnterBasket(GetCounterfactEvents(FilterColor('
                               'SceneAtStart(), "blue"))))', "Exist(FilterMoving(SceneAtStart(), EndSceneStep()))")]
E1_TEXT = E1_PATH.read_text(encoding="utf-8")
TEMPLATE_NODES = [[dict(n) for n in t.nodes] for t in templates().values()]


def _standard(value: Any, depth: int = 1) -> bool:
    """Whether ``value`` (parsed by the json module) keeps the rules of craft_dsl.files."""
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, str):  # no lone surrogate (a string that cannot be written as UTF-8)
        return not any("\ud800" <= c <= "\udfff" for c in value)
    if isinstance(value, (list, dict)):
        if depth > MAX_JSON_DEPTH:
            return False
        items = [*value.keys(), *value.values()] if isinstance(value, dict) else value
        return all(_standard(v, depth + 1) for v in items)
    return True


def _no_repeated_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    if len({k for k, _ in pairs}) != len(pairs):
        raise ValueError("repeated key")
    return dict(pairs)


@SLOW
@given(json_texts(), st.booleans())
def test_fuzz_json_readers_agree_with_the_json_module(text: str, as_bytes: bool) -> None:
    """read_json and the streaming reader accept exactly the standard JSON the json module reads, with the same
    value; everything else is an InputFileError naming the file."""
    with tempfile.TemporaryDirectory() as tmp:
        path = write(Path(tmp) / "doc.json", text.encode("utf-8", "surrogatepass") if as_bytes else text)
        try:
            expected = json.loads(path.read_bytes().decode("utf-8"), object_pairs_hook=_no_repeated_keys,
                                  parse_constant=lambda c: float(c))
            valid = _standard(expected)
        except (ValueError, RecursionError, UnicodeDecodeError):
            valid, expected = False, None
        result = expect_only_craft_errors(lambda: read_json(path, "test file"), str(path))
        if valid:
            assert not isinstance(result, CraftError), result
            assert json.dumps(result, sort_keys=True) == json.dumps(expected, sort_keys=True)
        else:
            assert isinstance(result, InputFileError)
        members = expect_only_craft_errors(lambda: list(iter_members(path, "test file")), str(path))
        if valid and isinstance(expected, (dict, list)) and not isinstance(members, CraftError):
            assert [m[1] for m in members] == list(expected.values() if isinstance(expected, dict) else expected)
        lines = expect_only_craft_errors(lambda: list(iter_lines(path, "test file")), str(path))
        assert isinstance(lines, (list, CraftError))


def _exercise_simulation(sim: Simulation) -> None:
    for program in PROGRAMS:
        expect_only_craft_errors(lambda p=program: p.run(sim))  # type: ignore[misc]


@SLOW
@given(mutated(e1_data(), max_changes=3), st.booleans())
def test_fuzz_recorded_simulation_mutations(data: Any, strict: bool) -> None:
    result = expect_only_craft_errors(lambda: load_simulation(data, strict=strict))
    if isinstance(result, CraftError):
        assert isinstance(result, SimulationFileError), result
    else:
        _exercise_simulation(result)
    try:
        text = json.dumps(data)
    except ValueError:  # an integer beyond Python's text conversion: no file to write
        return
    with tempfile.TemporaryDirectory() as tmp:
        path = write(Path(tmp) / "sim.json", text)
        from_file = expect_only_craft_errors(lambda: load_simulation(path, strict=strict), str(path))
        assert isinstance(from_file, CraftError) == isinstance(result, CraftError) or \
            "is not a JSON number" in str(from_file)  # NaN/Infinity: refused by the reader, not the loader


@SLOW
@given(st.data())
def test_fuzz_recorded_simulation_file_bytes(data: st.DataObject) -> None:
    text = E1_TEXT
    for _ in range(data.draw(st.integers(0, 2))):
        at = data.draw(st.integers(0, len(text)))
        text = text[:at] + data.draw(st.sampled_from(["", "9" * 5000, "NaN", '"x": 1, "x": 2, ', "[" * 500, "\ufeff",
                                                       "é", "}", ",", '"'])) + text[at + data.draw(st.integers(0, 9)):]
    raw = data.draw(file_bytes(text))
    with tempfile.TemporaryDirectory() as tmp:
        path = write(Path(tmp) / "sim.json", raw)
        result = expect_only_craft_errors(lambda: load_simulation(path), str(path))
        if isinstance(result, CraftError):
            assert isinstance(result, SimulationFileError), result
        else:
            _exercise_simulation(result)


@SLOW
@given(st.sampled_from(TEMPLATE_NODES).flatmap(lambda nodes: mutated(nodes, max_changes=2)),
       st.dictionaries(st.sampled_from(["<Z>", "<C>", "<S>", "<Z2>", "<C2>", "<S2>", "<X>"]),
                       st.sampled_from(["small", "red", "cube", "pink", "", "9" * 100]), max_size=7))
def test_fuzz_node_lists(nodes: Any, params: dict[str, str]) -> None:
    result = expect_only_craft_errors(lambda: Program.from_nodes(nodes, params))
    if isinstance(result, CraftError):
        assert isinstance(result, ProgramError), result
    else:
        assert Program.from_nodes(result.to_nodes()).key == result.key
        expect_only_craft_errors(lambda: result.run(load_simulation(E1_PATH)))
