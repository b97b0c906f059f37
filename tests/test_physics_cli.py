"""The physics CLI commands: simulate and scenes stats."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from craft_dsl.cli import main
from craft_dsl.physics.stats import format_table, scene_stats


def test_simulate_command_writes_a_loadable_file(tmp_path: Path) -> None:
    out = tmp_path / "sim.json"
    assert main(["simulate", "--scene", "3", "--seed", "1", "--steps", "120", "--out", str(out),
                 "--no-variations"]) == 0
    data = json.loads(out.read_text())
    assert "causal_graph" in json.dumps(data) or "scene_states" in json.dumps(data)
    from craft_dsl.recorded import load_simulation

    sim = load_simulation(out)
    assert sim.steps == 120 and len(sim.dynamic_ids) == 3


def test_scenes_stats_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scenes", "stats", "--seeds", "1", "--scenes", "3", "--steps", "60"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].split()[:3] == ["scene", "runs", "dynamic"]
    assert out.splitlines()[1].split()[:3] == ["3", "1", "3.00"]


def test_scene_stats_values() -> None:
    row = scene_stats(4, range(2), steps=600)
    assert row.runs == 2 and row.dynamic_objects == 4.0
    assert 0.0 < row.basket_share <= 1.0 and not row.degenerate
    assert "| 4 | 2 |" in format_table([row], markdown=True)
