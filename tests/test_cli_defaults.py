"""Defaults that fit the machine, messages that name the missing extra's ``pip install``, tables that never cut a
label (the command-line conventions of docs/architecture.md)."""

from __future__ import annotations

import json
import os
import pickle
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from craft_dsl.cli import build_parser, main
from craft_dsl.errors import CraftError, MissingExtraError
from craft_dsl.parallel import usable_cpu_count

ROOT = Path(__file__).resolve().parents[1]


def _help(capsys: pytest.CaptureFixture[str], *command: str) -> str:
    with pytest.raises(SystemExit):
        main([*command, "--help"])
    return " ".join(capsys.readouterr().out.split())  # argparse wraps the help: compare with single spaces


# -- --workers: the usable CPU cores ----------------------------------------------------------------------------


def test_usable_cpu_count_prefers_the_process_count_then_the_affinity_then_the_machine(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "process_cpu_count", lambda: 3, raising=False)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    assert usable_cpu_count() == 3
    monkeypatch.delattr(os, "process_cpu_count")
    assert usable_cpu_count() == 2
    monkeypatch.delattr(os, "sched_getaffinity")
    monkeypatch.setattr(os, "cpu_count", lambda: 5)
    assert usable_cpu_count() == 5
    monkeypatch.setattr(os, "cpu_count", lambda: None)  # unknown: one
    assert usable_cpu_count() == 1


@pytest.mark.parametrize("command", [("generate",), ("read",), ("engines", "compare")])
def test_workers_default_to_the_usable_cores_and_help_says_how_many(command: tuple[str, ...],
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    n = usable_cpu_count()
    assert f"(default: the usable CPU cores, {n} here)" in _help(capsys, *command)
    required = {"generate": ["--size", "1", "--out", "x"], "read": ["--videos", "v", "--questions", "q", "--out", "o"],
                "engines": []}[command[0]]
    assert build_parser().parse_args([*command, *required]).workers == n
    with pytest.raises(SystemExit) as info:
        build_parser().parse_args([*command, *required, "--workers", "0"])
    assert info.value.code == 2 and "--workers: give at least 1, not 0" in capsys.readouterr().err


def test_media_go_in_a_thread_only_when_a_core_is_left_over(monkeypatch: pytest.MonkeyPatch) -> None:
    from craft_dsl.dataset import executors

    default = build_parser().parse_args(["generate", "--size", "1", "--out", "x"]).workers
    assert not executors.make_executor("local", default).spare_cores  # every core has a worker: media inline
    monkeypatch.setattr(executors, "usable_cpu_count", lambda: 4)  # e.g. 4 cores of a 64-core machine's affinity
    assert not executors.LocalExecutor(4).spare_cores
    assert executors.LocalExecutor(3).spare_cores


def test_read_writes_the_same_bytes_for_any_number_of_workers(users_dataset: Path, tmp_path: Path) -> None:
    videos = sorted((users_dataset / "videos").rglob("*.mpg"))[:2]
    keep = {int(v.stem) for v in videos}
    records = json.loads((users_dataset / "dataset_minimal.json").read_text())
    questions = tmp_path / "questions.json"
    questions.write_text(json.dumps([{k: r[k] for k in ("video_index", "question_index", "question")}
                                     for r in records if r["video_index"] in keep]))
    outputs = []
    for workers in ("1", "4"):  # 4: more workers than videos (2 processes)
        out = tmp_path / f"w{workers}"
        assert main(["read", "--steps", "200", "--videos", str(users_dataset / "videos"), "--questions", str(questions),
                     "--out", str(out / "preds.json"), "--details", str(out / "details.jsonl"),
                     "--perceived", str(out / "perceived"), "--workers", workers, "--quiet"]) == 0
        outputs.append({p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()})
    assert len(outputs[0]) == 2 + len(keep)
    assert outputs[0] == outputs[1]


def test_jobs_still_works_with_a_warning(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["engines", "compare", "--scenes", "3", "--seeds", "1", "--steps", "30", "--engines",
                 "pymunk,pymunk", "--jobs", "1", "--quiet"]) == 0
    assert capsys.readouterr().err.startswith("warning: --jobs is deprecated; use --workers\n")


# -- a missing optional library: the message names the pip install that adds it ----------------------------------


@pytest.fixture
def dataset_copy(users_dataset: Path, tmp_path: Path) -> Path:
    folder = tmp_path / "copy"
    shutil.copytree(users_dataset, folder, ignore=shutil.ignore_patterns("videos", "*_frames", "intermediates"))
    return folder


def test_hf_without_pyarrow_writes_jsonl_and_says_which_pip_install_adds_parquet(
        dataset_copy: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    assert main(["hf", str(dataset_copy)]) == 0
    err = capsys.readouterr().err
    assert "JSONL only: no pyarrow; pip install 'craft-dsl[hf]' adds Parquet" in err, err
    assert not list((dataset_copy / "hf").rglob("*.parquet"))
    assert main(["hf", str(dataset_copy), "--parquet"]) == 2
    assert capsys.readouterr().err == ("error: writing Parquet files needs pyarrow, which is not installed: "
                                       "pip install 'craft-dsl[hf]' (or write JSONL only: --no-parquet)\n")
    assert main(["hf", str(dataset_copy), "--no-parquet"]) == 0
    assert "(JSONL only, as asked)" in capsys.readouterr().err


def test_stats_without_matplotlib_names_the_pip_install(dataset_copy: Path, tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    assert main(["stats", str(dataset_copy), "--out", str(tmp_path / "stats")]) == 2
    assert capsys.readouterr().err == ("error: drawing the charts needs matplotlib, which is not installed: "
                                       "pip install 'craft-dsl[stats]' (or write the CSV tables only: --no-charts)\n")
    assert main(["stats", str(dataset_copy), "--out", str(tmp_path / "stats"), "--no-charts"]) == 0


def test_generate_with_dask_without_dask_names_the_pip_install(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)
    assert main(["generate", "--size", "1", "--out", str(tmp_path / "out"), "--executor", "dask",
                 "--scheduler", "tcp://127.0.0.1:1", "--quiet"]) == 2
    assert capsys.readouterr().err == ("error: --executor dask needs Dask's distributed scheduler, which is not "
                                       "installed: pip install 'craft-dsl[dask]'\n")


@pytest.fixture
def without_box2d(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "Box2D", None)
    monkeypatch.delitem(sys.modules, "craft_dsl.physics.box2d_engine", raising=False)


BOX2D_MISSING = "error: the box2d engine needs pybox2d, which is not installed: pip install 'craft-dsl[box2d]'\n"


@pytest.mark.usefixtures("without_box2d")
@pytest.mark.parametrize("argv", [
    ["generate", "--size", "1", "--engine", "box2d", "--quiet"],  # one line, not one failure per video
    ["engines", "compare", "--scenes", "3", "--seeds", "2", "--steps", "30", "--quiet"],  # before any worker starts
    ["render", "--scene", "1", "--engine", "box2d", "--steps", "2", "--frame", "1"],
    ["run", "Count(SceneAtStart())", "--scene", "1", "--engine", "box2d"],
    ["scenes", "stats", "--scenes", "1", "--seeds", "1", "--steps", "2", "--engine", "box2d"],
])
def test_box2d_commands_without_pybox2d_name_the_pip_install(argv: list[str], tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = ["--out", str(tmp_path / ("f.png" if argv[0] == "render" else "out"))] if argv[0] in ("generate",
                                                                                                "render") else []
    assert main([*argv, *out]) == 2
    assert capsys.readouterr().err == BOX2D_MISSING
    assert not (tmp_path / "out").exists()


def test_torch_without_pytorch_names_the_pip_install() -> None:
    code = "import sys; sys.modules['torch'] = None; import craft_dsl.torch"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 1
    assert res.stderr.strip().splitlines()[-1] == ("craft_dsl.errors.MissingExtraError: craft_dsl.torch needs "
                                                   "PyTorch, which is not installed: pip install 'craft-dsl[torch]'")


def test_a_missing_extra_error_crosses_process_boundaries() -> None:
    err = MissingExtraError("drawing the charts", "stats", "matplotlib", "or use --no-charts")
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is MissingExtraError and str(back) == str(err) and back.extra == "stats"
    assert isinstance(back, CraftError) and isinstance(back, ModuleNotFoundError)


def test_every_pip_install_in_the_package_names_a_real_extra() -> None:
    tomllib = pytest.importorskip("tomllib")
    extras = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"])
    named: set[str] = set()
    for path in (ROOT / "craft_dsl").rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        named.update(re.findall(r"craft-dsl\[(\w+)\]", text))
        named.update(re.findall(r"MissingExtraError\(\s*\"[^\"]*\",\s*\"(\w+)\"", text))
    assert named and named <= extras, named - extras


# -- tables: a label is never cut ------------------------------------------------------------------------------


def _columns_end_together(lines: list[str]) -> None:
    """Right-aligned number columns: every row of the table ends where its header ends."""
    assert len({len(line) for line in lines}) == 1, "\n".join(lines)


def test_score_compare_paper_shows_the_whole_predictions_file_name(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["verify-fixture", "--out", str(tmp_path), "--sim", "3:2"]) == 0
    records = json.loads((tmp_path / "dataset_minimal.json").read_text())
    preds = tmp_path / "preds_origin_reader_format3_heldout_seed20261124.json"
    preds.write_text(json.dumps({f"{r['video_index']}_{r['question_index']}": r["answer"] for r in records}))
    capsys.readouterr()
    assert main(["score", "--questions", str(tmp_path / "dataset_minimal.json"), "--predictions", str(preds),
                 "--compare-paper", "easy"]) == 0
    out = capsys.readouterr().out
    table = out[out.index("CRAFT paper"):].splitlines()[1:]
    assert table[-1].split()[:3] == ["this", "run", preds.stem]
    _columns_end_together(table)


def test_the_paper_table_keeps_its_layout_for_short_labels() -> None:
    from craft_dsl.verify.scoring import paper_table

    lines = paper_table("hard").splitlines()
    assert lines[1].startswith("group         model          ") and lines[-1].startswith("humans        (481 q.)")


def test_baselines_table_widens_to_a_long_baseline_name() -> None:
    from craft_dsl.dataset.stats import COLUMNS, Table, format_baselines

    row = ("random", "a-much-longer-baseline-name", *(50.0,) * len(COLUMNS), 10, *(40.0,) * len(COLUMNS))
    text = format_baselines(Table("baselines", "t", ("split", "baseline"), [row]))
    lines = text.splitlines()
    assert lines[-1].split()[:2] == ["random", "a-much-longer-baseline-name"]
    cell, head = "50.0 / 40.0", "ours / paper"
    assert lines[-1].index(cell) + len(cell) == lines[1].index(head) + len(head)  # the columns moved together
    assert lines[0].index("  test questions") == lines[1].rindex(head) + len(head)
