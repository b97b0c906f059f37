"""Dataset verification and prediction scoring (craft_dsl.verify, craft_dsl.verify.cli)."""

from __future__ import annotations

import copy
import json
import re
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from craft_dsl import CraftError, Program, load_simulation
from craft_dsl.physics import simulate
from craft_dsl.templates import DROPPED, templates
from craft_dsl.verify import (
    CATEGORIES,
    PAPER_HUMANS,
    PAPER_RESULTS,
    Annotations,
    Question,
    build_dataset,
    category_of,
    family_of,
    index_json_object,
    minimal_records,
    normalise_answer,
    parse_dataset,
    parse_minimal,
    parse_predictions,
    parse_split,
    read_dataset,
    read_minimal,
    read_questions,
    score,
    verify_dataset,
)
from craft_dsl.verify.cli import run as run_cli
from tests.conftest import E1_PATH

# -- fixtures ----------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def built() -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Two live simulations and E1, every template (dropped ones too) asked once where it has a binding."""
    sims = [simulate(1, seed=0), simulate(3, seed=2), load_simulation(E1_PATH)]
    return build_dataset(sims, include_dropped=True)


@pytest.fixture
def dataset(built: tuple[list[dict[str, Any]], dict[str, Any]]) -> list[dict[str, Any]]:
    return copy.deepcopy(built[0])


@pytest.fixture
def annotations(built: tuple[list[dict[str, Any]], dict[str, Any]]) -> dict[str, Any]:
    return copy.deepcopy(built[1])


@pytest.fixture
def files(tmp_path: Path, dataset: list[dict[str, Any]], annotations: dict[str, Any]) -> dict[str, Path]:
    paths = {"dataset": tmp_path / "dataset.json", "annotations": tmp_path / "annotations.json",
             "minimal": tmp_path / "dataset_minimal.json"}
    paths["dataset"].write_text(json.dumps(dataset))
    paths["annotations"].write_text(json.dumps(annotations, indent=1))
    paths["minimal"].write_text(json.dumps(minimal_records(dataset)))
    return paths


def _question(dataset: list[dict[str, Any]], template_id: str) -> dict[str, Any]:
    family, index = template_id.rsplit("_", 1)
    for video in dataset:
        for q in video["questions"]["questions"]:
            if q["template_filename"] == f"{family}.json" and q["question_family_index"] == int(index):
                return q
    raise AssertionError(f"no {template_id} question")


def _write(tmp_path: Path, name: str, data: Any) -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


# -- categories and paper data ------------------------------------------------------------------------------------


def test_categories_cover_the_67_templates_as_in_readme_section_5() -> None:
    counts = Counter(category_of(t) for t in templates())
    assert counts == {"D/2Q": 4, "D/N-V": 12, "D/N-T": 6, "D/C": 2, "D/S": 2, "D/C-T": 12, "D/TO": 2,
                      "CF/O": 6, "CF/N": 3, "C/A": 9, "C/N": 9}
    assert list(counts) == list(CATEGORIES)
    kept = Counter(family_of(t) for t in templates() if t not in DROPPED)
    assert kept == {"D": 30, "CF": 6, "C": 12} and sum(kept.values()) == 48
    assert (category_of("descriptive_3"), category_of("descriptive_4"), category_of("descriptive_21"),
            category_of("counterfactual_6"), category_of("prevent_4")) == ("D/2Q", "D/N-V", "D/N-T", "CF/O", "C/N")
    with pytest.raises(CraftError, match="not a CRAFT template"):
        category_of("descriptive_40")


def test_paper_numbers_spot_checks() -> None:
    """A few cells of the paper's table (easy C, CF, D, All, then hard), checked digit by digit."""
    by_model = {row.model: row.easy + row.hard for row in PAPER_RESULTS}
    assert len(PAPER_RESULTS) == 17
    assert by_model["BERT-D"] == (68.44, 80.05, 93.41, 86.20, 66.33, 79.34, 91.30, 84.90)
    assert by_model["LSTM-D"] == (51.71, 55.89, 63.22, 59.53, 51.93, 56.00, 59.57, 57.64)
    assert PAPER_HUMANS == (71.27, 83.07, 87.45, 76.60)
    for row in PAPER_RESULTS:
        assert len(row.easy) == len(row.hard) == 4 and all(0 < v < 100 for v in row.easy + row.hard)


# -- answers ------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("a", "b"), [
    (True, "True"), (True, "true"), ("yes", True), (" YES ", "True"), (False, "False"), ("no", "false"),
    (2, "2"), ("02", 2), (2.0, "2"), ("2.0", 2), ("red", "Red"), ("Cube", " cube"), ("__INVALID__", "__invalid__"),
])
def test_answers_that_agree(a: Any, b: Any) -> None:
    assert normalise_answer(a) == normalise_answer(b)


@pytest.mark.parametrize(("a", "b"), [
    (True, "1"), (False, 0), (1, "one"), ("grey", "gray"), ("ball", "circle"), (None, "none"), (2.5, 2),
])
def test_answers_that_differ(a: Any, b: Any) -> None:
    assert normalise_answer(a) != normalise_answer(b)


# -- readers --------------------------------------------------------------------------------------------------


def test_read_dataset(files: dict[str, Path], dataset: list[dict[str, Any]]) -> None:
    qs = read_dataset(files["dataset"])
    n = sum(len(v["questions"]["questions"]) for v in dataset)
    assert len(qs) == n and n > 150
    q = qs[0]
    assert (q.video_index, q.question_index, q.template_id, q.video, q.simulation_id) == (0, 0, "descriptive_0",
                                                                                         "000000", "1")
    assert isinstance(q.program, tuple) and q.program[-1]["type"] == "count"
    assert {type(x.answer) for x in qs} == {bool, int, str}
    assert read_questions(files["dataset"]) == qs
    assert qs[-1].simulation_id == "1"  # E1's video_filename names sid_1


def test_read_minimal(files: dict[str, Path]) -> None:
    qs = read_minimal(files["minimal"])
    assert all(isinstance(q.answer, str) and q.program is None for q in qs)
    answers = {q.answer for q in qs}
    assert {"True", "False"} <= answers and any(a[0].isupper() and a not in ("True", "False") for a in answers)
    assert read_questions(files["minimal"]) == qs
    raw = json.loads(files["minimal"].read_text())
    assert {r["answer_type"] for r in raw} == {"Boolean", "Count", "Color", "Shape"}
    assert {r["question_type"] for r in raw} == {"Descriptive", "Counterfactual", "Cause", "Enable", "Prevent"}


def test_dataset_missing_field_names_file_record_and_field(tmp_path: Path, dataset: list[dict[str, Any]]) -> None:
    del dataset[1]["questions"]["questions"][2]["program"]
    path = _write(tmp_path, "dataset.json", dataset)
    with pytest.raises(CraftError) as err:
        read_dataset(path)
    msg = str(err.value)
    assert str(path) in msg and "video record 1, question 2" in msg and "field 'program'" in msg


def test_dataset_bad_answer_and_bad_video_record(dataset: list[dict[str, Any]]) -> None:
    bad = copy.deepcopy(dataset)
    bad[0]["questions"]["questions"][5]["answer"] = [1, 2]
    with pytest.raises(CraftError, match=r"video record 0, question 5: field 'answer': must be a boolean"):
        parse_dataset(bad)
    bad = copy.deepcopy(dataset)
    bad[2]["questions"] = []
    with pytest.raises(CraftError, match=r"dataset.json: video record 2: field 'questions'"):
        parse_dataset(bad)
    bad = copy.deepcopy(dataset)
    bad[0]["questions"]["questions"][1]["question_family_index"] = 99
    with pytest.raises(CraftError, match=r"question 1: field 'template_filename/question_family_index'"):
        parse_dataset(bad)
    with pytest.raises(CraftError, match="expected a JSON list of video records"):
        parse_dataset({"videos": []})


def test_minimal_malformed_records(files: dict[str, Path]) -> None:
    records = json.loads(files["minimal"].read_text())
    bad = copy.deepcopy(records)
    bad[3]["template_id"] = "descriptive_77"
    bad[3].pop("template_filename")
    with pytest.raises(CraftError, match=r"mini.json: record 3: field 'template_id': 'descriptive_77' is not"):
        parse_minimal(bad, "mini.json")
    bad = copy.deepcopy(records)
    bad[4]["video_index"] = "four"
    with pytest.raises(CraftError, match=r"record 4: field 'video_index': Input should be a valid integer"):
        parse_minimal(bad)
    bad = copy.deepcopy(records)
    bad[2]["template_id"] = "cause_1"
    with pytest.raises(CraftError, match=r"record 2: template_id 'cause_1' disagrees"):
        parse_minimal(bad)
    bad = copy.deepcopy(records)
    bad.append(dict(bad[0]))
    with pytest.raises(CraftError, match=rf"record {len(records)}: video_index 0, question_index 0 already used"):
        parse_minimal(bad)


def test_unreadable_json_files(tmp_path: Path) -> None:
    trunc = tmp_path / "dataset.json"
    trunc.write_text('[{"questions": ')
    with pytest.raises(CraftError, match=r"dataset.json: line 1, column 16: not valid JSON: .* may be truncated"):
        read_dataset(trunc)
    with pytest.raises(CraftError, match="no such file"):
        read_minimal(tmp_path / "missing.json")


def test_annotations_index_streams_with_any_chunk_size(tmp_path: Path, annotations: dict[str, Any]) -> None:
    small = {"000001": {"a": [1, 2.5e3, 'x\\"}y']}, "ünï": {"b": "é{"}, "000003": 12345, "4": []}
    path = tmp_path / "a.json"
    path.write_text(json.dumps(small, ensure_ascii=False, indent=2), encoding="utf-8")
    raw = path.read_bytes()
    for chunk in (1, 2, 3, 7, 64, 1 << 20):
        spans = index_json_object(path, chunk_size=chunk)
        assert list(spans) == list(small)
        assert {k: json.loads(raw[s:e]) for k, (s, e) in spans.items()} == small
    big = tmp_path / "annotations.json"
    big.write_text(json.dumps(annotations))
    store = Annotations.open(big, chunk_size=4096)
    assert store.ids() == ["000000", "000001", "000002"] and len(store) == 3
    assert store.raw("000001") == annotations["000001"]
    assert store.simulation("000002").dynamic_ids == load_simulation(E1_PATH).dynamic_ids


@pytest.mark.parametrize(("text", "message"), [
    ('{"000001": {"a": 1}', "truncated"),
    ('[{"a": 1}]', "expected a JSON object mapping video ids"),
    ('{"000001": {"a": 1}, "000001": {}}', "appears twice"),
    ('{"000001": {"a": 1} "x": 2}', r"expected ',' or '}' at byte 20"),
    ('{"000001": {"a": 1,}}', "not valid JSON at byte"),
])
def test_annotations_malformed(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "annotations.json"
    path.write_text(text)
    with pytest.raises(CraftError, match=message) as err:
        Annotations.open(path, chunk_size=5)
    assert str(path) in str(err.value)


def test_annotations_directory(tmp_path: Path, annotations: dict[str, Any]) -> None:
    (tmp_path / "sid_1").mkdir()
    for key, sim in annotations.items():
        (tmp_path / "sid_1" / f"{key}.json").write_text(json.dumps(sim))
    store = Annotations.open(tmp_path)
    assert sorted(store.ids()) == sorted(annotations)


def test_predictions_formats_and_errors() -> None:
    assert parse_predictions({"3_4": "Red", " 10_0 ": True}) == {(3, 4): "Red", (10, 0): True}
    assert parse_predictions([{"video_index": 3, "question_index": 4, "answer": 2}]) == {(3, 4): 2}
    with pytest.raises(CraftError, match=r"p.json: key '3-4' is not '<video_index>_<question_index>'"):
        parse_predictions({"3-4": "x"}, "p.json")
    with pytest.raises(CraftError, match=r"key '3_4': the answer must be a string"):
        parse_predictions({"3_4": ["x"]})
    with pytest.raises(CraftError, match=r"record 1: question 3_4 is already predicted"):
        parse_predictions([{"video_index": 3, "question_index": 4, "answer": 2}] * 2)
    with pytest.raises(CraftError, match=r"record 0, field 'answer': missing"):
        parse_predictions([{"video_index": 3, "question_index": 4}])
    with pytest.raises(CraftError, match="already predicted"):
        parse_predictions({"3_4": 1, "03_4": 1})


def test_split_parts() -> None:
    split = {"train": [{"video_index": 0, "question_index": 1}],
             "test": [{"video_index": 1, "question_index": 0}, {"video_index": 1, "question_index": 2}]}
    assert parse_split(split, "test") == {(1, 0), (1, 2)}
    assert parse_split(split, "train") == {(0, 1)}
    with pytest.raises(CraftError, match=r"s.json: has no part 'validation' \(parts: test, train\)"):
        parse_split(split, "validation", "s.json")
    with pytest.raises(CraftError, match=r"field 'test', record 0: field 'question_index'"):
        parse_split({"test": [{"video_index": 1}]}, "test")


# -- verification -------------------------------------------------------------------------------------------------


def test_built_dataset_verifies(dataset: list[dict[str, Any]], annotations: dict[str, Any]) -> None:
    report = verify_dataset(dataset, annotations)
    assert report.ok and report.videos == 3
    assert report.totals.total == report.totals.agree == sum(len(v["questions"]["questions"]) for v in dataset)
    assert not report.mismatches and not report.errors
    assert set(report.per_category) == set(CATEGORIES)
    assert sum(t.total for t in report.per_template.values()) == report.totals.total
    assert len(report.per_template) == 67  # every template has a question in at least one video
    assert any(t in DROPPED for t in report.per_template)


def test_build_dataset_leaves_dropped_templates_out_by_default() -> None:
    ds, ann = build_dataset({7: load_simulation(E1_PATH)})
    assert list(ann) == ["000007"] and ds[0]["questions"]["info"]["video_index"] == 7
    records = ds[0]["questions"]["questions"]
    assert [q["question_index"] for q in records] == list(range(len(records)))
    tids = {f"{q['template_filename'][:-5]}_{q['question_family_index']}" for q in records}
    assert not tids & DROPPED and len(tids) == len(records)
    assert all("_output" in node for q in records for node in q["program"])
    assert verify_dataset(ds, ann).ok


def test_verify_from_files(files: dict[str, Path]) -> None:
    report = verify_dataset(files["dataset"], files["annotations"])
    assert report.ok and report.totals.total > 150


def test_tampered_answer_is_a_mismatch(dataset: list[dict[str, Any]], annotations: dict[str, Any]) -> None:
    q = _question(dataset, "descriptive_22")
    true_answer = q["answer"]
    q["answer"] = "purple" if true_answer != "purple" else "red"
    n = _question(dataset, "cause_3")
    n["answer"] = n["answer"] + 1
    report = verify_dataset(dataset, annotations)
    assert not report.ok and report.totals.mismatch == 2 and not report.errors
    m = report.mismatches[0]
    assert (m.video_index, m.question_index, m.template_id) == (q["video_index"], q["question_index"],
                                                                 "descriptive_22")
    assert (m.recorded, m.recomputed) == (q["answer"], true_answer)
    assert m.program == str(Program.from_nodes(q["program"])) and m.program.startswith("QueryColor(")
    assert m.question == q["question"]
    assert report.per_template["descriptive_22"].mismatch == 1
    assert report.per_category["D/C"].mismatch == 1 and report.per_category["C/N"].mismatch == 1
    assert report.totals.agree == report.totals.total - 2


def test_recorded_answers_compare_after_normalisation(dataset: list[dict[str, Any]],
                                                      annotations: dict[str, Any]) -> None:
    for video in dataset:
        for q in video["questions"]["questions"]:
            q["answer"] = str(q["answer"]).capitalize()  # as dataset_minimal.json writes them
    assert verify_dataset(dataset, annotations).ok


def test_missing_simulation_is_an_error_entry(dataset: list[dict[str, Any]], annotations: dict[str, Any]) -> None:
    del annotations["000001"]
    report = verify_dataset(dataset, annotations)
    n1 = len(dataset[1]["questions"]["questions"])
    assert report.totals.error == n1 and report.totals.mismatch == 0
    assert report.totals.agree == report.totals.total - n1
    e = report.errors[0]
    assert (e.video_index, e.question_index, e.kind) == (1, 0, "simulation")
    assert "no simulation for video '000001'" in e.message


def test_broken_program_and_simulation_are_errors(dataset: list[dict[str, Any]],
                                                  annotations: dict[str, Any]) -> None:
    q = dataset[0]["questions"]["questions"][3]
    q["program"][-1]["type"] = "count_things"
    objects = annotations["000002"]["original_video_output"]["scene_states"][0]["scene"]["objects"]
    objects[:] = [o for o in objects if o["shape"] != "ground"]
    report = verify_dataset(dataset, annotations)
    kinds = Counter(e.kind for e in report.errors)
    assert kinds == {"program": 1, "simulation": len(dataset[2]["questions"]["questions"])}
    prog = next(e for e in report.errors if e.kind == "program")
    assert (prog.video_index, prog.question_index) == (0, 3) and "count_things" in prog.message
    sim = next(e for e in report.errors if e.kind == "simulation")
    assert "annotations['000002']" in sim.message and "not in the scene" in sim.message


def test_simulation_without_variations_gives_evaluation_errors(dataset: list[dict[str, Any]],
                                                               annotations: dict[str, Any]) -> None:
    annotations["000000"] = annotations["000000"]["original_video_output"]  # a bare simulator output
    report = verify_dataset(dataset[:1], annotations)
    assert report.errors and {e.kind for e in report.errors} == {"evaluation"}
    assert {e.template_id.split("_")[0] for e in report.errors} <= {"counterfactual", "cause", "enable", "prevent"}
    assert report.per_category["D/2Q"].agree == report.per_category["D/2Q"].total


def test_verify_report_json(dataset: list[dict[str, Any]], annotations: dict[str, Any]) -> None:
    for video in dataset:
        for q in video["questions"]["questions"][:2]:
            q["answer"] = 99
    report = verify_dataset(dataset, annotations)
    out = report.to_json(max_items=4)
    assert out["ok"] is False and out["mismatch"] == 6 and len(out["mismatches"]) == 4
    assert out["mismatches_omitted"] == 2
    assert set(out["mismatches"][0]) == {"video_index", "question_index", "template_id", "program", "question",
                                         "recorded", "recomputed"}
    assert list(out["per_category"]) == [c for c in CATEGORIES if c in out["per_category"]]
    assert "mismatches (2 of 6)" in report.format(max_items=2)


# -- scoring ----------------------------------------------------------------------------------------------------


def test_perfect_predictions_score_100_everywhere(files: dict[str, Path]) -> None:
    records = json.loads(files["minimal"].read_text())
    preds = {f"{r['video_index']}_{r['question_index']}": r["answer"] for r in records}
    report = score(files["minimal"], preds)
    assert report.total == len(records) and report.predicted == len(records) and report.missing == 0
    assert report.coverage == 100.0 and not report.unknown_predictions
    groups = [*report.columns.values(), *report.per_category.values(), *report.per_type.values(),
              *report.per_template.values()]
    assert all(g.accuracy == 100.0 for g in groups)
    # the raw answers of dataset.json score the same against the capitalised string answers
    raw = {(q.video_index, q.question_index): q.answer for q in read_dataset(files["dataset"])}
    assert score(files["minimal"], raw).columns["All"].accuracy == 100.0
    assert score(files["dataset"], preds).columns["All"].accuracy == 100.0


def _minimal(video: int, qi: int, tid: str, answer: str) -> dict[str, Any]:
    family, index = tid.rsplit("_", 1)
    return {"question": "?", "answer": answer, "template_filename": f"{family}.json", "template_id": tid,
            "question_family_index": int(index), "video_index": video, "question_index": qi, "simulation_id": "1"}


HAND = [  # (template, recorded answer, prediction or None for missing, correct?)
    ("descriptive_0", "2", "2", True),
    ("descriptive_22", "Red", "red", True),
    ("descriptive_24", "Cube", "circle", False),
    ("descriptive_26", "True", None, False),
    ("descriptive_38", "False", "no", True),
    ("counterfactual_0", "False", False, True),
    ("counterfactual_3", "1", 1, True),
    ("cause_0", "True", "yes", True),
    ("enable_3", "0", "2", False),
    ("prevent_1", "False", "True", False),
]


def test_hand_computed_mix() -> None:
    questions = [_minimal(i // 4, i % 4, tid, ans) for i, (tid, ans, _, _) in enumerate(HAND)]
    preds: dict[str, Any] = {f"{i // 4}_{i % 4}": p for i, (_, _, p, _) in enumerate(HAND) if p is not None}
    preds["9_9"] = "True"
    report = score(questions, preds)
    acc = {k: s.accuracy for k, s in report.columns.items()}
    assert acc == {"C": pytest.approx(100 / 3), "CF": 100.0, "D": 60.0, "All": 60.0}
    assert {k: (s.correct, s.total) for k, s in report.columns.items()} == {
        "C": (1, 3), "CF": (2, 2), "D": (3, 5), "All": (6, 10)}
    assert {c: (s.correct, s.total, s.missing) for c, s in report.per_category.items()} == {
        "D/2Q": (1, 1, 0), "D/C": (1, 1, 0), "D/S": (0, 1, 0), "D/C-T": (0, 1, 1), "D/TO": (1, 1, 0),
        "CF/O": (1, 1, 0), "CF/N": (1, 1, 0), "C/A": (1, 2, 0), "C/N": (0, 1, 0)}
    assert {t: (s.correct, s.total) for t, s in report.per_type.items()} == {
        "Descriptive": (3, 5), "Counterfactual": (2, 2), "Cause": (1, 1), "Enable": (0, 1), "Prevent": (0, 1)}
    assert report.per_template["prevent_1"].correct == 0 and report.per_template["cause_0"].correct == 1
    assert (report.predicted, report.missing, report.coverage) == (9, 1, 90.0)
    assert report.unknown_predictions == [(9, 9)]
    out = report.to_json()
    assert out["accuracy"]["All"] == 60.0 and out["unknown_predictions"] == ["9_9"]
    assert out["per_category"]["C/A"] == {"total": 2, "correct": 1, "missing": 0, "accuracy": 50.0}


def test_split_filtering() -> None:
    questions = [_minimal(i // 4, i % 4, tid, ans) for i, (tid, ans, _, _) in enumerate(HAND)]
    preds = {f"{i // 4}_{i % 4}": p for i, (_, _, p, _) in enumerate(HAND) if p is not None}
    test_part = parse_split({"test": [{"video_index": 1, "question_index": q} for q in range(4)]
                             + [{"video_index": 5, "question_index": 0}]}, "test")
    report = score(questions, preds, split=test_part)
    # video 1 holds HAND[4:8]: descriptive_38, counterfactual_0, counterfactual_3, cause_0, all correct
    assert report.total == 4 and report.columns["All"].accuracy == 100.0
    assert set(report.per_category) == {"D/TO", "CF/O", "CF/N", "C/A"}
    assert report.outside_split == 5 and report.split_not_in_questions == 1 and not report.unknown_predictions


def test_score_accepts_question_records_and_dropped_templates_are_noted() -> None:
    qs = [Question(0, 0, "descriptive_12", 1), Question(0, 1, "descriptive_0", 0)]
    report = score(qs, {(0, 0): "1"})
    assert report.dropped_templates == 1 and report.columns["D"].correct == 1 and report.missing == 1
    assert "2 predicted" not in report.format() and "note: 1 question(s)" in report.format()


# -- command line ------------------------------------------------------------------------------------------------


def _cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = run_cli(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_verify_exit_codes_and_json(capsys: pytest.CaptureFixture[str], files: dict[str, Path],
                                        dataset: list[dict[str, Any]], tmp_path: Path) -> None:
    code, out, _ = _cli(capsys, "verify", "--dataset", str(files["dataset"]), "--annotations",
                        str(files["annotations"]))
    assert code == 0 and re.match(r"verified \d+ questions over 3 videos: \d+ agree, 0 mismatch", out)
    code, out, _ = _cli(capsys, "verify", "--dataset", str(files["dataset"]), "--annotations",
                        str(files["annotations"]), "--json")
    assert code == 0 and json.loads(out)["ok"] is True
    _question(dataset, "descriptive_0")["answer"] = 42
    _question(dataset, "descriptive_1")["answer"] = 42
    tampered = _write(tmp_path, "tampered.json", dataset)
    code, out, _ = _cli(capsys, "verify", "--dataset", str(tampered), "--annotations", str(files["annotations"]),
                        "--json", "--max-mismatches", "1")
    data = json.loads(out)
    assert code == 1 and data["mismatch"] == 2 and len(data["mismatches"]) == 1 and data["mismatches_omitted"] == 1
    assert data["mismatches"][0]["recorded"] == 42 and data["mismatches"][0]["template_id"] == "descriptive_0"
    code, out, _ = _cli(capsys, "verify", "--dataset", str(tampered), "--annotations", str(files["annotations"]))
    assert code == 1 and "recorded 42, recomputed" in out and "program:  Count(" in out
    code, _, err = _cli(capsys, "verify", "--dataset", str(tmp_path / "nope.json"), "--annotations",
                        str(files["annotations"]))
    assert code == 2 and "nope.json: no such file" in err
    broken = _write(tmp_path, "broken.json", [{"questions": {"questions": [{"answer": 1}]}}])
    code, _, err = _cli(capsys, "verify", "--dataset", str(broken), "--annotations", str(files["annotations"]))
    assert code == 2 and "broken.json: video record 0, question 0: field 'program'" in err


def test_cli_score(capsys: pytest.CaptureFixture[str], files: dict[str, Path], tmp_path: Path) -> None:
    records = json.loads(files["minimal"].read_text())
    preds = [{"video_index": r["video_index"], "question_index": r["question_index"], "answer": r["answer"]}
             for r in records if r["video_index"] != 2]
    pfile = _write(tmp_path, "model_x.json", preds)
    split = _write(tmp_path, "split.json", {
        "train": [], "validation": [],
        "test": [{"video_index": r["video_index"], "question_index": r["question_index"]}
                 for r in records if r["video_index"] >= 1]})
    code, out, _ = _cli(capsys, "score", "--questions", str(files["minimal"]), "--predictions", str(pfile), "--json")
    data = json.loads(out)
    n2 = sum(r["video_index"] == 2 for r in records)
    assert code == 0 and data["questions"] == len(records) and data["missing"] == n2
    assert data["accuracy"]["All"] == pytest.approx(100 * (len(records) - n2) / len(records))
    code, out, _ = _cli(capsys, "score", "--questions", str(files["minimal"]), "--predictions", str(pfile),
                        "--split", str(split), "--part", "test", "--json", "--compare-paper", "hard")
    data = json.loads(out)
    n1 = sum(r["video_index"] == 1 for r in records)
    assert data["questions"] == n1 + n2 and data["columns"]["All"]["correct"] == n1
    assert data["paper"]["rows"][0] == {"group": "heuristic", "model": "Random", "C": 5.37, "CF": 4.62,
                                        "D": 5.08, "All": 4.98}
    code, out, _ = _cli(capsys, "score", "--questions", str(files["dataset"]), "--predictions", str(pfile),
                        "--compare-paper", "easy", "--per-template")
    assert code == 0 and "BERT-D" in out and "this run      model_x" in out and "descriptive_22" in out
    assert "D/N-T" in out and "humans" in out
    code, _, err = _cli(capsys, "score", "--questions", str(files["minimal"]), "--predictions", str(pfile),
                        "--part", "test")
    assert code == 2 and "--part needs --split" in err
    code, _, err = _cli(capsys, "score", "--questions", str(files["minimal"]), "--predictions", str(pfile),
                        "--split", str(split), "--part", "dev")
    assert code == 2 and "has no part 'dev'" in err


def test_cli_fixture_then_verify_through_main(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from craft_dsl.cli import main

    code = main(["verify-fixture", "--out", str(tmp_path), "--sim", "3:2"])
    assert code == 0 and "1 videos" in capsys.readouterr().err
    assert {p.name for p in tmp_path.iterdir()} == {"dataset.json", "dataset_minimal.json", "annotations.json"}
    code = main(["verify", "--dataset", str(tmp_path / "dataset.json"), "--annotations",
                 str(tmp_path / "annotations.json")])
    assert code == 0 and "0 mismatch" in capsys.readouterr().out
    code = main(["verify-fixture", "--out", str(tmp_path), "--sim", "x:2"])
    assert code == 2 and "expected SCENE:SEED" in capsys.readouterr().err
