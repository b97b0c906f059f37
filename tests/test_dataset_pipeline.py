"""The dataset-level generation pipeline (craft_dsl.dataset.pipeline): stages on synthetic records, the writers
against craft_dsl.verify's readers, and small end-to-end runs (verify passes, workers 1 vs 2 identical, resume)."""

from __future__ import annotations

import hashlib
import json
import os
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

import craft_dsl.dataset.questions  # noqa: F401 - the end-to-end runs need it; a broken import fails, never skips
from craft_dsl.cli import main as cli_main
from craft_dsl.dataset import pipeline as P
from craft_dsl.dataset.instance import InstanceResult, InstanceTask
from craft_dsl.errors import CraftError
from craft_dsl.templates import DROPPED, templates
from craft_dsl.verify import (
    open_annotations,
    parse_dataset,
    parse_minimal,
    parse_split,
    read_dataset,
    read_minimal,
    read_split,
    verify_dataset,
)

# -- synthetic records ----------------------------------------------------------------------------------------


def rec(video: int, qi: int, tid: str, answer: Any, text: str = "What?") -> dict[str, Any]:
    family, index = tid.rsplit("_", 1)
    path = f"./videos/sid_1/{video:06d}.mpg"
    return {"video_filename": path, "video_index": video, "video": f"{video:06d}", "question": text,
            "program": [{"type": "scene", "inputs": [], "value_inputs": [], "_output": []}], "answer": answer,
            "template_filename": f"{family}.json", "question_family_index": int(index), "question_index": qi,
            "template_id": tid}


def group(tid: str, answers: list[Any], start_video: int = 0) -> list[dict[str, Any]]:
    """One question of template ``tid`` per video, videos start_video, start_video + 1, ..."""
    return [rec(start_video + k, 0, tid, a) for k, a in enumerate(answers)]


# -- configuration and work list ------------------------------------------------------------------------------


def test_config_defaults_and_errors() -> None:
    c = P.GenerationConfig.make(size=40)
    assert c.scenes == tuple(range(1, 21)) and c.steps == 600 and c.perturbations == 3 and c.amount == 0.02
    assert c.workers == 1 and c.videos is False and c.engine == "box2d" and len(c.templates) == 67
    for bad, field in (({"size": 0}, "size"), ({"size": 4, "scenes": (1, 21)}, "scenes"),
                       ({"size": 4, "scenes": ()}, "scenes"), ({"size": 4, "templates": ("cause_9",)}, "templates"),
                       ({"size": 4, "workers": 0}, "workers"), ({"size": 4, "colour": 1}, "colour")):
        with pytest.raises(CraftError, match=field):
            P.GenerationConfig.make(**bad)
    # template ids are kept in canonical order, so the same set gives the same configuration
    assert P.GenerationConfig.make(size=1, templates=("cause_1", "descriptive_0")).templates == (
        "descriptive_0", "cause_1")


def test_work_list_scene_blocks() -> None:
    work = P.work_list(P.GenerationConfig.make(size=40))
    assert [i for i, _ in work] == list(range(40))
    assert all(s == i // 2 + 1 for i, s in work)  # the original's sid = id // (size // 20) + 1
    work = P.work_list(P.GenerationConfig.make(size=7, scenes=(4, 9, 2)))
    assert work == [(0, 4), (1, 4), (2, 4), (3, 9), (4, 9), (5, 2), (6, 2)]  # remainder: first scenes get one more
    assert len(P.work_list(P.GenerationConfig.make(size=3, scenes=(1, 2, 3, 4, 5)))) == 3


def test_instance_seeds_depend_only_on_seed_and_id() -> None:
    a = P.instance_seeds(0, 5)
    assert a[0] == P.instance_seeds(0, 5)[0] and a[0] != P.instance_seeds(0, 6)[0] != P.instance_seeds(1, 5)[0]
    assert a[1].generate_state(2).tolist() == P.instance_seeds(0, 5)[1].generate_state(2).tolist()
    assert a[1].generate_state(2).tolist() != a[2].generate_state(2).tolist()


# -- post-process --------------------------------------------------------------------------------------


def test_post_process_rules() -> None:
    records = [
        rec(0, 0, "descriptive_24", "cube"),   # shape answer, video 0 has one dynamic shape -> dropped
        rec(1, 0, "descriptive_24", "cube"),   # video 1 has two shapes -> kept
        rec(0, 1, "descriptive_0", True, "Is there a hexagon?"),
        rec(0, 2, "cause_2", False),           # basket template
        rec(0, 3, "prevent_0", True, "Is the small red cube is prevented by the circle from entering?"),
        rec(0, 4, "prevent_3", True, "Is X is prevented by Y?"),  # not one of prevent_0/1/2: unchanged
        rec(0, 5, "descriptive_22", "red"),
    ]
    kept, dropped = P.post_process(records, {0: 1, 1: 2})
    assert [(r["video_index"], r["question_index"]) for r in kept] == [(1, 0), (0, 3), (0, 4), (0, 5)]
    assert dropped == Counter({"shape_single_shape": 1, "hexagon": 1, "basket_template": 1})
    assert kept[1]["question"] == "Is the small red cube prevented by the circle from entering?"
    assert kept[2]["question"] == "Is X is prevented by Y?"
    assert records[4]["question"].startswith("Is the small red cube is")  # inputs are not modified
    every = [rec(0, k, tid, False) for k, tid in enumerate(templates())]
    kept, dropped = P.post_process(every, {0: 3})
    assert len(DROPPED) == 19 and dropped["basket_template"] == 19 and len(kept) == 48
    assert not {P.template_id_of(r) for r in kept} & DROPPED


# -- balancing -----------------------------------------------------------------------------------------


def _scene_of(records: list[dict[str, Any]], scene: int = 1) -> dict[int, int]:
    return {r["video_index"]: scene for r in records}


def test_balance_purges_single_answer_groups() -> None:
    records = group("cause_0", [True] * 5) + group("descriptive_4", [4, 4, 4], start_video=10)
    kept, counts = P.balance(records, _scene_of(records), seed=0)
    assert kept == [] and counts["purged_single_answer"] == 8


def test_balance_equalises_answers_and_keeps_counts_3_to_10() -> None:
    answers = [True] * 7 + [False] * 3 + ["x"] * 0
    records = group("cause_0", answers)
    records += group("descriptive_4", [0, 0, 0, 0, 1, 1, 2, 2, 2, 3, 5, 10, 11, 11], start_video=100)
    kept, counts = P.balance(records, _scene_of(records), seed=7)
    by_template: dict[str, Counter[str]] = {}
    for r in kept:
        by_template.setdefault(r["template_id"], Counter())[str(r["answer"])] += 1
    assert by_template["cause_0"] == Counter({"True": 3, "False": 3})
    # 3, 5, 10 set aside and kept; 0, 1, 2 and 11 undersampled to the rarest (1 and 11: two each)
    assert by_template["descriptive_4"] == Counter({"0": 2, "1": 2, "2": 2, "11": 2, "3": 1, "5": 1, "10": 1})
    assert counts["undersampled"] == 4 + 2 + 1 and counts["purged_single_answer"] == 0
    # kept records keep their input order
    positions = [records.index(r) for r in kept]
    assert positions == sorted(positions)


def test_balance_groups_are_per_scene_and_template() -> None:
    a = group("cause_0", [True, True, False])
    b = group("cause_0", [True, True, True], start_video=10)  # same template, other scene: single answer
    scene_of = {**_scene_of(a, 1), **_scene_of(b, 2)}
    kept, counts = P.balance(a + b, scene_of, seed=0)
    assert len(kept) == 2 and {r["video_index"] for r in kept} <= {0, 1, 2} and counts["purged_single_answer"] == 3


def test_balance_only_outliers_plus_one_answer_keeps_group() -> None:
    records = group("descriptive_4", [0, 0, 0, 5, 6])
    kept, _ = P.balance(records, _scene_of(records), seed=0)
    assert len(kept) == 5


def test_balance_is_seeded_and_independent_of_other_groups() -> None:
    records = group("cause_0", [True] * 30 + [False] * 10)
    first, _ = P.balance(records, _scene_of(records), seed=3)
    again, _ = P.balance(records, _scene_of(records), seed=3)
    assert first == again
    others = [dict(r, video_index=r["video_index"] + 1000) for r in group("enable_1", [True] * 9 + [False] * 4)]
    scene_of = {**_scene_of(records), **_scene_of(others)}
    mixed, _ = P.balance(others + records, scene_of, seed=3)
    assert [r for r in mixed if r["template_id"] == "cause_0"] == first
    draws = {tuple(r["video_index"] for r in P.balance(records, _scene_of(records), seed=s)[0]) for s in range(6)}
    assert len(draws) > 1  # the seed matters


# -- splits --------------------------------------------------------------------------------------------


def test_hard_split_is_the_fixed_scene_split() -> None:
    records = [rec(s, 0, "cause_0", True) for s in range(1, 21)]
    split = P.hard_split(records, {s: s for s in range(1, 21)})
    assert {p: {k["video_index"] for k in split[p]} for p in split} == {
        "train": {1, 2, 3, 4, 5, 6, 7, 9, 10, 15, 19, 20}, "validation": {8, 12, 14, 16}, "test": {11, 13, 17, 18}}
    for a, b in ((1, 18), (3, 16), (4, 17)):  # the "similar scene" pairs never share a part
        assert not any({a, b} <= {k["video_index"] for k in split[p]} for p in split)


def test_random_split_by_whole_videos_60_20_20() -> None:
    records = [rec(v, q, "cause_0", True) for v in range(50) for q in range(3)]
    split = P.random_split(records, seed=0)
    assert split == P.random_split(records, seed=0) and split != P.random_split(records, seed=1)
    videos = {p: {k["video_index"] for k in split[p]} for p in split}
    assert (len(videos["train"]), len(videos["validation"]), len(videos["test"])) == (30, 10, 10)
    assert set().union(*videos.values()) == set(range(50)) and sum(len(v) for v in videos.values()) == 50
    assert sum(len(v) for v in split.values()) == 150  # every question in exactly one part
    assert all(len([k for k in split[p] if k["video_index"] == v]) == 3 for p in split for v in videos[p])
    small = P.random_split(records[:12], seed=0)  # 4 videos: int(0.2 * 4) = 0 -> all train, as the original
    assert len(small["train"]) == 12


# -- writers --------------------------------------------------------------------------------------------------


def test_writers_are_read_by_verify(tmp_path: Path) -> None:
    records = [rec(3, 1, "descriptive_22", "red"), rec(3, 0, "cause_0", True), rec(1, 4, "descriptive_4", 2)]
    scene_of = {1: 2, 3: 7}
    dataset = P.dataset_videos(records, scene_of)
    assert [v["questions"]["info"]["video_index"] for v in dataset] == [1, 3]
    assert dataset[1]["simulation_id"] == "7" and dataset[1]["video_path"] == "./videos/sid_7/000003.mpg"
    assert [q["question_index"] for q in dataset[1]["questions"]["questions"]] == [0, 1]
    questions = parse_dataset(json.loads(json.dumps(dataset)))
    assert {(q.video_index, q.question_index, q.answer) for q in questions} == {(1, 4, 2), (3, 0, True),
                                                                                (3, 1, "red")}
    from craft_dsl.verify import minimal_records

    minimal = parse_minimal(json.loads(json.dumps(minimal_records(dataset))))
    assert {q.answer for q in minimal} == {"2", "True", "Red"}
    split = P.random_split(records, seed=0)
    assert parse_split(json.loads(json.dumps(split)), "train") == {(1, 4), (3, 0), (3, 1)}


# -- end to end (part A, craft_dsl.dataset.questions, imported above) -------------------------------------------

SMALL = {"size": 4, "seed": 0, "scenes": (1, 2), "steps": 300, "perturbations": 1}


def hashes(folder: Path) -> dict[str, str]:
    """Every file's hash, the log (which holds times) left out."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != P.LOG_FILE}


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    out = tmp_path_factory.mktemp("reference")
    report = P.generate_dataset(P.GenerationConfig.make(**SMALL), out)
    return out, report


def test_end_to_end_files_and_verify(reference: tuple[Path, dict[str, Any]]) -> None:
    out, report = reference
    for name in ("dataset.json", "dataset_minimal.json", "split_info_hard.json", "split_info_random.json",
                 "annotations.json", "videos_with_no_questions.json", "generation_report.json",
                 "imbalanced_dataset.json", "balanced_dataset.json"):
        assert (out / name).is_file(), name
    questions = read_dataset(out / "dataset.json")
    with_questions = {q.video_index for q in questions}
    for i, scene in ((0, 1), (1, 1), (2, 2), (3, 2)):
        # every simulation is stored once: in annotations.json if the video has questions, else in intermediates/
        assert (out / "intermediates" / f"sid_{scene}" / f"{i:06d}.json").is_file() == (i not in with_questions)
        qa = json.loads((out / "questions" / f"qa_{i:06d}.json").read_text())
        assert set(qa) == {"info", "stats"} and qa["stats"]["scene"] == scene
    assert set(json.loads((out / "annotations.json").read_text())) == {f"{i:06d}" for i in with_questions}
    assert json.loads((out / "videos_with_no_questions.json").read_text()) == sorted({0, 1, 2, 3} - with_questions)
    assert not (out / ".generate").exists() and not [p for p in out.rglob("*") if ".tmp" in p.name]
    assert "done: 4 videos computed" in (out / P.LOG_FILE).read_text()
    minimal = read_minimal(out / "dataset_minimal.json")
    assert questions and [q.key for q in questions] == [q.key for q in minimal]
    assert not {q.template_id for q in questions} & DROPPED
    assert all(isinstance(q.answer, (bool, int, str)) for q in questions)
    keys = {q.key for q in questions}
    for name in ("split_info_hard.json", "split_info_random.json"):
        parts = [read_split(out / name, p) for p in P.SPLIT_PARTS]
        assert set().union(*parts) == keys and sum(map(len, parts)) == len(keys)
    verdict = verify_dataset(questions, open_annotations(out / "annotations.json"))
    assert verdict.ok, verdict.format()
    assert cli_main(["verify", "--dataset", str(out / "dataset.json"),
                     "--annotations", str(out / "annotations.json")]) == 0
    q = report["questions"]
    assert q["final"] == len(questions)
    assert q["generated"] - q["dropped_by_perturbation"] == q["after_perturbation"]
    assert q["after_perturbation"] - sum(q["dropped_by_post_process"].values()) == q["after_post_process"]
    assert q["after_post_process"] - sum(q["dropped_by_balancing"].values()) == q["final"]
    saved = json.loads((out / "generation_report.json").read_text())
    assert saved["questions"] == q and sum(t["final"] for t in saved["per_template"].values()) == q["final"]


def test_workers_give_byte_identical_output(reference: tuple[Path, dict[str, Any]], tmp_path: Path) -> None:
    out, _ = reference
    P.generate_dataset(P.GenerationConfig.make(**SMALL, workers=2), tmp_path)
    assert hashes(tmp_path) == hashes(out)


def test_resume_after_interruption(reference: tuple[Path, dict[str, Any]], tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    from craft_dsl.dataset import executors

    out, _ = reference
    real = executors.run_instance
    calls: list[int] = []
    crash = [2]

    def failing(task: InstanceTask) -> InstanceResult:
        calls.append(task.instance_id)
        if task.instance_id in crash:
            raise RuntimeError("simulated crash")
        return real(task)

    monkeypatch.setattr(executors, "run_instance", failing)
    config = P.GenerationConfig.make(**SMALL)
    with pytest.raises(CraftError, match=r"1 of 4 instances failed \(000002: RuntimeError: simulated crash\)"):
        P.generate_dataset(config, tmp_path)
    assert calls == [0, 1, 2, 3]
    # scene 1 (videos 0, 1) is merged; video 3's shard waits for video 2
    assert (tmp_path / "questions" / "qa_000001.json").is_file()
    assert not (tmp_path / "questions" / "qa_000003.json").exists()
    assert (tmp_path / ".generate" / "shards" / "000003.shard").is_file()
    assert not (tmp_path / "dataset.json").exists()
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]  # no half-written file anywhere
    # bytes a killed merge appended after its last commit are dropped (the growing files go back to the journal)
    for partial in (tmp_path / ".generate").glob("*.partial"):
        with partial.open("a") as fh:
            fh.write(', {"half": "written')
    # a truncated shard (as a crash of a non-atomic writer would leave) is not taken as done
    shard = tmp_path / ".generate" / "shards" / "000003.shard"
    shard.write_bytes(shard.read_bytes()[:100])
    calls.clear()
    crash.clear()
    report = P.generate_dataset(config, tmp_path)
    assert sorted(calls) == [2, 3] and report["resumed"] == 2
    assert hashes(tmp_path) == hashes(out)
    calls.clear()
    P.generate_dataset(config, tmp_path)
    assert calls == []


def test_other_configuration_in_folder_is_refused(reference: tuple[Path, dict[str, Any]]) -> None:
    out, _ = reference
    with pytest.raises(CraftError, match="seed 0 here, 1 now"):
        P.generate_dataset(P.GenerationConfig.make(**dict(SMALL, seed=1)), out)
    with pytest.raises(CraftError, match=r"balance True here, False now; videos False here, True now.*--force"):
        P.generate_dataset(P.GenerationConfig.make(**dict(SMALL, balance=False, videos=True)), out)


def test_cli_generate(reference: tuple[Path, dict[str, Any]], capsys: pytest.CaptureFixture[str]) -> None:
    out, _ = reference
    before = hashes(out)
    # temporary files a killed run leaves (atomic writes interrupted) are removed by the next run
    (out / ".dataset.k3j2.tmp.json").write_text("[")
    (out / "questions" / ".qa_000001.x8.tmp.json").write_text("{")
    argv = ["generate", "--size", "4", "--seed", "0", "--scenes", "1-2", "--steps", "300", "--perturbations", "1",
            "--out", str(out), "--workers", "2"]
    assert cli_main(argv) == 0  # everything already done: resumes, rewrites the same bytes
    text = capsys.readouterr()
    assert "4 videos" in text.out and "craft-dsl verify --dataset" in text.out and "resuming" in text.err
    assert hashes(out) == before
    assert "removed 2 temporary files of an interrupted run" in (out / P.LOG_FILE).read_text()
    assert cli_main(["generate", "--size", "0", "--out", str(out)]) == 2
    assert cli_main(["generate", "--size", "4", "--scenes", "1,x", "--out", str(out)]) == 2
    assert "error:" in capsys.readouterr().err


def test_no_balance_keeps_every_filtered_question(tmp_path: Path) -> None:
    from craft_dsl.cli import main as cli_main

    out = tmp_path / "nb"
    assert cli_main(["generate", "--size", "2", "--scenes", "3,4", "--steps", "200", "--perturbations", "0",
                     "--no-balance", "--out", str(out), "--quiet"]) == 0
    report = json.loads((out / "generation_report.json").read_text())
    q = report["questions"]
    assert q["final"] == q["after_post_process"] > 0
    assert not any(q["dropped_by_balancing"].values())


def test_media_in_a_thread_or_inline_are_the_same_bytes() -> None:
    from dataclasses import replace

    from craft_dsl.dataset.instance import run_instance

    config = P.GenerationConfig.make(size=1, scenes=(7,), steps=120, perturbations=1)
    task = P.instance_task(config, 0, 7, questions=True, media=True, media_thread=True)
    threaded = run_instance(task)
    inline = run_instance(replace(task, media_thread=False))
    assert threaded == inline
    assert [path for path, _ in inline.media] == ["videos/sid_7/000000.mpg", "first_frames/sid_7/000000.png",
                                                  "last_frames/sid_7/000000.png"]
    assert inline.shard is not None and all(data for _, data in inline.media)


def test_local_workers_use_a_media_thread_only_with_a_spare_core(monkeypatch: pytest.MonkeyPatch) -> None:
    from craft_dsl.dataset import executors

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    assert executors.LocalExecutor(1).spare_cores
    assert not executors.LocalExecutor(2).spare_cores
    assert not executors.LocalExecutor(3).spare_cores
