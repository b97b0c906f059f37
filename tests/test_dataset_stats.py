"""Dataset statistics: tables, the paper's heuristic baselines (hand-computed cases), charts and the command."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from craft_dsl.cli import main
from craft_dsl.dataset import stats as S
from craft_dsl.dataset.folder import DatasetFolder


def rec(vi: int, qi: int, tid: str, answer: str, kind: str) -> dict[str, Any]:
    family = {"descriptive": "D", "counterfactual": "CF"}.get(tid.rsplit("_", 1)[0], "C")
    return {"video_index": vi, "question_index": qi, "template_id": tid, "answer": answer, "answer_type": kind,
            "family": family, "category": "D/2Q", "question_type": tid.split("_")[0].capitalize(),
            "simulation_id": "1"}


def test_baselines_by_hand() -> None:
    train = [rec(0, 0, "descriptive_0", "2", "Count"), rec(0, 1, "descriptive_0", "2", "Count"),
             rec(0, 2, "descriptive_1", "1", "Count"), rec(0, 3, "cause_0", "True", "Boolean"),
             rec(0, 4, "cause_0", "False", "Boolean"), rec(0, 5, "cause_1", "False", "Boolean"),
             rec(0, 6, "descriptive_22", "Red", "Color")]
    test = [rec(1, 0, "descriptive_0", "2", "Count"), rec(1, 1, "cause_0", "False", "Boolean"),
            rec(1, 2, "descriptive_22", "Blue", "Color"), rec(1, 3, "counterfactual_3", "7", "Count")]
    part_of = {**{(r["video_index"], r["question_index"]): "train" for r in train},
               **{(r["video_index"], r["question_index"]): "test" for r in test}}
    result = S.heuristic_baselines(train + test, part_of)
    # training answers: 2, 1, true, false, red -> 5; Count {2, 1}; Boolean {true, false}; Color {red}
    assert result["Random"]["All"] == pytest.approx((100 * (1 / 5 + 1 / 5 + 0 + 0) / 4, 4))
    assert result["AT-Random"]["All"][0] == pytest.approx(100 * (1 / 2 + 1 / 2 + 0 + 0) / 4)
    # MFA: "2" and "false" both appear twice; ties go to the first in sorted order ("2")
    assert result["MFA"]["All"][0] == pytest.approx(25.0)
    assert result["AT-MFA"]["All"][0] == pytest.approx(50.0)  # Count -> 2 (right), Boolean -> false (right)
    assert result["AT-MFA"]["C"] == (100.0, 1) and result["AT-MFA"]["CF"] == (0.0, 1)
    assert result["MFA"]["D"][1] == 2
    empty = S.heuristic_baselines(train, {k: "train" for k in part_of})
    assert empty["Random"]["All"] == (None, 0)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["0", "1", "2", "True", "False", "Red", "Cube"]),
                          st.sampled_from(["train", "test"])), min_size=1, max_size=40))
def test_baselines_are_percentages_and_at_mfa_dominates_mfa(items: list[tuple[str, str]]) -> None:
    kinds = {"0": "Count", "1": "Count", "2": "Count", "True": "Boolean", "False": "Boolean", "Red": "Color",
             "Cube": "Shape"}
    records = [rec(i, 0, "descriptive_0", a, kinds[a]) for i, (a, _) in enumerate(items)]
    part_of = {(i, 0): part for i, (_, part) in enumerate(items)}
    result = S.heuristic_baselines(records, part_of)
    n_test = sum(1 for _, p in items if p == "test")
    for name in S.BASELINES:
        acc, n = result[name]["All"]
        assert n == n_test
        assert (acc is None) == (n_test == 0)
        if acc is not None:
            assert 0.0 <= acc <= 100.0
    if n_test:
        # knowing the answer type never hurts: per type, the type's most frequent answer is at least as good
        assert result["AT-MFA"]["All"][0] >= result["MFA"]["All"][0] - 1e-9
        assert result["AT-Random"]["All"][0] >= result["Random"]["All"][0] - 1e-9


def test_tables_of_a_generated_dataset(users_dataset: Path) -> None:
    folder = DatasetFolder(users_dataset)
    records = folder.records
    by_template = S.answers_per_template(records)
    assert sum(r[-1] for r in by_template.rows) == len(records)
    assert [r[0] for r in by_template.rows] == sorted((r[0] for r in by_template.rows), key=S.template_order)
    by_category = S.answers_per_category(records)
    assert sum(r[-1] for r in by_category.rows) == len(records)
    per_scene = S.question_types_per_scene(records)
    assert {r[0] for r in per_scene.rows} == {1, 8, 11} and sum(r[2] for r in per_scene.rows) == len(records)
    events = S.events_per_video(folder)
    assert [r[0] for r in events.rows] == sorted({r["video_index"] for r in records})
    sim = folder.annotations.simulation("000002")
    row = next(r for r in events.rows if r[0] == 2)
    assert row[2] == sum(1 for e in sim.events if e.type == "Collision") and row[-1] == sum(row[2:-1])
    objects = S.objects_per_scene(folder)
    assert [r[0] for r in objects.rows] == [1, 8, 11] and all(r[1] == 2 and r[2] <= r[3] <= r[4]
                                                              for r in objects.rows)
    baselines = S.baselines_table(folder)
    assert [(r[0], r[1]) for r in baselines.rows] == [(s, b) for s in ("random", "hard") for b in S.BASELINES]
    hard_mfa = next(r for r in baselines.rows if r[:2] == ("hard", "MFA"))
    assert hard_mfa[-1] == 29.98 and hard_mfa[6] == len(folder.split("hard")["test"])
    text = S.format_baselines(baselines)
    assert "AT-MFA" in text and "/ 42.0" in text and "/ 41.1" in text


def test_stats_command_writes_csv_and_charts(users_dataset: Path, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib", reason="charts need matplotlib, the stats extra: pip install 'craft-dsl[stats]'")
    out = tmp_path / "stats"
    assert main(["stats", str(users_dataset), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "heuristic baselines" in captured.out and "wrote 18 files" in captured.err
    names = ("answers_per_template", "answers_per_category", "question_types_per_scene", "events_per_video",
             "objects_per_scene", "baselines")
    for name in names:
        for ext in ("csv", "png", "svg"):
            assert (out / f"{name}.{ext}").stat().st_size > 0, (name, ext)
        assert (out / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (out / f"{name}.svg").read_text().lstrip().startswith("<?xml")
    with (out / "baselines.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert [r["baseline"] for r in rows[:4]] == list(S.BASELINES) and rows[2]["paper_All"] == "30.72"
    from craft_dsl.dataset.charts import write_charts

    again = write_charts([S.baselines_table(DatasetFolder(users_dataset))], tmp_path / "again")
    for path in again:  # the same table gives the same bytes (no date, no random ids)
        assert path.read_bytes() == (out / path.name).read_bytes(), path.name


def test_stats_command_json_and_errors(users_dataset: Path, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["stats", str(users_dataset), "--out", str(tmp_path), "--no-charts", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data["tables"]) == {"answers_per_template", "answers_per_category", "question_types_per_scene",
                                   "events_per_video", "objects_per_scene", "baselines"}
    assert not list(tmp_path.glob("*.png"))
    assert main(["stats", str(tmp_path)]) == 2
    assert "not a CRAFT dataset folder (no dataset_minimal.json" in capsys.readouterr().err


def test_stats_command_in_a_subprocess(users_dataset: Path, tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "craft_dsl.cli", "stats", str(users_dataset), "--no-charts",
                           "--out", str(tmp_path)], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert "MFA" in done.stdout and (tmp_path / "events_per_video.csv").is_file()
