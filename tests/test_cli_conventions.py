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
    if "default" not in out:  # a command whose options are all flags (off unless given) or required
        options = [a for a in _commands()[command]._actions if a.option_strings]  # type: ignore[attr-defined]
        assert all(a.nargs == 0 or a.required for a in options), out


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


def test_a_scene_layout_file_is_accepted_wherever_a_scene_id_is(tmp_path: object,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    from pathlib import Path

    from craft_dsl.resources import data_dir

    folder = Path(str(tmp_path))
    layout = folder / "my_scene.json"
    layout.write_text((data_dir("scenes") / "scene_03.json").read_text())
    assert main(["render", "--scene", str(layout), "--steps", "20", "--frame", "10",
                 "--out", str(folder / "f.png")]) == 0
    assert main(["run", "Count(SceneAtStart())", "--scene", str(layout)]) == 0
    assert main(["engines", "compare", "--scenes", f"1,{layout}", "--seeds", "1", "--steps", "60", "--quiet"]) == 0
    assert "my_scene" in capsys.readouterr().out
    assert main(["scenes", "stats", "--scenes", str(layout), "--seeds", "1", "--steps", "30"]) == 0


@pytest.mark.parametrize("bad", ["21", "0", "nope.json", "x"])
def test_a_bad_scene_is_exit_2_naming_the_option(bad: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["render", "--scene", bad, "--out", "/tmp/never.png"]) == 2
    assert "--scene" in capsys.readouterr().err


def test_one_range_reader() -> None:
    from craft_dsl.errors import CraftError
    from craft_dsl.ranges import parse_ranges, parse_scenes

    assert parse_ranges("1,3,5-7", "--x", 1, 20) == (1, 3, 5, 6, 7)
    assert parse_scenes("all") == list(range(1, 21))
    for bad in ("1-", "5-3", "0", "a,b", ""):
        with pytest.raises(CraftError, match="--x"):
            parse_ranges(bad, "--x", 1, 20)
