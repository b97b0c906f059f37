"""Fuzz: verification and prediction inputs. Predictions files in every form (object, list of records, JSON
Lines) with hostile keys and answers, and mutations of dataset.json, dataset_minimal.json, split files and
annotations.json: score, evaluate and verify either finish or fail with a CraftError naming the file.

Long run: python -m pytest tests/ -k fuzz --hypothesis-profile=long
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import CraftError, load_simulation
from craft_dsl.errors import DatasetFileError, InputFileError, PredictionsFileError
from craft_dsl.oracle import evaluate_predictions
from craft_dsl.oracle.predictions import collect_predictions
from craft_dsl.verify import (
    build_dataset,
    minimal_records,
    parse_dataset,
    read_dataset,
    read_questions,
    read_split,
    score,
    verify_dataset,
)
from tests.conftest import E1_PATH
from tests.fuzz.hostile import expect_only_craft_errors, file_bytes, hostile_scalars, json_texts, mutated, write

SLOW = settings(suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
DATASET, ANNOTATIONS = build_dataset([load_simulation(E1_PATH)], include_dropped=True)
MINIMAL = minimal_records(DATASET)
QUESTIONS = parse_dataset(DATASET)
KEYS = [f"{q.video_index}_{q.question_index}" for q in QUESTIONS]
SPLIT = {"train": [], "test": [{"video_index": q.video_index, "question_index": q.question_index} for q in QUESTIONS]}


def keys() -> st.SearchStrategy[str]:
    return st.one_of(st.sampled_from(KEYS), st.sampled_from(["0_0", "00_0", " 0_1 ", "0-1", "", "_", "1_", "a_b",
                                                            "9" * 13 + "_0", "٣_1", "0_0\n", "-1_0"]),
                     st.builds(lambda v, q: f"{v}_{q}", st.integers(0, 10**13), st.integers(0, 10**13)),
                     st.text(max_size=8))


def answers() -> st.SearchStrategy[Any]:
    return st.one_of(st.sampled_from(["True", "false", "2", "red", "cube", "small", " 02 ", "2.0", "9" * 400]),
                     hostile_scalars(),
                     st.fixed_dictionaries({}, optional={"answer": hostile_scalars(), "program": st.text(max_size=20),
                                                         "trace": st.just({}), "extra": st.integers()}))


@st.composite
def prediction_files(draw: st.DrawFn) -> tuple[str, str]:
    """(suffix, text) of a predictions file in one of the three forms, with hostile entries."""
    form = draw(st.sampled_from(["object", "array", "jsonl"]))
    entries = draw(st.lists(st.tuples(keys(), answers()), max_size=12))
    if form == "object":
        parts = []
        for k, a in entries:
            try:
                parts.append(f"{json.dumps(k)}: {json.dumps(a)}")
            except ValueError:
                parts.append(f"{json.dumps(k)}: 1")
        text = "{" + ", ".join(parts) + "}"
    else:
        records = []
        for k, a in entries:
            v, _, q = k.partition("_")
            record: dict[str, Any] = {"video_index": int(v) if v.isascii() and v.isdigit() and len(v) < 20 else v,
                                      "question_index": int(q) if q.isascii() and q.isdigit() and len(q) < 20 else q,
                                      "answer": a}
            if draw(st.integers(0, 5)) == 0:
                record = draw(mutated(record, max_changes=1))
            try:
                records.append(json.dumps(record))
            except ValueError:
                records.append("{}")
        text = "[" + ", ".join(records) + "]" if form == "array" else "\n".join(records)
    if draw(st.integers(0, 3)) == 0:
        text = draw(json_texts(None).map(lambda t: t)) if draw(st.booleans()) else text[: draw(st.integers(0,
                                                                                                           len(text)))]
    return (".jsonl" if form == "jsonl" else ".json"), text


@SLOW
@given(prediction_files(), st.data())
def test_fuzz_predictions_files(file: tuple[str, str], data: st.DataObject) -> None:
    suffix, text = file
    raw = data.draw(file_bytes(text)) if data.draw(st.integers(0, 4)) == 0 else text.encode("utf-8", "surrogatepass")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = write(folder / f"preds{suffix}", raw)
        questions = write(folder / "dataset_minimal.json", json.dumps(MINIMAL))
        report = expect_only_craft_errors(lambda: score(questions, path), str(path))
        if isinstance(report, CraftError):
            assert isinstance(report, PredictionsFileError), report
        else:
            assert 0 <= report.predicted <= report.total == len(MINIMAL)
        oracle = expect_only_craft_errors(lambda: collect_predictions(path), str(path))
        if isinstance(oracle, CraftError):
            assert isinstance(oracle, PredictionsFileError), oracle
            return
        write(folder / "dataset.json", json.dumps(DATASET))
        write(folder / "annotations.json", json.dumps(ANNOTATIONS))
        expect_only_craft_errors(lambda: evaluate_predictions(folder, path))


@SLOW
@given(st.sampled_from(["dataset", "minimal", "split"]).flatmap(
    lambda kind: st.tuples(st.just(kind), mutated({"dataset": DATASET, "minimal": MINIMAL, "split": SPLIT}[kind],
                                                  max_changes=2))),
       st.data())
def test_fuzz_dataset_and_split_files(named: tuple[str, Any], data: st.DataObject) -> None:
    kind, doc = named
    try:
        text = json.dumps(doc)
    except ValueError:  # an integer beyond Python's text conversion
        return
    raw = data.draw(file_bytes(text)) if data.draw(st.integers(0, 5)) == 0 else text.encode("utf-8", "surrogatepass")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = write(folder / f"{kind}.json", raw)
        questions = write(folder / "questions.json", json.dumps(MINIMAL))
        if kind == "split":
            result = expect_only_craft_errors(lambda: read_split(path, "test"), str(path))
            if not isinstance(result, CraftError):
                expect_only_craft_errors(lambda: score(questions, {"0_0": "1"}, split=result))
        elif kind == "minimal":
            result = expect_only_craft_errors(lambda: read_questions(path), str(path))
            if not isinstance(result, CraftError):
                expect_only_craft_errors(lambda: score(path, {k: "2" for k in KEYS}))
        else:
            result = expect_only_craft_errors(lambda: read_dataset(path), str(path))
            if not isinstance(result, CraftError):
                report = expect_only_craft_errors(lambda: verify_dataset(result, ANNOTATIONS))
                assert not isinstance(report, CraftError), report  # bad programs are reported, not raised
        if isinstance(result, CraftError):
            assert isinstance(result, (DatasetFileError, InputFileError)), result


@SLOW
@given(mutated(ANNOTATIONS, max_changes=2), st.data())
def test_fuzz_annotations(annotations: Any, data: st.DataObject) -> None:
    try:
        text = json.dumps(annotations, indent=data.draw(st.sampled_from([None, 1])))
    except ValueError:
        return
    raw = data.draw(file_bytes(text)) if data.draw(st.integers(0, 4)) == 0 else text.encode("utf-8", "surrogatepass")
    with tempfile.TemporaryDirectory() as tmp:
        path = write(Path(tmp) / "annotations.json", raw)
        report = expect_only_craft_errors(lambda: verify_dataset(QUESTIONS, path), str(path))
        if isinstance(report, CraftError):
            assert isinstance(report, DatasetFileError), report
        in_memory = expect_only_craft_errors(lambda: verify_dataset(QUESTIONS, annotations))
        assert not isinstance(in_memory, CraftError) or isinstance(in_memory, DatasetFileError), in_memory
