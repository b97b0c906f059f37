"""The docs' module reference is generated from the registry and must stay in step with it."""

from __future__ import annotations

import subprocess
from pathlib import Path

from craft_dsl.cli import modules_table

ROOT = Path(__file__).resolve().parents[1]


def test_module_reference_matches_registry() -> None:
    text = (ROOT / "docs" / "modules.md").read_text(encoding="utf-8")
    table = modules_table(markdown=True)
    assert table in text, "docs/modules.md is stale: regenerate it with `craft-dsl modules --markdown`"


def test_readme_has_the_two_newcomer_commands() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    head = readme[:2000]
    assert "pip install -e . && craft-dsl demo" in head
    assert "pip install -e '.[dev]' && python -m pytest -q" in head


def _ci_function_output(ci: str, name: str, call: str) -> list[str]:
    """The lines printed by ``call`` run in bash, with the shell function ``name`` defined as .ci/run defines it."""
    function = ci[ci.index(f"{name}() {{"):]
    function = function[:function.index("\n}\n") + 3]
    done = subprocess.run(["bash", "-c", function + call], cwd=ROOT, capture_output=True, text=True, check=True)
    return done.stdout.splitlines()


def test_ci_runs_the_readme_commands_read_from_readme() -> None:
    """.ci/run reads README's two commands from README (so they cannot drift apart) and runs them in a venv."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    calls = 'readme_command "**Install and run the main job**"; readme_command "**Run the tests:**"'
    assert _ci_function_output(ci, "readme_command", calls) == [
        "python -m pip install -e . && craft-dsl demo", "python -m pip install -e '.[dev]' && python -m pytest -q"]
    assert 'eval "$MAIN_CMD"' in ci and 'eval "$TEST_CMD"' in ci and '-m venv "$VENV"' in ci


def test_ci_runs_the_harness_lines_read_from_readme() -> None:
    """.ci/run runs README's evaluation-harness lines, every one of them, as README prints them."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    lines = _ci_function_output(ci, "readme_block", 'readme_block "**Run the evaluation-harness tests**"')
    assert len(lines) == 3 and "-e '.[dev,lmms-eval,trl]'" in lines[0]
    assert lines[-1] == "python -m pytest -q tests/test_harness_*.py"
    assert '<<< "$HARNESS_CMDS"' in ci and 'eval "$line"' in ci
