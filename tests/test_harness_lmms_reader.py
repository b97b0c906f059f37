"""The reader as an lmms-eval model (craft_dsl.harness.lmms_reader): each video read once, its answers those of
``craft-dsl read``; with lmms-eval installed, ``lmms-eval --model craft_reader`` over an exported task folder reports
per category what ``craft-dsl read`` then ``craft-dsl score`` give on the same videos, answer for answer."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from craft_dsl.cli import main
from craft_dsl.errors import CraftError
from craft_dsl.harness.answers import kind_of_template, parse_answer
from craft_dsl.harness.lmms_eval import METRIC_OF_GROUP, VisualSettings, export_lmms_eval
from craft_dsl.harness.lmms_reader import MODEL_ID, ReadSettings, VideoAnswers, _settings_from_args
from craft_dsl.verify import read_split
from craft_dsl.verify.categories import FAMILIES

PARTS = {"easy": "random", "hard": "hard"}
#: The users' dataset is made with --steps 200 (tests/conftest.py): its videos are whole at 200 steps.
STEPS = 200


def _questions(dataset: Path, video_index: int) -> list[Any]:
    from craft_dsl.reader import Question

    rows = json.loads((dataset / "dataset_minimal.json").read_text())
    return [Question(r["video_index"], r["question_index"], r["question"]) for r in rows
            if r["video_index"] == video_index]


def test_each_video_is_read_once_and_answers_as_craft_dsl_read(users_dataset: Path, video: Path) -> None:
    from craft_dsl.reader.cli import dataset_engine, read_video

    questions = _questions(users_dataset, int(video.stem))
    engine = dataset_engine([str(users_dataset)])
    expected = {a.question.question_index: a.answer
                for a in read_video(str(video), questions, steps=STEPS, first_engine=engine)["answers"]}
    reader = VideoAnswers(ReadSettings(steps=STEPS))
    first, later = questions[::2], questions[1::2]
    got = reader.answer([(video, q) for q in first], lambda _path: engine)
    got += reader.answer([(video, q) for q in later] + [(video, first[0])], lambda _path: engine)[:-1]
    assert reader.readings == 1  # the later questions come from the kept scene
    assert got == [expected[q.question_index] for q in [*first, *later]]
    rows = json.loads((users_dataset / "dataset_minimal.json").read_text())
    template = {(r["video_index"], r["question_index"]): r["template_id"] for r in rows}
    for q, answer in zip([*first, *later], got):  # the text lmms-eval scores reads back as the same answer
        kind = kind_of_template(template[q.video_index, q.question_index])
        assert answer is None or parse_answer(answer, kind) == answer


def test_a_video_that_cannot_be_read_gives_no_answers(tmp_path: Path) -> None:
    from craft_dsl.reader import Question

    bad = tmp_path / "000001.mpg"
    bad.write_bytes(b"not a video")
    messages: list[str] = []
    reader = VideoAnswers(report=messages.append)
    assert reader.answer([(bad, Question(1, 0, "How many objects fall to the ground?"))]) == [None]
    assert len(messages) == 1 and messages[0].startswith(f"error: {bad}") and "scored wrong" in messages[0]


def test_model_arguments_are_checked() -> None:
    settings, workers, dataset = _settings_from_args({"votes": 0, "steps": "200", "workers": 2, "engine": "box2d",
                                                      "dataset": "/data/craft", "batch_size": 1, "device": "cpu"})
    assert settings == ReadSettings(votes=0, steps=200, engine="box2d") and workers == 2 and dataset == "/data/craft"
    with pytest.raises(CraftError, match="unknown model argument worker; allowed: dataset, decoder"):
        _settings_from_args({"worker": 2})
    with pytest.raises(CraftError, match="steps must be a whole number"):
        _settings_from_args({"steps": "many"})
    with pytest.raises(CraftError, match="steps must be a whole number of at least 1"):
        _settings_from_args({"steps": 0})
    with pytest.raises(CraftError, match="unknown engine 'ode'; allowed: auto, box2d, pymunk"):
        _settings_from_args({"engine": "ode"})
    with pytest.raises(CraftError, match="workers must be at least 1"):
        _settings_from_args({"workers": 0})


# -- lmms-eval itself (pip install -e '.[lmms-eval]', best in a venv of its own: docs/evaluate.md) -----------------


def _lmms_eval_missing() -> str | None:
    if importlib.util.find_spec("lmms_eval") is None:
        return "lmms-eval is not installed (pip install -e '.[lmms-eval]'; see docs/evaluate.md)"
    return None


needs_lmms_eval = pytest.mark.skipif(_lmms_eval_missing() is not None, reason=str(_lmms_eval_missing()))


@needs_lmms_eval
def test_lmms_eval_finds_the_model_by_its_entry_point() -> None:
    from importlib.metadata import entry_points

    names = [ep.name for ep in entry_points().select(group="lmms_eval.models")]
    assert MODEL_ID in names, "craft-dsl's entry point is not installed: pip install -e . again"
    from lmms_eval import models

    cls = models.get_model(MODEL_ID)
    assert cls.__name__ == "CraftReader" and cls.__module__ == "craft_dsl.harness.lmms_reader"
    with pytest.raises(CraftError, match="unknown model argument"):
        cls.create_from_arg_string("frames=8")


@needs_lmms_eval
def test_an_lmms_eval_run_of_the_reader_equals_read_and_score(users_dataset: Path, tmp_path: Path) -> None:
    """The reader through lmms-eval (two workers) and through craft-dsl read: the same answer to every question of
    both test parts, so the same accuracy in every column and sub-category."""
    tasks = tmp_path / "craft_tasks"
    export_lmms_eval(users_dataset, tasks, settings=VisualSettings("frames", 2))
    env = {**os.environ, "HF_DATASETS_OFFLINE": "1", "HF_HUB_OFFLINE": "1"}
    out = tmp_path / "lmms"
    res = subprocess.run([sys.executable, "-m", "lmms_eval", "--model", MODEL_ID, "--model_args",
                          f"steps={STEPS},workers=2", "--tasks", "craft", "--include_path", str(tasks),
                          "--output_path", str(out), "--log_samples"],
                         capture_output=True, text=True, env=env, timeout=900, check=False)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-3000:]
    results = json.loads(next(out.rglob("*_results.json")).read_text())["results"]

    # craft-dsl read over the test parts' videos, then craft-dsl score on each part
    rows = json.loads((users_dataset / "dataset_minimal.json").read_text())
    keys = {p: read_split(users_dataset / f"split_info_{s}.json", "test") for p, s in PARTS.items()}
    videos = {v for part in keys.values() for v, _q in part}
    questions = tmp_path / "questions.json"
    questions.write_text(json.dumps([r for r in rows if r["video_index"] in videos]))
    preds = tmp_path / "preds.json"
    assert main(["read", "--videos", str(users_dataset / "videos"), "--questions", str(questions), "--out",
                 str(preds), "--steps", str(STEPS), "--workers", "1", "--quiet"]) == 0
    answers = json.loads(preds.read_text())
    for part, split in PARTS.items():
        log = next(out.rglob(f"*_samples_craft_{part}.jsonl"))
        samples = [json.loads(line) for line in log.read_text().splitlines()]
        assert len(samples) == len(keys[part])
        for sample in samples:
            item = sample["accuracy"]
            assert item["prediction"] == answers[f"{item['video_index']}_{item['question_index']}"], item
        score = subprocess.run([sys.executable, "-m", "craft_dsl", "score", "--questions",
                                str(users_dataset / "dataset_minimal.json"), "--predictions", str(preds), "--split",
                                str(users_dataset / f"split_info_{split}.json"), "--part", "test", "--json"],
                               capture_output=True, text=True, check=True)
        report = json.loads(score.stdout)
        got = results[f"craft_{part}"]
        assert got["accuracy,none"] == report["columns"]["All"]["accuracy"]
        for family in FAMILIES:
            if family in report["columns"]:
                assert got[f"{METRIC_OF_GROUP[family]},none"] == report["columns"][family]["accuracy"], family
        for category, s in report["per_category"].items():
            assert got[f"{METRIC_OF_GROUP[category]},none"] == s["accuracy"], category
