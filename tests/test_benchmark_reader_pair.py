"""benchmarks/reader_pair.py: two codes' reading speed from runs made side by side, and whether they answer alike."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from tests.script_module import load_script

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "reader_pair.py"


@pytest.fixture(scope="module")
def pair() -> ModuleType:
    return load_script(SCRIPT, "reader_pair")


def _report(seconds: dict[str, float], answers: dict[str, str]) -> dict[str, Any]:
    """A ``reader.py --json`` report: each video's timings (perception a third of its seconds' rest) and answers."""
    videos = []
    for name, s in seconds.items():
        stages = {"decode": 0.1, "layout": 0.2, "detect": 0.3, "reconstruct": s - 1.1, "answering": 0.5}
        videos.append({"path": f"/data/videos/{name}", "timings": {**stages, "perception": s - 0.5},
                       "questions": [{"key": k, "answer": a} for k, a in answers.items() if k.startswith(name)]})
    return {"per_video": videos}


def test_a_round_compares_seconds_stages_and_answers(pair: ModuleType) -> None:
    base = _report({"000001.mpg": 2.0, "000002.mpg": 4.0, "000003.mpg": 3.0},
                   {"000001.mpg-0": "True", "000002.mpg-0": "2", "000003.mpg-0": "red"})
    cur = _report({"000001.mpg": 1.5, "000002.mpg": 3.0, "000003.mpg": 3.0},
                  {"000001.mpg-0": "True", "000002.mpg-0": "3", "000003.mpg-0": "red"})
    r = pair.compare(base, cur)
    assert r["videos"] == 3
    assert r["baseline"]["mean"] == pytest.approx(3.0) and r["current"]["mean"] == pytest.approx(2.5)
    assert r["baseline"]["median"] == pytest.approx(3.0) and r["current"]["median"] == pytest.approx(3.0)
    assert r["ratio"] == pytest.approx(2.5 / 3.0)
    assert r["current"]["stages"]["reconstruct"] == pytest.approx(2.5 - 1.1)
    assert r["answers_differ"] == ["000002.mpg-0"]
    text = "\n".join(pair.round_lines(1, (0, 1), r))
    assert "| mean | 3.000 | 2.500 | 0.833 |" in text and "baseline on core 0, current on core 1" in text
    assert "unpinned" in "\n".join(pair.round_lines(1, (None, None), r))
    same = pair.compare(base, base)
    assert pair.summary_lines([r, same])[0].startswith("current / baseline over 2 rounds: **0.917**")
    assert "1 questions answered differently: ['000002.mpg-0']" in pair.summary_lines([r, same])[0]
    assert "every answer the same" in pair.summary_lines([same])[0]


def test_runs_of_other_videos_are_refused(pair: ModuleType) -> None:
    with pytest.raises(ValueError, match="different videos"):
        pair.compare(_report({"000001.mpg": 2.0}, {}), _report({"000002.mpg": 2.0}, {}))
    with pytest.raises(ValueError, match="no video"):
        pair.compare(_report({}, {}), _report({}, {}))


def test_a_folder_that_is_no_dataset_is_refused(pair: ModuleType, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        pair.main(["--dataset", str(tmp_path), "--baseline", "HEAD"])
    assert "not a dataset with videos" in capsys.readouterr().err


@pytest.mark.skipif(not (SCRIPT.parents[1] / ".git").exists(),
                    reason="compares with a commit checked out by git: needs a git checkout of the project")
def test_the_committed_code_beside_itself_answers_alike(pair: ModuleType, users_dataset: Path, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "pair.json"
    assert pair.main(["--dataset", str(users_dataset), "--baseline", "HEAD", "--limit", "1", "--rounds", "1",
                      "--json", str(out)]) == 0
    (r,) = json.loads(out.read_text())["rounds"]
    assert r["videos"] == 1 and r["answers_differ"] == []
    assert r["baseline"]["mean"] > 0 and r["current"]["mean"] > 0
    printed = capsys.readouterr().out
    assert "### round 1" in printed and "every answer the same" in printed
