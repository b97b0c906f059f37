"""The oracle for model predictions (craft_dsl.oracle): outcomes, traces, predictions files, evaluate, CLI."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from craft_dsl import CraftError, Program, Simulation, load_simulation, parse
from craft_dsl.cli import main
from craft_dsl.errors import ProgramError
from craft_dsl.oracle import (
    ProgramCache,
    compare_trace,
    evaluate_predictions,
    program_outcome,
    read_program,
    score_distribution,
)
from craft_dsl.oracle.cli import vocabulary
from craft_dsl.oracle.predictions import collect_predictions
from craft_dsl.oracle.traces import TraceError, values_agree
from craft_dsl.types import DslType
from craft_dsl.verify import build_dataset
from tests.conftest import E1_PATH

COUNT_FALL = "Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))"


# -- outcomes ---------------------------------------------------------------------------------------------------


def test_each_program_gets_exactly_one_outcome(e1: Simulation) -> None:
    answer = program_outcome(COUNT_FALL, e1)
    assert (answer.kind, answer.answer, answer.form) == ("answer", parse(COUNT_FALL).run(e1), "text")
    syntax = program_outcome("Count(FilterDynamic(SceneAtStart()", e1)
    assert syntax.kind == "syntax_error" and syntax.location and syntax.location.startswith("line 1")
    unknown = program_outcome(["Count", "Cnt"], e1)
    assert (unknown.kind, unknown.location, unknown.form) == ("syntax_error", "token 1", "prefix")
    typed = program_outcome("Count(QueryColor(Unique(SceneAtStart())))", e1)
    assert typed.kind == "type_error"
    assert (typed.module, typed.argument, typed.found) == ("Count", 1, "Color")
    assert typed.expected == ("EventSet", "ObjectSet")
    value = program_outcome('Count(FilterColor(SceneAtStart(), "pink"))', e1)
    assert value.kind == "type_error" and "allowed: gray" in (value.message or "")
    not_answer = program_outcome("FilterDynamic(SceneAtStart())", e1)
    assert not_answer.kind == "type_error" and not_answer.found == "ObjectSet"
    invalid = program_outcome("QueryColor(Unique(SceneAtStart()))", e1)
    assert invalid.kind == "invalid"
    assert invalid.node == "Unique(SceneAtStart())" and "holds 9 objects" in (invalid.message or "")


def test_invalid_explains_filter_first_and_missing_counterfactuals(e1: Simulation) -> None:
    first = program_outcome("IsBefore(FilterFirst(FilterBefore(Events(), FilterFirst(Events()))), "
                            "FilterLast(Events()))", e1)
    assert first.kind == "invalid" and first.message == "FilterFirst: the event set is empty"
    assert first.node == "FilterFirst(FilterBefore(Events(), FilterFirst(Events())))"
    static = program_outcome("AnyTrue(ExistList(GetCounterfactEventsList(FilterStationary(SceneAtStart(), 0))))", e1)
    assert static.kind == "invalid" and "has no variation for object" in (static.message or "")
    partner = program_outcome("QueryColor(EventPartner(FilterFirst(FilterCollision(Events())), "
                              "Unique(FilterShape(SceneAtStart(), \"triangle\"))))", e1)
    assert partner.kind in ("answer", "invalid")
    if partner.kind == "invalid":
        assert "EventPartner: object" in (partner.message or "") or "Unique" in (partner.message or "")


def test_outcome_json_is_plain_data(e1: Simulation) -> None:
    data = program_outcome(["Count", "Cnt"], e1).to_json()
    assert json.loads(json.dumps(data)) == data
    assert data["outcome"] == "syntax_error" and "did you mean Count" in data["message"]


def test_read_program_detects_forms() -> None:
    p = parse(COUNT_FALL)
    assert read_program(p.to_nodes()).key == p.key
    assert read_program(p.to_tokens("postfix"), "postfix").key == p.key
    assert read_program(" ".join(p.to_tokens()), "prefix").key == p.key
    with pytest.raises(CraftError, match="a program must be DSL text"):
        read_program(42)


def test_program_cache_reads_each_distinct_program_once() -> None:
    cache = ProgramCache(maxsize=2)
    p = parse(COUNT_FALL)
    a = cache.get(p.to_tokens(), "prefix")
    assert cache.get(list(p.to_tokens()), "prefix") is a
    assert (cache.hits, cache.misses) == (1, 1)
    with pytest.raises(CraftError):
        cache.get(["Cnt"], "prefix")
    with pytest.raises(CraftError):  # the error is cached and raised again
        cache.get(["Cnt"], "prefix")
    cache.get(p.to_nodes(), "nodes")
    assert len(cache) == 2  # the oldest entry left


def test_program_cache_reads_a_token_list_it_cannot_key() -> None:
    """A token that is not hashable makes the list unkeyable: it is read (a syntax error, as without a cache),
    never a TypeError."""
    cache = ProgramCache()
    with pytest.raises(ProgramError) as caught:
        cache.get(["Count", ["x"]], "prefix")
    with pytest.raises(ProgramError) as alone:
        read_program(["Count", ["x"]], "prefix")
    assert str(caught.value) == str(alone.value)
    assert len(cache) == 0


def test_program_cache_keys_node_lists_by_their_exact_form() -> None:
    """A node list that reads differently is never served another's entry: ``"inputs": null`` is an error where no
    ``inputs`` is valid, and a list holding objects marshal cannot write is read, not cached."""
    cache = ProgramCache()
    ok = [{"type": "end_scene"}, {"type": "count", "inputs": [0]}]
    bad = [{"type": "end_scene", "inputs": None}, {"type": "count", "inputs": [0]}]
    assert str(cache.get(ok, "nodes")) == "Count(SceneAtEnd())"
    with pytest.raises(CraftError, match="'inputs' must be a list of node indexes, found null"):
        cache.get(bad, "nodes")
    assert cache.get([dict(n) for n in ok], "nodes") is cache.get(ok, "nodes")
    odd = [{"type": "end_scene", "inputs": object()}]
    with pytest.raises(CraftError):
        cache.get(odd, "nodes")
    assert len(cache) == 2

# -- traces -----------------------------------------------------------------------------------------------------


def test_recorded_outputs_agree_with_the_oracle_trace(e1: Simulation) -> None:
    from craft_dsl.templates import first_instances

    for _t, _params, program, _answer in first_instances(e1, include_dropped=True):
        nodes = program.to_nodes(outputs=e1)
        trace = {str(k): n["_output"] for k, n in enumerate(nodes)}
        result = compare_trace(Program.from_nodes(nodes), e1, trace)
        assert result.compared == len(nodes) and result.agreed == len(nodes), str(program)
        assert result.first_divergence is None


def test_first_divergence_is_the_earliest_node_in_evaluation_order(e1: Simulation) -> None:
    p = Program.from_tokens(["Count", "FilterDynamic", "FilterObjectsFromEvents", "FilterCollideGround", "Events"])
    values = p.values(e1)
    objects = sorted(values[2])
    # tokens: 0 Count, 1 FilterDynamic, 2 FilterObjectsFromEvents, 3 FilterCollideGround, 4 Events
    result = compare_trace(p, e1, {"0": 99, "2": objects + [77], "1": objects})
    assert result.compared == 3 and result.agreed == 0 or result.agreed == 1
    assert result.first_divergence is not None
    assert result.first_divergence.node == 2 and result.first_divergence.module == "FilterObjectsFromEvents"
    assert result.per_module["Count"] == [1, 0]


def test_trace_values_in_every_documented_shape(e1: Simulation) -> None:
    event = e1.events[1]
    as_dict = {"type": event.type, "step": event.step, "objects": list(reversed(event.objects))}
    assert values_agree(event, as_dict, DslType.EVENT, e1, "t")
    assert values_agree(event, event.id, DslType.EVENT, e1, "t")
    original = {"EnterBasket": "ContainerEndUp", "TouchStart": "StartTouching"}.get(event.type, event.type)
    assert values_agree(event, {**as_dict, "type": original}, DslType.EVENT, e1, "t")
    assert values_agree((1, 3), [3, 1], DslType.OBJECT_SET, e1, "t")
    assert values_agree(True, "yes", DslType.BOOL, e1, "t")
    assert values_agree(2, "2", DslType.INTEGER, e1, "t")
    assert values_agree("red", "Red", DslType.COLOR, e1, "t")
    assert values_agree(((1,), ()), [[1], []], DslType.OBJECT_SET_LIST, e1, "t")
    assert not values_agree(((1,), ()), [[], [1]], DslType.OBJECT_SET_LIST, e1, "t")
    from craft_dsl import INVALID

    assert values_agree(INVALID, "__INVALID__", DslType.OBJECT, e1, "t")
    assert not values_agree(3, "INVALID", DslType.OBJECT, e1, "t")


@pytest.mark.parametrize(
    ("trace", "needle"),
    [
        ({"7": 1}, "node 7 does not exist"),
        ({"x": 1}, "is not a node number"),
        ({"0": [1]}, "expected an integer"),
        ({"1": 3}, "expected a list of object ids"),
        ({"4": [{"step": 3}]}, "expected an event"),
        ({"4": [{"type": "Bump", "step": 3, "objects": []}]}, "unknown event type 'Bump'"),
        ({"4": [999]}, "event id 999 is not an event"),
        ("nonsense", "expected an object"),
        ([1, 2, 3, 4, 5, 6], "lists 6 values but the program has 5 nodes"),
    ],
)
def test_malformed_traces_name_node_and_type(e1: Simulation, trace: Any, needle: str) -> None:
    p = Program.from_tokens(["Count", "FilterDynamic", "FilterObjectsFromEvents", "FilterCollideGround", "Events"])
    with pytest.raises(TraceError, match=needle):
        compare_trace(p, e1, trace, "preds.json: record '0_1', field 'trace'")


def test_a_trace_of_an_unused_node_is_counted_not_compared(e1: Simulation) -> None:
    nodes = [{"type": "start_scene", "inputs": []}, {"type": "events", "inputs": []}, {"type": "count", "inputs": [1]}]
    result = compare_trace(Program.from_nodes(nodes), e1, [[0, 1], None, len(e1.events)])
    assert (result.unused, result.compared, result.agreed) == (1, 1, 1)


# -- answer distributions -------------------------------------------------------------------------------------------


def test_distribution_scores() -> None:
    right, ll, brier = score_distribution({"true": 0.8, "false": 0.2}, True)
    assert right and ll == pytest.approx(math.log(0.8)) and brier == pytest.approx(0.04 + 0.04)
    wrong, ll, brier = score_distribution({"red": 1.0}, "blue")
    assert not wrong and ll == pytest.approx(math.log(1e-6)) and brier == pytest.approx(2.0)


def test_a_perception_answer_distribution_is_read_as_written(tmp_path: Path) -> None:
    from craft_dsl.perception.distribution import AnswerDistribution

    dist = AnswerDistribution({"true": 0.25, "false": 0.75}, {"true": True, "false": False}, "exact", 4)
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"0_1": {"answer_distribution": dist.to_json()}}))
    assert collect_predictions(path)[(0, 1)].distribution == {"true": 0.25, "false": 0.75}


# -- predictions files -----------------------------------------------------------------------------------------------


def test_prediction_files_in_every_layout(tmp_path: Path) -> None:
    obj = {"0_1": "red", "0_2": {"answer": 2, "program": "Count(SceneAtStart())", "extra": 1}}
    (tmp_path / "a.json").write_text(json.dumps(obj))
    (tmp_path / "b.json").write_text(json.dumps([{"video_index": 0, "question_index": 1, "answer": "red"}]))
    (tmp_path / "c.jsonl").write_text('{"video_index": 0, "question_index": 1, "answer": "red"}\n\n'
                                      '{"key": "0_2", "program": ["Count", "SceneAtStart"]}\n')
    a = collect_predictions(tmp_path / "a.json")
    assert a[(0, 1)].answer == "red" and a[(0, 2)].program == "Count(SceneAtStart())"
    assert a[(0, 2)].unknown_fields == ("extra",)
    assert collect_predictions(tmp_path / "b.json")[(0, 1)].answer == "red"
    c = collect_predictions(tmp_path / "c.jsonl")
    assert c[(0, 2)].program == ["Count", "SceneAtStart"]


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        ('{"0_1": "a", "0_1": "b"}', "appears twice"),
        ('{"x": "a"}', "is not '<video_index>_<question_index>'"),
        ('{"0_1": {"answer": [1]}}', "field 'answer'"),
        ('{"0_1": {"program": 3}}', "field 'program'"),
        ('{"0_1": {"program_format": "infix"}}', "field 'program_format'"),
        ('{"0_1": {"answer_distribution": {"a": 0.5}}}', "sum to 0.5"),
        ('{"0_1": {"answer_distribution": {"a": 1.5}}}', "number in \\[0, 1\\]"),
        ('{"0_1": null}', "is null"),
        ('[{"video_index": 0, "question_index": 1}, {"video_index": 0, "question_index": 1}]', "already predicted"),
        ('{"0_1": "a"', "not valid JSON"),
        ("3", "expected an object"),
    ],
)
def test_bad_prediction_files_name_file_record_and_field(tmp_path: Path, content: str, needle: str) -> None:
    path = tmp_path / "preds.json"
    path.write_text(content)
    with pytest.raises(CraftError, match=needle) as info:
        collect_predictions(path)
    assert str(path) in str(info.value)


# -- evaluate end to end ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def fixture_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("ds")
    dataset, annotations = build_dataset([load_simulation(E1_PATH)], include_dropped=True)
    (folder / "dataset.json").write_text(json.dumps(dataset))
    (folder / "annotations.json").write_text(json.dumps(annotations))
    return folder


def _questions(folder: Path) -> list[dict[str, Any]]:
    return [q for v in json.loads((folder / "dataset.json").read_text()) for q in v["questions"]["questions"]]


def test_perfect_predictions_score_100_in_every_form(fixture_dir: Path) -> None:
    qs = _questions(fixture_dir)
    forms = ["text", "nodes", "prefix", "postfix"]
    preds = {}
    for i, q in enumerate(qs):
        p = Program.from_nodes(q["program"])
        form = forms[i % 4]
        program: Any = {"text": str(p), "nodes": q["program"], "prefix": p.to_tokens(),
                        "postfix": p.to_tokens("postfix")}[form]
        preds[f"{q['video_index']}_{q['question_index']}"] = {
            "answer": q["answer"], "program": program, "program_format": form,
            "trace": [n["_output"] for n in q["program"]] if form == "nodes" else {},
            "answer_distribution": {str(q["answer"]): 1.0},
        }
    report = evaluate_predictions(fixture_dir, preds)
    m = report.overall
    assert m.questions == len(qs)
    for rate in (m.validity, m.exact_match_rate, m.execution_accuracy, m.answer_accuracy, m.trace_agreement,
                 m.mode_accuracy):
        assert rate == 100.0
    assert m.mean_log_likelihood == 0.0 and m.mean_brier == 0.0
    assert {name for name, _ in report.groups()} >= {"All", "C", "CF", "D", "D/2Q", "C/A"}


def test_wrong_predictions_are_diagnosed(fixture_dir: Path) -> None:
    qs = _questions(fixture_dir)
    q0, q1, q2, q3 = qs[:4]
    p0 = Program.from_nodes(q0["program"])
    preds = {
        f"0_{q0['question_index']}": {"program": ["Cnt"] + p0.to_tokens()[1:]},
        f"0_{q1['question_index']}": {"program": "QueryColor(Unique(SceneAtStart()))"},
        f"0_{q2['question_index']}": {"answer": "nonsense"},
    }
    report = evaluate_predictions(fixture_dir / "dataset.json", preds, fixture_dir / "annotations.json")
    by_key = {r.key: r for r in report.results}
    first = by_key[(0, q0["question_index"])].outcome
    assert first is not None and first.kind == "syntax_error"
    assert by_key[(0, q1["question_index"])].outcome.kind == "invalid"  # type: ignore[union-attr]
    assert by_key[(0, q2["question_index"])].answer_correct is False
    assert not by_key[(0, q3["question_index"])].predicted
    assert report.overall.outcomes["syntax_error"] == 1 and report.overall.programs == 2
    text = report.format()
    assert "unknown token 'Cnt'" in text and "INVALID on the true simulation" in text


def test_evaluate_rejects_bad_input(fixture_dir: Path) -> None:
    with pytest.raises(CraftError, match="name questions the dataset does not have"):
        evaluate_predictions(fixture_dir, {"99_0": "red"})
    with pytest.raises(CraftError, match="field 'trace': node 40 does not exist"):
        evaluate_predictions(fixture_dir, {"0_0": {"trace": {"40": 1}}})
    with pytest.raises(CraftError, match="token order"):
        evaluate_predictions(fixture_dir, {}, token_order="infix")


def test_a_split_selects_questions(fixture_dir: Path) -> None:
    report = evaluate_predictions(fixture_dir, {}, split={(0, 0), (0, 1)})
    assert report.overall.questions == 2 and report.outside_split == len(_questions(fixture_dir)) - 2


# -- command line -------------------------------------------------------------------------------------------------


def test_evaluate_command(fixture_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    q = _questions(fixture_dir)[0]
    preds = tmp_path / "preds.jsonl"
    tokens = Program.from_nodes(q["program"]).to_tokens("postfix")
    preds.write_text(json.dumps({"video_index": 0, "question_index": q["question_index"], "program": tokens}) + "\n")
    assert main(["evaluate", "--dataset", str(fixture_dir), "--predictions", str(preds),
                 "--token-order", "postfix", "--json", "--per-question"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["overall"]["exact_match"] == 1
    assert data["questions"][0]["program"]["outcome"] == "answer"
    assert main(["evaluate", "--dataset", str(fixture_dir), "--predictions", str(preds), "--per-template"]) == 0
    assert "exec %" in capsys.readouterr().out
    bad = tmp_path / "bad.json"
    bad.write_text('{"0_0": {"trace": {"99": 1}}}')
    assert main(["evaluate", "--dataset", str(fixture_dir), "--predictions", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "bad.json: key '0_0', field 'trace': node 99" in err


def test_vocab_and_export_pairs(fixture_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "vocab.json"
    assert main(["vocab", "--out", str(out)]) == 0
    vocab = json.loads(out.read_text())
    assert list(vocab["program_token_to_idx"])[:4] == ["<NULL>", "<START>", "<END>", "<UNK>"]
    assert {"Count", "FilterColor", "red", "0", "-1"} <= set(vocab["program_token_to_idx"])
    assert {"how", "many", "basket", "bucket", "?"} <= set(vocab["question_token_to_idx"])
    assert vocab == vocabulary()
    pairs = tmp_path / "pairs.jsonl"
    assert main(["export-pairs", "--dataset", str(fixture_dir), "--out", str(pairs), "--order", "postfix"]) == 0
    rows = [json.loads(line) for line in pairs.read_text().splitlines()]
    assert len(rows) == len(_questions(fixture_dir))
    for row in rows:
        assert str(Program.from_tokens(row["program_tokens"], "postfix")) == row["program"]
        assert set(row["question_tokens"]) <= set(vocab["question_token_to_idx"]), row["question"]


def test_evaluate_runs_as_an_installed_command(fixture_dir: Path, tmp_path: Path) -> None:
    preds = tmp_path / "p.json"
    preds.write_text(json.dumps({"0_0": "True"}))
    res = subprocess.run([sys.executable, "-m", "craft_dsl.cli", "evaluate", "--dataset", str(fixture_dir),
                          "--predictions", str(preds)], capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr
    assert "answer %" in res.stdout
