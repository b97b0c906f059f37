"""Hugging Face files of a dataset folder: rows, JSONL/Parquet per split, the card, and loading with `datasets`."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from craft_dsl.cli import main
from craft_dsl.dataset import hf
from craft_dsl.dataset.folder import DatasetFolder
from craft_dsl.errors import CraftError
from craft_dsl.program import Program


def jsonl(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_rows_hold_every_question_with_its_program(users_dataset: Path) -> None:
    folder = DatasetFolder(users_dataset)
    rows = hf.rows(folder)
    minimal = json.loads((users_dataset / "dataset_minimal.json").read_text())
    assert [(r["video_index"], r["question_index"]) for r in rows] == [
        (m["video_index"], m["question_index"]) for m in minimal]
    assert [name for name, _ in hf.FEATURES] == list(rows[0])
    full = {(q["video_index"], q["question_index"]): q for v in json.loads((users_dataset / "dataset.json")
                                                                           .read_text()) for q in
            v["questions"]["questions"]}
    for row, m in zip(rows, minimal, strict=True):
        assert row["answer"] == m["answer"] and row["template_id"] == m["template_id"]
        assert row["video_file_path"] == m["video_file_path"]
        assert row["first_frame_path"] == m["video_file_path"].replace("videos", "first_frames").replace("mpg", "png")
        nodes = full[(row["video_index"], row["question_index"])]["program"]
        assert row["program"] == str(Program.from_nodes(nodes))
        assert [n["type"] for n in row["program_nodes"]] == [n["type"] for n in nodes]
        assert Program.from_nodes(row["program_nodes"]) == Program.from_nodes(nodes)
    assert {r["category"] for r in rows} <= {"D/2Q", "D/N-V", "D/N-T", "D/C", "D/S", "D/C-T", "D/TO", "CF/O", "CF/N",
                                              "C/A", "C/N"}


def test_split_files_partition_the_questions(users_dataset: Path) -> None:
    for split in ("random", "hard"):
        info = json.loads((users_dataset / f"split_info_{split}.json").read_text())
        for part in ("train", "validation", "test"):
            lines = jsonl(users_dataset / "hf" / split / f"{part}.jsonl")
            assert {(r["video_index"], r["question_index"]) for r in lines} == {
                (k["video_index"], k["question_index"]) for k in info[part]}
    hard_test = jsonl(users_dataset / "hf" / "hard" / "test.jsonl")
    assert hard_test and {r["simulation_id"] for r in hard_test} == {"11"}  # the held-out scene


def test_card_front_matter(users_dataset: Path) -> None:
    card = (users_dataset / "README.md").read_text()
    assert card.startswith("---\n")
    front = card.split("---\n")[1]
    assert "configs:\n- config_name: random\n  default: true\n  data_files:\n  - split: train\n" in front
    extension = "parquet" if hf._have_pyarrow() else "jsonl"  # Parquet when the hf extra is installed
    assert f"    path: hf/hard/test.{extension}\n" in front
    assert "  - name: program_nodes\n    list:\n    - name: type\n      dtype: string\n" in front
    assert "## Heuristic baselines" in card and "| random | AT-MFA |" in card and "/ 42.0 |" in card
    assert '"video_format"' not in card or "`\"mpg\"`" in card
    yaml = pytest.importorskip("yaml", reason="parsing the card's YAML needs PyYAML (installed with the hf extra)")
    meta = yaml.safe_load(front)
    assert [c["config_name"] for c in meta["configs"]] == ["random", "hard"]
    assert [f["name"] for f in meta["dataset_info"][0]["features"]] == [n for n, _ in hf.FEATURES]


def test_parquet_has_the_jsonl_rows(users_dataset: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet",
                             reason="Parquet needs pyarrow, the hf extra: pip install 'craft-dsl[hf]'")
    for part in ("train", "test"):
        table = pq.read_table(users_dataset / "hf" / "random" / f"{part}.parquet")
        assert table.to_pylist() == jsonl(users_dataset / "hf" / "random" / f"{part}.jsonl")
        assert str(table.schema.field("program_nodes").type) == (
            "list<element: struct<type: string, inputs: list<element: int64>, value_inputs: list<element: string>>>")


def load(folder: Path, config: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    datasets = pytest.importorskip("datasets",
                                   reason="loading needs the datasets library: pip install 'craft-dsl[integration]'")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    return datasets.load_dataset(str(folder), config, cache_dir=str(tmp_path / "cache"))


def test_datasets_loads_both_configs_offline(users_dataset: Path, tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    for config in ("random", "hard"):
        ds = load(users_dataset, config, tmp_path, monkeypatch)
        assert set(ds) == {"train", "validation", "test"}
        for part in ds:
            assert ds[part].to_list() == jsonl(users_dataset / "hf" / config / f"{part}.jsonl")
        features = ds["train"].features
        assert str(features["video_index"].dtype) == "int64" and str(features["answer"].dtype) == "string"
        assert set(features["program_nodes"].feature) == {"type", "inputs", "value_inputs"}


def test_jsonl_only_card_loads_with_the_same_features(users_dataset: Path, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "copy"
    shutil.copytree(users_dataset, folder, ignore=shutil.ignore_patterns("videos", "*_frames", "intermediates"))
    result = hf.write_hf(folder, parquet=False)
    assert not result.parquet and not list((folder / "hf").rglob("*.parquet"))
    assert "path: hf/random/train.jsonl" in (folder / "README.md").read_text()
    jsonl_ds = load(folder, "random", tmp_path, monkeypatch)
    parquet_ds = load(users_dataset, "random", tmp_path / "p", monkeypatch)
    assert jsonl_ds["train"].features == parquet_ds["train"].features
    assert jsonl_ds["train"].to_list() == parquet_ds["train"].to_list()


def test_missing_pyarrow_is_a_clear_error(tmp_path: Path, users_dataset: Path, monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "copy"
    shutil.copytree(users_dataset, folder, ignore=shutil.ignore_patterns("videos", "*_frames", "intermediates"))
    monkeypatch.setattr(hf, "_have_pyarrow", lambda: False)
    with pytest.raises(CraftError, match=r"pip install 'craft-dsl\[hf\]'"):
        hf.write_hf(folder, parquet=True)
    assert main(["hf", str(folder), "--parquet"]) == 2
    assert main(["hf", str(folder)]) == 0  # default: JSONL when pyarrow is missing, and says so
    captured = capsys.readouterr()
    assert "random: train" in captured.out and "JSONL only: no pyarrow" in captured.err
    assert main(["hf", str(tmp_path / "nowhere")]) == 2
    assert "no such dataset folder" in capsys.readouterr().err


def test_hf_command_in_a_subprocess(users_dataset: Path, tmp_path: Path) -> None:
    folder = tmp_path / "copy"
    shutil.copytree(users_dataset, folder, ignore=shutil.ignore_patterns("videos", "*_frames", "intermediates", "hf",
                                                                         "README.md"))
    done = subprocess.run([sys.executable, "-m", "craft_dsl.cli", "hf", str(folder), "--no-parquet", "--json"],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["parquet"] is False and "README.md" in report["files"]
    assert sum(report["counts"]["random"].values()) == len(json.loads((folder / "dataset_minimal.json").read_text()))
    assert (folder / "hf" / "hard" / "validation.jsonl").read_text() == (
        users_dataset / "hf" / "hard" / "validation.jsonl").read_text()


def test_empty_parts_are_left_out(users_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "copy"
    shutil.copytree(users_dataset, folder, ignore=shutil.ignore_patterns("videos", "*_frames", "intermediates"))
    split = json.loads((folder / "split_info_hard.json").read_text())
    everything = split["train"] + split["validation"] + split["test"]
    (folder / "split_info_hard.json").write_text(json.dumps({"train": everything, "validation": [], "test": []}))
    result = hf.write_hf(folder)
    assert result.counts["hard"] == {"train": len(everything), "validation": 0, "test": 0}
    assert not list((folder / "hf" / "hard").glob("test.*")) and not list((folder / "hf" / "hard").glob("validation.*"))
    card = (folder / "README.md").read_text()
    assert "hf/hard/validation" not in card and "Parts without questions (hard/validation, hard/test)" in card
    ds = load(folder, "hard", tmp_path, monkeypatch)
    assert set(ds) == {"train"} and len(ds["train"]) == len(everything)
