"""The lmms-eval task folder (craft_dsl.harness.lmms_eval): its files, prompts, frames, and accuracies that equal
``craft-dsl score``'s on the same answers. The last tests load the folder with lmms-eval itself, when installed."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import random
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from craft_dsl.cli import main
from craft_dsl.errors import CraftError
from craft_dsl.harness.answers import kind_of_template
from craft_dsl.harness.lmms_eval import (
    KIND_INSTRUCTIONS,
    METRIC_OF_GROUP,
    VisualSettings,
    aggregate,
    doc_to_text,
    doc_to_visual,
    export_lmms_eval,
    frame_indices,
    process_results,
)
from craft_dsl.verify import read_questions, read_split, score
from craft_dsl.verify.categories import CATEGORIES, FAMILIES

PARTS = {"easy": "random", "hard": "hard"}


@pytest.fixture(scope="module")
def task_folder(users_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("lmms") / "craft_tasks"
    export_lmms_eval(users_dataset, out, settings=VisualSettings("frames", 4))
    return out


def _docs(folder: Path, part: str) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (folder / f"{part}.jsonl").read_text().splitlines()]


def _utils(folder: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"craft_utils_{abs(hash(folder))}", folder / "utils.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_folder_holds_a_group_and_one_task_per_test_part(task_folder: Path, users_dataset: Path) -> None:
    yaml = pytest.importorskip("yaml")
    names = sorted(p.name for p in task_folder.iterdir())
    assert names == ["craft.yaml", "craft_easy.yaml", "craft_hard.yaml", "craft_task.json", "easy.jsonl",
                     "hard.jsonl", "utils.py"]
    group = yaml.safe_load((task_folder / "craft.yaml").read_text())
    assert group == {"group": "craft", "task": ["craft_easy", "craft_hard"]}
    yaml.add_constructor("!function", lambda loader, node: f"!function {node.value}", Loader=yaml.SafeLoader)
    utils = _utils(task_folder)
    for part, split in PARTS.items():
        task = yaml.safe_load((task_folder / f"craft_{part}.yaml").read_text())
        assert task["task"] == f"craft_{part}" and task["dataset_path"] == "json"
        assert task["dataset_kwargs"] == {"data_files": {"test": f"{part}.jsonl"}} and task["test_split"] == "test"
        docs = _docs(task_folder, part)
        keys = read_split(users_dataset / f"split_info_{split}.json", "test")
        assert {(d["video_index"], d["question_index"]) for d in docs} == keys
        metrics = [m["metric"] for m in task["metric_list"]]
        present = {d["category"] for d in docs} | {d["family"] for d in docs}
        assert metrics == [METRIC_OF_GROUP[g] for g in ("All", *FAMILIES, *CATEGORIES) if g == "All" or g in present]
        for m in task["metric_list"]:  # every aggregation the task names exists in utils.py
            assert hasattr(utils, m["aggregation"].removeprefix("!function utils.")), m
        assert task["lmms_eval_specific_kwargs"]["default"]["frames"] == 4
        for d in docs:
            assert d["answer_kind"] == kind_of_template(d["template_id"])
            assert (users_dataset / d["video"]).is_file()


def test_the_prompt_states_the_expected_answer_kind(task_folder: Path) -> None:
    doc = next(d for d in _docs(task_folder, "easy") if d["answer_kind"] == "count")
    text = doc_to_text(doc, {"pre_prompt": "", "post_prompt": ""})
    assert text == f"{doc['question']}\n{KIND_INSTRUCTIONS['count']}"
    assert "whole number" in text
    assert doc_to_text({**doc, "answer_kind": "bool"}).endswith("Answer with True or False and nothing else.")
    assert doc_to_text(doc, {"pre_prompt": "P: ", "post_prompt": " Q"}).startswith("P: ")


def test_frame_sampling_by_count_or_rate() -> None:
    assert frame_indices(600, 60.0, frames=4) == [0, 200, 399, 599]
    assert frame_indices(600, 60.0, frames=1) == [0]
    assert frame_indices(3, 60.0, frames=8) == [0, 1, 2]
    assert frame_indices(600, 60.0, fps=2) == list(range(0, 600, 30))
    assert frame_indices(200, 60.0, fps=60) == list(range(200))
    assert frame_indices(0, 60.0) == []
    with pytest.raises(CraftError, match="frames must be a whole number"):
        VisualSettings("frames", 0)
    with pytest.raises(CraftError, match="at most 60"):
        VisualSettings("frames", 8, 120.0)
    with pytest.raises(CraftError, match="unknown visual"):
        VisualSettings("gif")


def test_doc_to_visual_gives_frames_or_the_video_path(task_folder: Path, users_dataset: Path) -> None:
    pytest.importorskip("PIL")
    doc = _docs(task_folder, "easy")[0]
    frames = doc_to_visual(doc, VisualSettings("frames", 3), users_dataset)
    assert len(frames) == 3 and frames[0].size == (256, 256)
    by_rate = doc_to_visual(doc, VisualSettings("frames", 8, 6.0), users_dataset)  # 200 steps at 60 fps, 6 fps
    assert len(by_rate) == 20
    assert doc_to_visual(doc, VisualSettings("video"), users_dataset) == [str(users_dataset / doc["video"])]
    with pytest.raises(CraftError, match="no such video"):
        doc_to_visual({**doc, "video": "videos/none.mpg"}, VisualSettings("video"), users_dataset)
    utils = _utils(task_folder)  # the folder's own settings (4 frames), overridden by the task's kwargs
    assert len(utils.doc_to_visual(doc)) == 4
    assert len(utils.doc_to_visual(doc, {"frames": 2})) == 2
    assert utils.doc_to_visual(doc, {"visual": "video"}) == [str(users_dataset.resolve() / doc["video"])]


def _model_outputs(docs: list[dict[str, Any]], seed: int) -> list[str]:
    """Messy outputs, from a seeded draw: the gold in wrappers, other answers, refusals, hedges."""
    rng = random.Random(seed)
    others = {"count": ["0", "one", "2", "three"], "bool": ["yes", "No.", "true", "It does not."],
              "color": ["red", "Blue", "gray"], "shape": ["cube", "a ball", "Triangle"]}
    out = []
    for d in docs:
        gold = str(d["answer"])
        choice = rng.random()
        if choice < 0.4:
            out.append(rng.choice([gold, f"The answer is {gold.lower()}.", f"**{gold}**", f"Answer: {gold}"]))
        elif choice < 0.8:
            out.append(rng.choice(others[d["answer_kind"]]))
        else:
            out.append(rng.choice(["I cannot tell.", "", "Hard to say from the video."]))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_accuracies_equal_craft_dsl_score_on_the_same_answers(task_folder: Path, users_dataset: Path, seed: int,
                                                                tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    questions = read_questions(users_dataset / "dataset_minimal.json")
    utils = _utils(task_folder)
    for part, split in PARTS.items():
        docs = _docs(task_folder, part)
        outputs = _model_outputs(docs, seed)
        items: dict[str, list[dict[str, Any]]] = {m: [] for m in METRIC_OF_GROUP.values()}
        for doc, text in zip(docs, outputs):
            for metric, item in process_results(doc, [text]).items():
                items[metric].append(item)
        assert utils.process_results(docs[0], [outputs[0]]) == process_results(docs[0], [outputs[0]])
        # the predictions file of the same outputs, through craft-dsl parse-answers, scored by craft-dsl score
        raw = tmp_path / f"{part}_outputs.json"
        raw.write_text(json.dumps({f"{d['video_index']}_{d['question_index']}": t for d, t in zip(docs, outputs)}))
        preds = tmp_path / f"{part}_preds.json"
        assert main(["parse-answers", "--questions", str(users_dataset / "dataset_minimal.json"), "--outputs",
                     str(raw), "--out", str(preds)]) == 0
        capsys.readouterr()
        split_file = users_dataset / f"split_info_{split}.json"
        assert main(["score", "--questions", str(users_dataset / "dataset_minimal.json"), "--predictions",
                     str(preds), "--split", str(split_file), "--json"]) == 0
        cli = json.loads(capsys.readouterr().out)
        direct = score(questions, preds, split=read_split(split_file, "test"))
        for group, metric in METRIC_OF_GROUP.items():
            ours = aggregate(items[metric], group)
            assert ours == getattr(utils, f"aggregate_{metric}")(items[metric]) or math.isnan(ours)
            if group in (*FAMILIES, "All"):
                expected = cli["columns"][group]["accuracy"]
                assert direct.columns[group].accuracy == expected
            else:
                expected = cli["per_category"].get(group, {}).get("accuracy")
            if expected is None:
                assert math.isnan(ours), (part, group)
            else:
                assert ours == expected, (part, group, seed)


def test_export_refuses_what_it_cannot_do(tmp_path: Path, users_dataset: Path) -> None:
    with pytest.raises(CraftError, match="no such dataset folder"):
        export_lmms_eval(tmp_path / "none", tmp_path / "out")
    with pytest.raises(CraftError, match="letters, digits and underscores"):
        export_lmms_eval(users_dataset, tmp_path / "out", name="craft-1")
    with pytest.raises(CraftError, match="unknown group"):
        aggregate([], "D/X")
    assert math.isnan(aggregate([], "All"))
    unread = [{"video_index": 0, "question_index": 1, "template_id": "descriptive_1", "answer": "1",
               "prediction": None}]
    assert aggregate(unread, "All") == aggregate(unread, "D/2Q") == 0.0 and math.isnan(aggregate(unread, "C"))


def test_the_command_writes_the_folder(tmp_path: Path, users_dataset: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "t"
    assert main(["export", "lmms-eval", str(users_dataset), "--out", str(out), "--fps", "5", "--name", "mycraft"]) == 0
    err = capsys.readouterr().err
    assert "group mycraft, tasks mycraft_easy" in err and "mycraft_hard" in err
    config = json.loads((out / "craft_task.json").read_text())
    assert config["visual"] == {"visual": "frames", "frames": 8, "fps": 5.0}
    assert config["dataset_root"] == str(users_dataset.resolve())
    with pytest.raises(SystemExit) as info:
        main(["export", "lmms-eval", str(users_dataset), "--out", str(out), "--frames", "0"])
    assert info.value.code == 2 and "--frames: give at least 1, not 0" in capsys.readouterr().err


# -- lmms-eval itself (installed apart: docs/evaluate.md) --------------------------------------------------------



def _lmms_eval_missing() -> str | None:
    if importlib.util.find_spec("lmms_eval") is None:
        return "lmms-eval is not installed (pip install lmms-eval; see docs/evaluate.md)"
    return None


@pytest.mark.skipif(_lmms_eval_missing() is not None, reason=str(_lmms_eval_missing()))
def test_lmms_eval_task_manager_loads_the_tasks_from_local_files(task_folder: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    from lmms_eval.tasks import TaskManager, get_task_dict

    manager = TaskManager("WARNING", include_path=str(task_folder))
    assert {"craft", "craft_easy", "craft_hard"} <= set(manager.all_tasks)
    tasks = get_task_dict(["craft_easy", "craft_hard"], manager)
    for part in PARTS:
        task = tasks[f"craft_{part}"]
        docs = list(task.test_docs())
        assert [dict(d) for d in docs] == _docs(task_folder, part)
        assert "whole number" in task.doc_to_text(next(d for d in docs if d["answer_kind"] == "count"))
        frames = task.doc_to_visual(docs[0])  # the task's own kwargs: 4 frames, as exported
        assert len(frames) == 4 and all(f.size == (256, 256) for f in frames)


@pytest.mark.skipif(_lmms_eval_missing() is not None, reason=str(_lmms_eval_missing()))
def test_an_lmms_eval_run_reports_craft_dsl_scores(task_folder: Path, users_dataset: Path, tmp_path: Path) -> None:
    """lmms-eval's dummy model answers "0" to everything (after asking each question's frames); every accuracy it
    reports equals craft-dsl score's."""
    env = {**os.environ, "HF_DATASETS_OFFLINE": "1", "HF_HUB_OFFLINE": "1"}
    res = subprocess.run([sys.executable, "-m", "lmms_eval", "--model", "dummy", "--model_args",
                          "response=0,read_bytes=1", "--tasks", "craft", "--include_path", str(task_folder),
                          "--output_path", str(tmp_path)],
                         capture_output=True, text=True, env=env, timeout=600, check=False)
    assert res.returncode == 0, res.stderr[-3000:]
    results = json.loads(next(tmp_path.rglob("*_results.json")).read_text())["results"]
    questions = read_questions(users_dataset / "dataset_minimal.json")
    for part, split in PARTS.items():
        preds = {(d["video_index"], d["question_index"]): "0" for d in _docs(task_folder, part)
                 if d["answer_kind"] == "count"}
        report = score(questions, preds, split=read_split(users_dataset / f"split_info_{split}.json", "test"))
        got = results[f"craft_{part}"]
        assert got["accuracy,none"] == report.columns["All"].accuracy
        for c, s in report.per_category.items():
            assert got[f"{METRIC_OF_GROUP[c]},none"] == s.accuracy
