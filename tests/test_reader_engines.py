"""Which physics a perceived scene is executed with: the ``physics`` field, and the reader's choice of engine by how
closely each engine's reconstruction follows the video."""

from __future__ import annotations

import sys
from dataclasses import replace
from typing import Any

import pytest

from craft_dsl import parse
from craft_dsl.errors import PerceptionError
from craft_dsl.perception import PerceivedScene, SceneModel, export_perceived
from craft_dsl.perception.world import ExecutionOptions
from craft_dsl.physics import simulate
from craft_dsl.reader import reconstruct as R

# scene 2, seed 0, 300 steps of Box2D: without the large blue circle one object hits the ground in Box2D, none in
# pymunk (so executing the scene with the wrong engine gives another answer)
COUNTERFACTUAL = ('Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(GetCounterfactEvents(Unique('
                  'FilterColor(FilterShape(FilterSize(FilterDynamic(SceneAtStart()), "large"), "circle"), "blue"'
                  ')))))))')


# -- the physics field ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("engine", ["pymunk", "box2d"])
def test_an_exported_live_run_names_its_engine_and_is_executed_with_it(engine: str) -> None:
    sim = simulate(6, seed=4, steps=300, engine=engine)
    scene = export_perceived(sim)
    assert scene.physics == engine
    model = SceneModel(PerceivedScene.model_validate_json(scene.model_dump_json()))
    assert model.engine.name == engine
    assert SceneModel(scene, ExecutionOptions(engine="pymunk")).engine.name == "pymunk"  # an explicit choice wins


def test_a_scene_that_names_no_engine_runs_with_pymunk(e1: Any) -> None:
    scene = export_perceived(e1)  # a recorded simulation: no engine made it
    assert scene.physics is None
    assert SceneModel(scene).engine.name == "pymunk"


def test_counterfactuals_of_a_box2d_scene_are_box2d_counterfactuals() -> None:
    sim = simulate(2, seed=0, steps=300, engine="box2d")
    scene = export_perceived(sim)
    program = parse(COUNTERFACTUAL)
    assert program.run(SceneModel(scene).simulation()) == program.run(sim) == 1
    assert program.run(SceneModel(scene, ExecutionOptions(engine="pymunk")).simulation()) == 0


def test_an_unknown_engine_is_refused_naming_the_field() -> None:
    data = export_perceived(simulate(1, seed=0, steps=60)).model_dump(mode="json")
    data["physics"] = "bullet"
    with pytest.raises(PerceptionError, match="physics"):
        PerceivedScene.model_validate(data)


# -- the reader's choice ----------------------------------------------------------------------------------------


def _fake_reconstruct(distances: dict[str, float], calls: list[str]) -> Any:
    def fake(_model: Any, _values: Any, _objects: Any, _frames: int, _steps: int, engine: str, _measure: Any
             ) -> R.Reconstruction:
        calls.append(engine)
        return R.Reconstruction(simulation=engine, values={}, slots=[], attributes=[],  # type: ignore[arg-type]
                                final_px=distances[engine])
    return fake


@pytest.mark.parametrize(("distances", "tried", "kept"), [
    ({"pymunk": 0.6, "box2d": 0.3}, ["pymunk"], "pymunk"),  # close enough: no second engine
    ({"pymunk": 4.0, "box2d": 2.5}, ["pymunk", "box2d"], "box2d"),  # the second follows the video better
    ({"pymunk": 4.0, "box2d": 3.9}, ["pymunk", "box2d"], "pymunk"),  # within the margin: the first stays
    ({"pymunk": 4.0, "box2d": 9.0}, ["pymunk", "box2d"], "pymunk"),
])
def test_the_engine_whose_run_follows_the_video_is_kept(monkeypatch: pytest.MonkeyPatch, distances: dict[str, float],
                                                         tried: list[str], kept: str) -> None:
    calls: list[str] = []
    monkeypatch.setattr(R, "reconstruct", _fake_reconstruct(distances, calls))
    rec = R.reconstruct_best(None, {}, [], 10, 10, engines=["pymunk", "box2d"])  # type: ignore[arg-type]
    assert calls == tried and list(rec.tried) == tried and rec.simulation == kept


def test_without_box2d_the_reader_uses_pymunk_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    assert R.reader_engines() == ("pymunk", "box2d")
    assert R.reader_engines(aliased=True) == ("box2d",)  # the original renderer's look: its physics
    monkeypatch.setitem(sys.modules, "Box2D", None)
    assert R.reader_engines() == ("pymunk",)
    assert R.reader_engines(aliased=True) == ("pymunk",)
    with pytest.raises(ValueError, match="at least one engine"):
        R.reconstruct_best(None, {}, [], 10, engines=[])  # type: ignore[arg-type]


def test_the_reader_names_the_engine_in_the_perceived_scene() -> None:
    from craft_dsl.reader.perceive import perceive_frames
    from craft_dsl.render import frames as render_frames

    sim = simulate(1, seed=2, steps=90)
    perception = perceive_frames(render_frames(sim), engines=["box2d"])
    assert perception.scene.physics == "box2d" and perception.scene.meta["engines_tried"] == ["box2d"]
    assert SceneModel(perception.scene).engine.name == "box2d"
    assert replace(perception.reconstruction, tried=()).simulation.engine.name == "box2d"
