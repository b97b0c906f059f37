"""benchmarks/reader_votes.py: the reader's answers with and without counterfactual votes, and their cost."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType

import pytest

from craft_dsl.perception import export_perceived
from craft_dsl.physics import simulate
from craft_dsl.question_parsing import question_to_program
from craft_dsl.reader.answer import format_answer
from tests.script_module import load_script

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
#: Questions about the scene of ``simulate(3, 7)`` (a large red circle, a small cyan circle, a large red cube).
TEXTS = ("How many objects fall to the ground?",
         "If the small cyan circle is removed, how many objects enter the basket?",
         "If the large red cube is removed, how many objects enter the basket?")


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    return load_script(BENCHMARKS / "reader_votes.py", "reader_votes")


def test_the_summary_counts_what_the_votes_changed_per_column(bench: ModuleType) -> None:
    records = [{"column": "CF", "truth": "2", "plain": "1", "voted": "2"},
               {"column": "CF", "truth": "True", "plain": "True", "voted": "False"},
               {"column": "C", "truth": "0", "plain": "1", "voted": "2"},
               {"column": "D", "truth": "Red", "plain": "Red", "voted": "Red"}]
    summary = bench.summarize(records)
    assert summary["CF"] == {"questions": 2, "plain": 1, "voted": 1, "to_right": 1, "to_wrong": 1}
    assert summary["C"] == {"questions": 1, "plain": 0, "voted": 0, "to_other": 1}
    assert summary["All"]["questions"] == 4 and summary["All"]["voted"] == 2
    text = bench.table(summary, plain_s=2.0, voted_s=3.0, videos=2, votes=6)
    assert "| CF | 2 | 1 | 1 | 1 | 1 | 0 |" in text
    assert "1.000 s a video with the replay alone, 1.500 s with 6 votes: x1.50" in text


def test_a_folder_of_perceived_scenes_is_answered_both_ways(bench: ModuleType, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    sim = simulate(3, 7)
    (tmp_path / "perceived").mkdir()
    (tmp_path / "perceived" / "000003.json").write_text(export_perceived(sim).dumps())
    questions = [{"video_index": 3, "question_index": i, "question": t} for i, t in enumerate(TEXTS)]
    (tmp_path / "questions.json").write_text(json.dumps(questions))
    truth = [{**q, "answer": format_answer(question_to_program(q["question"]).run(sim))} for q in questions]
    (tmp_path / "dataset_minimal.json").write_text(json.dumps(truth))
    out = tmp_path / "votes.json"
    assert bench.main(["--perceived", str(tmp_path / "perceived"), "--questions", str(tmp_path / "questions.json"),
                       "--dataset", str(tmp_path), "--votes", "2", "--workers", "1", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| All | 3 | 3 | 3 | 0 | 0 | 0 |" in printed  # an exact scene: right both ways
    assert "with 2 votes" in printed
    data = json.loads(out.read_text())
    assert [r["column"] for r in data["records"]] == ["D", "CF", "CF"]
    assert data["voted_s"] > 0 and data["plain_s"] > 0
