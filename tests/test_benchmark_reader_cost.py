"""benchmarks/reader_cost.py: the CPU seconds of a child command are counted, and the reader reads the test
questions of the chosen test videos only, as records holding nothing but the question."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType

import pytest

from tests.script_module import load_script

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "reader_cost.py"


@pytest.fixture(scope="module")
def rc() -> ModuleType:
    return load_script(SCRIPT, "reader_cost")


def test_a_child_command_s_cpu_seconds_are_counted(rc: ModuleType) -> None:
    cpu, wall = rc.run_child(["--version"])
    assert cpu > 0.0 and wall > 0.0  # a Python start-up costs CPU time, counted once the child has ended


def test_only_the_test_questions_of_the_first_test_videos_are_read(rc: ModuleType, tmp_path: Path) -> None:
    records = [{"video_index": v, "question_index": q, "question": f"q{v}.{q}", "answer": "1", "program": []}
               for v in range(4) for q in range(2)]
    (tmp_path / "dataset_minimal.json").write_text(json.dumps(records))
    (tmp_path / "split_info_random.json").write_text(json.dumps(
        {"test": [{"video_index": 1, "question_index": 0}, {"video_index": 3, "question_index": 1}]}))
    (tmp_path / "split_info_hard.json").write_text(json.dumps(
        {"test": [{"video_index": 2, "question_index": 1}, {"video_index": 3, "question_index": 1}]}))
    chosen, videos = rc.test_questions(tmp_path, 2)
    assert videos == [1, 2]
    assert chosen == [{"video_index": 1, "question_index": 0, "question": "q1.0"},
                      {"video_index": 2, "question_index": 1, "question": "q2.1"}]
    assert rc.test_questions(tmp_path, None)[1] == [1, 2, 3]
