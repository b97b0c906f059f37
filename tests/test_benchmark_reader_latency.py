"""benchmarks/reader.py's latency table: videos grouped by the restarts their reconstruction needed."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from craft_dsl.reader.reconstruct import MAX_ANCHORS
from tests.script_module import load_script

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    return load_script(BENCHMARKS / "reader.py", "reader_benchmark")


def _video(anchors: int, reconstruct: float, tried: int = 1) -> dict[str, Any]:
    return {"anchors": anchors, "tried": ["pymunk", "box2d"][:tried],
            "timings": {"perception": reconstruct + 1.0, "answering": 0.5, "reconstruct": reconstruct}}


def test_videos_are_grouped_by_restarts_with_their_share_of_the_reconstruction(bench: ModuleType) -> None:
    videos = [_video(0, 1.0), _video(2, 2.0), _video(MAX_ANCHORS, 5.0, tried=2), _video(MAX_ANCHORS, 2.0)]
    lines = bench.latency_lines(videos)
    text = "\n".join(lines)
    assert "median 3.50" in text and "largest 6.50" in text
    rows = {line.split(" | ")[0].strip("| "): line for line in lines if line.startswith("| ") and "---" not in line}
    assert rows["none"] == "| none | 1 | 1.00 | 10% |"
    assert rows["1-2"] == "| 1-2 | 1 | 2.00 | 20% |"
    assert rows[f"{MAX_ANCHORS} (the most)"] == f"| {MAX_ANCHORS} (the most) | 2 | 3.50 | 70% |"
    assert rows["a second engine tried"] == "| a second engine tried | 1 | 5.00 | 50% |"
    assert "3-5" not in rows


def test_no_videos_no_table(bench: ModuleType) -> None:
    assert bench.latency_lines([]) == []
