"""End-to-end tests of the craft-dsl command line (in-process main() and the installed script)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from craft_dsl.cli import main

DATA = Path(__file__).parent / "data"
E1 = str(DATA / "e1.json")
FALL = "Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))"


def run_cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_run_text_program(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(capsys, "run", FALL, "--sim", E1) == (0, "2\n", "")


def test_run_json_and_program_file(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    prog = tmp_path / "q.craft"
    prog.write_text('Var Red = FilterColor(SceneAtStart(), "Red")\n# comment\nQueryShape(Red)\n')
    code, out, _ = run_cli(capsys, "run", f"@{prog}", "--sim", E1, "--json")
    assert code == 0
    assert json.loads(out) == {
        "program": 'Var Red = FilterColor(SceneAtStart(), "red")\nQueryShape(Unique(Red))',
        "type": "Shape",
        "answer": "cube",
    }


def test_run_trace_lists_every_node(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_cli(capsys, "run", FALL, "--sim", E1, "--trace", "--json")
    assert code == 0
    trace = json.loads(out)
    assert [t["expression"] for t in trace][0] == "Events()"
    assert trace[-1] == {"expression": FALL, "type": "Integer", "value": 2}
    assert trace[-2]["value"] == [1, 3]


def test_run_invalid_answer_in_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_cli(capsys, "run", 'QueryColor(FilterShape(SceneAtStart(), "circle"))', "--sim", E1,
                           "--json")
    assert code == 0 and json.loads(out)["answer"] == "__INVALID__"


def test_run_node_list_with_params(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from craft_dsl.templates import templates

    nodes = tmp_path / "nodes.json"
    nodes.write_text(json.dumps(list(templates()["counterfactual_3"].nodes)))
    code, out, _ = run_cli(capsys, "run", "--nodes", str(nodes), "--sim", E1,
                           "--param", "<Z>=small", "--param", "C=blue", "--param", "<S>=circle")
    assert (code, out) == (0, "2\n")


def test_check_prints_canonical_form_and_type(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_cli(capsys, "check", "exist ( filter_enter_container ( events() ) )")
    assert code == 0
    assert out == "Exist(FilterEnterBasket(Events()))\n: Bool\n"


@pytest.mark.parametrize(
    ("program", "needle"),
    [
        ("Count(SceneAtStart()))", "line 1, column 22"),
        ("Cont(SceneAtStart())", "did you mean Count"),
        ('FilterColor(SceneAtStart(), "pink")', "allowed: gray, red"),
        ("Count(StartSceneStep())", "Count: argument 1 expects EventSet or ObjectSet, found Integer"),
    ],
)
def test_check_errors_exit_2_with_message(capsys: pytest.CaptureFixture[str], program: str, needle: str) -> None:
    code, out, err = run_cli(capsys, "check", program)
    assert code == 2 and out == ""
    assert err.startswith("error: ") and needle in err


def test_bad_simulation_file_is_refused(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    broken = tmp_path / "broken.json"
    broken.write_text((DATA / "e1.json").read_text()[:500])
    code, _, err = run_cli(capsys, "run", FALL, "--sim", str(broken))
    assert code == 2 and "not valid JSON" in err and "truncated" in err


def test_modules_lists_the_registry(capsys: pytest.CaptureFixture[str]) -> None:
    from craft_dsl.registry import MODULES

    code, out, _ = run_cli(capsys, "modules")
    assert code == 0
    names = [line.split()[0] for line in out.splitlines()]
    assert names == [m.name for m in MODULES]


def test_installed_script_runs() -> None:
    exe = shutil.which("craft-dsl")
    cmd = [exe] if exe else [sys.executable, "-m", "craft_dsl.cli"]
    res = subprocess.run([*cmd, "run", FALL, "--sim", E1], capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr
    assert res.stdout == "2\n"


def test_run_on_a_live_simulation(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_cli(capsys, "run", "Count(FilterDynamic(SceneAtStart()))", "--scene", "2", "--seed", "1")
    assert (code, out) == (0, "10\n")


def test_run_needs_exactly_one_simulation(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_cli(capsys, "run", FALL)
    assert code == 2 and "--sim FILE" in err and "--scene N" in err
    code, _, err = run_cli(capsys, "run", FALL, "--sim", E1, "--scene", "3")
    assert code == 2 and "not both" in err


def test_closed_pipe_is_quiet() -> None:
    exe = shutil.which("craft-dsl")
    cmd = " ".join([exe] if exe else [sys.executable, "-m", "craft_dsl.cli"])
    res = subprocess.run(f"{cmd} modules | head -1", shell=True, capture_output=True, text=True, check=False)
    assert res.stdout.startswith("SceneAtStart")
    assert "Traceback" not in res.stderr
