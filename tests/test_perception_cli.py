"""``craft-dsl perceive``: export, noise, check, fit, run, answer and schema, end to end."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from craft_dsl.cli import main
from craft_dsl.dataset.questions import generate_questions
from craft_dsl.perception import load_perceived
from craft_dsl.physics import simulate

#: The engine these precision tests run: the derivation's tolerance and the fit's sub-pixel drift were measured on
#: pymunk's runs (true circles, one contact); on Box2D's (the default), whose circles' contacts flicker, the
#: figures are in docs/perception.md.
PRECISION_ENGINE = "pymunk"


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("perceive") / "p.json"
    assert main(["perceive", "export", "--scene", "3", "--seed", "7", "--engine", PRECISION_ENGINE,
                 "--out", str(path)]) == 0
    return path


def test_export_writes_a_valid_ground_truth_scene(exported: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene, dropped = load_perceived(exported)
    assert dropped == [] and scene.scene == 3 and scene.video.frames == 600
    assert main(["perceive", "check", str(exported)]) == 0
    assert "13 objects (3 tracked), events: 48" in capsys.readouterr().out


def test_run_and_distribution(exported: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    program = "Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))"
    true = simulate(3, seed=7, engine=PRECISION_ENGINE)
    from craft_dsl import parse

    assert main(["perceive", "run", program, "--perceived", str(exported), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["answer"] == parse(program).run(true)
    noisy = tmp_path / "n.json"
    assert main(["perceive", "noise", str(exported), "--attribute-confusion", "0.3", "--seed", "1",
                 "--out", str(noisy)]) == 0
    capsys.readouterr()
    assert main(["perceive", "run", 'Count(FilterColor(SceneAtStart(), "red"))', "--perceived", str(noisy),
                 "--distribution", "--json", "--samples", "40"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "monte_carlo" and out["samples"] == 40
    assert sum(a["p"] for a in out["answers"]) == pytest.approx(1.0)


def test_answer_a_question_file_with_truth(exported: Path, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    import numpy as np

    sim = simulate(3, seed=7, engine=PRECISION_ENGINE)
    records = generate_questions(sim, np.random.default_rng(0), video_index=0, video_filename="v.mp4")
    questions = tmp_path / "q.json"
    questions.write_text(json.dumps(records), encoding="utf-8")
    out = tmp_path / "answers.json"
    assert main(["perceive", "answer", "--perceived", str(exported), "--questions", str(questions), "--json",
                 "--out", str(out)]) == 0
    result = json.loads(out.read_text(encoding="utf-8"))
    assert len(result["questions"]) == len(records)
    assert result["accuracy"]["All"]["most_likely"] == 1.0
    assert main(["perceive", "answer", "--perceived", str(exported)]) == 0  # the 48 templates, no truth
    assert "descriptive_0" in capsys.readouterr().out


def test_fit_reports_the_start_and_the_drift(exported: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["perceive", "fit", "--perceived", str(exported), "--json"]) == 0
    fit = json.loads(capsys.readouterr().out)
    assert len(fit["bodies"]) == 3 and all(b["drift_px"]["max"] < 1.0 for b in fit["bodies"])


def test_bad_options_and_files_exit_2(exported: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["perceive", "noise", str(exported), "--attribute-confusion", "2"]) == 2
    assert "bad noise setting" in capsys.readouterr().err
    assert main(["perceive", "run", "Count(Events())", "--perceived", str(tmp_path / "missing.json")]) == 2
    assert "cannot read perceived scene" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text("{not json", encoding="utf-8")
    assert main(["perceive", "check", str(bad)]) == 2
    assert "not valid JSON (line 1" in capsys.readouterr().err


def test_schema_command_prints_the_committed_schema(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["perceive", "schema"]) == 0
    root = Path(__file__).resolve().parents[1]
    assert capsys.readouterr().out == (root / "docs" / "perceived_scene.schema.json").read_text(encoding="utf-8")


def test_subprocess_run_over_an_exported_scene(exported: Path) -> None:
    res = subprocess.run([sys.executable, "-m", "craft_dsl.cli", "perceive", "run",
                          'Exist(FilterColor(SceneAtStart(), "pink"))', "--perceived", str(exported)],
                         capture_output=True, text=True, check=False)
    assert res.returncode == 2 and res.stderr.startswith("error: ") and "pink" in res.stderr
    res = subprocess.run([sys.executable, "-m", "craft_dsl.cli", "perceive", "run", "Count(Events())",
                          "--perceived", str(exported)], capture_output=True, text=True, check=False)
    assert res.returncode == 0 and res.stdout.strip() == "50"


def test_answer_picks_one_video_of_a_dataset_file(exported: Path, tmp_path: Path) -> None:
    import numpy as np

    from craft_dsl.perception.answering import read_question_file

    sim = simulate(3, seed=7, engine=PRECISION_ENGINE)
    records = generate_questions(sim, np.random.default_rng(0), video_index=4, video_filename="v.mp4")[:5]
    dataset = [{"questions": {"info": {"video_index": v}, "questions": [dict(r, video_index=v) for r in records]}}
               for v in (3, 4)]
    path = tmp_path / "dataset.json"
    path.write_text(json.dumps(dataset), encoding="utf-8")
    items = read_question_file(path, video_index=4)
    assert [i.template_id for i in items] == [r["template_id"] for r in records]
    assert main(["perceive", "answer", "--perceived", str(exported), "--questions", str(path)]) == 2  # which video?
