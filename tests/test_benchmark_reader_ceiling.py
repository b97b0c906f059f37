"""benchmarks/reader_ceiling.py: the reader beside engines run from the true and the fitted start state."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from craft_dsl.verify.answers import answers_agree
from tests.script_module import load_script

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    return load_script(BENCHMARKS / "reader_ceiling.py", "reader_ceiling")


def test_the_table_counts_accuracy_per_column_and_the_shared_wrong_answers(bench: ModuleType) -> None:
    true_row = "box2d from the true start"
    results: list[dict[str, Any]] = [
        {"keys": ["0_0", "0_1"], "rows": {"reader": ["1", "True"], true_row: ["0", "True"]}},
        {"keys": ["1_0", "1_1"], "rows": {"reader": ["2", "Red"], true_row: ["2", "Blue"]}},
    ]
    truth = {"0_0": "0", "0_1": "True", "1_0": "2", "1_1": "Blue", "9_9": "x"}
    template = {"0_0": "descriptive_4", "0_1": "counterfactual_0", "1_0": "descriptive_5", "1_1": "descriptive_22"}
    lines = bench.table(results, {"0_0", "0_1", "1_0", "1_1"}, truth, template)
    assert lines[0].startswith("| answered by | All (4) | C (0) | CF (1) | D (3) |")
    reader = next(line for line in lines if line.startswith("| reader |"))
    engine = next(line for line in lines if line.startswith(f"| {true_row} |"))
    assert reader == "| reader | 50.00 | - | 100.00 | 33.33 | - |"
    # the engine gets every answer right: it shares none of the reader's two wrong answers
    assert engine == f"| {true_row} | 100.00 | - | 100.00 | 100.00 | 0 of 2 |"
    only_some = bench.table(results, {"0_0"}, truth, template)
    assert "| reader | 0.00 | - | - | 0.00 | - |" in only_some


def test_the_datasets_own_engine_from_the_true_start_gives_the_datasets_answers(bench: ModuleType,
                                                                              users_dataset: Path,
                                                                              tmp_path: Path) -> None:
    out = tmp_path / "rows.json"
    bench.main(["--dataset", str(users_dataset), "--engines", "box2d", "--limit", "1", "--workers", "1",
                "--json", str(out)])
    (video,) = json.loads(out.read_text())["results"]
    truth = bench.held_out_questions(users_dataset).truth
    rows = video["rows"]
    assert set(rows) == {"reader", "box2d from the true start", "box2d from the reader's start"}  # the default
    assert all(len(answers) == len(video["keys"]) for answers in rows.values())
    assert video["keys"] and all(answers_agree(a, truth[k])
                                 for k, a in zip(video["keys"], rows["box2d from the true start"]))
