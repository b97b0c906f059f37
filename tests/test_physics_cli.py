"""The physics CLI commands: simulate and scenes stats."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from test_physics_micro import each_engine

from craft_dsl.analysis.scene_stats import format_table, scene_stats
from craft_dsl.cli import main


@each_engine
def test_simulate_command_writes_a_loadable_file(tmp_path: Path, engine: str) -> None:
    out = tmp_path / "sim.json"
    assert main(["simulate", "--scene", "3", "--seed", "1", "--steps", "120", "--out", str(out),
                 "--no-variations", "--engine", engine]) == 0
    data = json.loads(out.read_text())
    assert "causal_graph" in json.dumps(data) or "scene_states" in json.dumps(data)
    from craft_dsl.recorded import load_simulation

    sim = load_simulation(out)
    assert sim.steps == 120 and len(sim.dynamic_ids) == 3


@each_engine
def test_scenes_stats_command(capsys: pytest.CaptureFixture[str], engine: str) -> None:
    assert main(["scenes", "stats", "--seeds", "1", "--scenes", "3", "--steps", "60", "--engine", engine]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].split()[:3] == ["scene", "runs", "dynamic"]
    assert out.splitlines()[1].split()[:3] == ["3", "1", "3.00"]


@each_engine
def test_scene_stats_values(engine: str) -> None:
    row = scene_stats(4, range(2), steps=600, engine=engine)
    assert row.runs == 2 and row.dynamic_objects == 4.0
    assert 0.0 < row.basket_share <= 1.0 and not row.degenerate
    assert "| 4 | 2 |" in format_table([row], markdown=True)


@each_engine
def test_simulate_command_exports_variations(tmp_path: Path, engine: str) -> None:
    out = tmp_path / "sim.json"
    assert main(["simulate", "--scene", "10", "--seed", "0", "--steps", "200", "--out", str(out),
                 "--engine", engine]) == 0
    from craft_dsl.physics import simulate
    from craft_dsl.recorded import load_simulation

    loaded, live = load_simulation(out), simulate(10, seed=0, steps=200, engine=engine)
    assert [(e.type, e.step, e.objects) for e in loaded.events] == [(e.type, e.step, e.objects) for e in live.events]
    uid = min(live.dynamic_ids)
    assert [(e.type, e.step) for e in loaded.counterfactual(uid).events] == [
        (e.type, e.step) for e in live.counterfactual(uid).events]


def test_unknown_engine_is_rejected_by_the_cli(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["simulate", "--scene", "3", "--out", "x.json", "--engine", "ode"])
    assert "invalid choice" in capsys.readouterr().err
