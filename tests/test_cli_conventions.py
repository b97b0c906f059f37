"""Command-line conventions shared by every command."""

from __future__ import annotations

import subprocess
import sys

import pytest

from craft_dsl.cli import build_parser, main


def _commands() -> dict[str, object]:
    parser = build_parser()
    action = next(a for a in parser._actions if a.dest == "command")
    return dict(action.choices)  # type: ignore[arg-type]


def test_version_and_module_entry_point() -> None:
    res = subprocess.run([sys.executable, "-m", "craft_dsl", "--version"], capture_output=True, text=True, check=False)
    assert res.returncode == 0 and res.stdout.startswith("craft-dsl ")


@pytest.mark.parametrize("command", sorted(_commands()))
def test_every_command_shows_its_defaults(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "usage: craft-dsl" in out
    if "default" not in out:  # a command without any option that has a default
        assert out.count("--") <= 2, out


def test_workers_is_the_one_name_for_parallelism() -> None:
    for name, sub in _commands().items():
        options = {o for a in sub._actions for o in a.option_strings}  # type: ignore[attr-defined]
        assert "--jobs" not in options or "--workers" in options, name


def test_a_missing_extra_is_one_line_and_exit_2() -> None:
    code = ("import sys; sys.modules['Box2D'] = None\n"
            "from craft_dsl.cli import main\n"
            "sys.exit(main(['simulate', '--scene', '1', '--engine', 'box2d', '--out', '/dev/null']))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 2, res.stderr
    assert res.stderr.strip() == ("error: the box2d engine needs pybox2d, which is not installed: "
                                  "pip install 'craft-dsl[box2d]'")
