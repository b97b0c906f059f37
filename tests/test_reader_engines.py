"""Which physics a perceived scene is executed with: the ``physics`` field, and the reader's choice of engine by how
closely each engine's reconstruction follows the video."""

from __future__ import annotations

import sys
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from craft_dsl import parse
from craft_dsl.errors import PerceptionError
from craft_dsl.perception import PerceivedScene, SceneModel, export_perceived
from craft_dsl.perception.world import ExecutionOptions
from craft_dsl.physics import simulate
from craft_dsl.reader import reconstruct as R
from craft_dsl.vocabulary import DEFAULT_ENGINE

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


def test_a_scene_that_names_no_engine_runs_with_the_default_engine(e1: Any) -> None:
    scene = export_perceived(e1)  # a recorded simulation: no engine made it
    assert scene.physics is None
    assert SceneModel(scene).engine.name == DEFAULT_ENGINE == "box2d"


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


def _fake_runs(first_runs: dict[str, tuple[float, int, float]], calls: list[str], full: list[str],
               frames: int = 600) -> tuple[Any, Any]:
    """Stand-ins for first_run and reconstruct: each engine's first run (score, first stray frame; ``frames``: none
    strays) and its whole reconstruction's distance from the tracks."""
    def first(_model: Any, _values: Any, _objects: Any, _frames: int, _steps: int, engine: str, _measure: Any,
              _rows: Any) -> R.FirstRun:
        calls.append(engine)
        score, strays, _final = first_runs[engine]
        attempt = R._Attempt(np.zeros(0), {}, engine, {}, {0: strays} if strays < frames else {},  # type: ignore[arg-type]
                             0, 0, score)
        return R.FirstRun(engine, np.arange(1, frames + 1), [], [], attempt)  # type: ignore[arg-type]

    def rec(model: Any, values: Any, objects: Any, frames_: int, steps: int, engine: str, measure: Any,
            rows: Any, opening: R.FirstRun | None = None) -> R.Reconstruction:
        if opening is None:  # its first run not made yet: made here, as reconstruct does
            opening = first(model, values, objects, frames_, steps, engine, measure, rows)
        assert opening.engine == engine  # each engine goes on from its own first run
        full.append(engine)
        return R.Reconstruction(simulation=engine, values={}, slots=[], attributes=[],  # type: ignore[arg-type]
                                final_px=first_runs[engine][2])
    return first, rec


@pytest.mark.parametrize(("first_runs", "tried", "full", "record", "physics"), [
    # no body strays from pymunk's first run, and its run follows the video closely: pymunk alone
    ({"pymunk": (0.6, 600, 0.6), "box2d": (0.3, 600, 0.3)}, ["pymunk"], ["pymunk"], "pymunk", "pymunk"),
    # Box2D's first run is nearer and follows the video throughout / 40 frames longer: Box2D's physics; the record
    # is Box2D's run where pymunk's does not follow closely, pymunk's where it does
    ({"pymunk": (4.0, 120, 3.0), "box2d": (1.0, 600, 1.0)}, ["pymunk", "box2d"], ["pymunk", "box2d"], "box2d",
     "box2d"),
    ({"pymunk": (4.0, 120, 1.5), "box2d": (2.5, 160, 1.0)}, ["pymunk", "box2d"], ["pymunk"], "pymunk", "box2d"),
    # not nearer by the margin, not longer, or not both: pymunk's physics, whichever run is the record
    ({"pymunk": (4.0, 120, 3.0), "box2d": (3.9, 600, 0.5)}, ["pymunk", "box2d"], ["pymunk", "box2d"], "box2d",
     "pymunk"),
    ({"pymunk": (4.0, 120, 3.0), "box2d": (9.0, 600, 2.9)}, ["pymunk", "box2d"], ["pymunk", "box2d"], "pymunk",
     "pymunk"),
    ({"pymunk": (12.0, 120, 1.0), "box2d": (4.0, 130, 0.9)}, ["pymunk", "box2d"], ["pymunk"], "pymunk", "pymunk"),
    # pymunk's first run strays only in the last 30 frames: no later run could follow 30 frames longer, so Box2D's
    # first run is not made (its whole reconstruction still is, pymunk's run not being close)
    ({"pymunk": (4.0, 571, 3.0), "box2d": (1.0, 600, 1.0)}, ["pymunk", "box2d"], ["pymunk", "box2d"], "box2d",
     "pymunk"),
    ({"pymunk": (4.0, 571, 1.0), "box2d": (1.0, 600, 1.0)}, ["pymunk"], ["pymunk"], "pymunk", "pymunk"),
    ({"pymunk": (4.0, 570, 1.0), "box2d": (1.0, 600, 1.0)}, ["pymunk", "box2d"], ["pymunk"], "pymunk", "box2d"),
    # no body strays from pymunk's first run, but its run is not close: Box2D's run may be the record
    ({"pymunk": (2.5, 600, 2.5), "box2d": (1.0, 600, 1.0)}, ["pymunk", "box2d"], ["pymunk", "box2d"], "box2d",
     "pymunk"),
])
def test_the_record_is_the_nearest_run_and_the_physics_the_first_run_that_follows_best(
        monkeypatch: pytest.MonkeyPatch, first_runs: dict[str, tuple[float, int, float]], tried: list[str],
        full: list[str], record: str, physics: str) -> None:
    calls: list[str] = []
    reconstructed: list[str] = []
    first, rec = _fake_runs(first_runs, calls, reconstructed)
    monkeypatch.setattr(R, "first_run", first)
    monkeypatch.setattr(R, "reconstruct", rec)
    out = R.reconstruct_best(None, {}, [], 600, 600, engines=["pymunk", "box2d"])  # type: ignore[arg-type]
    assert list(out.tried) == tried and reconstructed == full
    assert out.simulation == record and out.physics == physics
    assert calls.count("pymunk") == 1  # the first engine's reconstruction goes on from its first run
    made_first = calls.count("box2d") - reconstructed.count("box2d")  # Box2D's first run: made only if it can win
    assert made_first == (first_runs["pymunk"][1] + R.ENGINE_LATER_FRAMES <= 600)


def test_the_later_engine_must_follow_longer_at_the_video_rate() -> None:
    """ENGINE_LATER_FRAMES is a 60-fps count: at 10 fps 30 steps are 5 frames."""
    def run(score: float, strays: int, frames: int) -> R.FirstRun:
        attempt = R._Attempt(np.zeros(0), {}, None, {}, {0: strays}, 0, 0, score)  # type: ignore[arg-type]
        return R.FirstRun(None, np.arange(1, frames + 1) * (600 // frames), [], [], attempt)  # type: ignore[arg-type]
    assert R.later_engine_wins(run(4.0, 20, 100), run(1.0, 25, 100))
    assert not R.later_engine_wins(run(4.0, 20, 100), run(1.0, 24, 100))
    assert not R.later_engine_wins(run(4.0, 20, 600), run(1.0, 25, 600))


def test_the_first_engines_reconstruction_sees_only_its_own_first_runs_measurements(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Asking which physics made the video leaves no trace: each engine's first run starts from the same
    measurements, and the first engine's reconstruction sees exactly those its own first run made (as if it had
    been tried alone), never the other engine's."""
    from craft_dsl.reader.track import TrackedObject

    obj = TrackedObject(color=0, blobs=[])
    obj.poses[0] = (1.0, 1.0, 0.0)
    seen: dict[str, set[int]] = {}

    def first(_model: Any, _values: Any, objects: Any, frames: int, _steps: int, engine: str, _measure: Any,
              _rows: Any) -> R.FirstRun:
        seen[engine] = set(objects[0].poses)
        objects[0].poses[{"pymunk": 5, "box2d": 7}[engine]] = (0.0, 0.0, 0.0)  # what this engine's fit measured
        attempt = R._Attempt(np.zeros(0), {}, engine, {}, {0: 100}, 0, 0, 3.0)  # type: ignore[arg-type]
        return R.FirstRun(engine, np.arange(1, frames + 1), [], [], attempt)  # type: ignore[arg-type]

    def rec(_model: Any, _values: Any, objects: Any, *_args: Any, opening: R.FirstRun | None = None
            ) -> R.Reconstruction:
        assert opening is not None
        seen.setdefault("reconstructed", set()).update(objects[0].poses)
        return R.Reconstruction(simulation=opening.engine, values={}, slots=[], attributes=[],  # type: ignore[arg-type]
                                final_px=1.0)

    monkeypatch.setattr(R, "first_run", first)
    monkeypatch.setattr(R, "reconstruct", rec)
    out = R.reconstruct_best(None, {}, [obj], 600, 600, engines=["pymunk", "box2d"])  # type: ignore[arg-type]
    assert out.simulation == out.physics == "pymunk"  # box2d's first run is neither nearer nor longer
    assert seen == {"pymunk": {0}, "box2d": {0}, "reconstructed": {0, 5}}
    assert set(obj.poses) == {0, 5}  # the kept record's measurements are put back


def test_a_later_first_run_takes_the_measurements_already_made_and_holds_what_it_would_have_made() -> None:
    """Box2D's first run measures the frames pymunk's first run measured: from what they made, the same values,
    made once; frames not made before and poses of another shape are made as without it."""
    from craft_dsl.reader.track import TrackedObject

    made: list[tuple[str, int]] = []

    def measure(obj: Any, which: Any, shape: str, size: str) -> None:  # per frame, from that frame alone
        for k in which:
            if k not in obj.measurements:
                obj.measurements[k] = f"m{k}"
                made.append(("m", k))
        if obj.pose_shape != (shape, size):
            obj.poses.clear()
            obj.pose_shape = (shape, size)
        for k in which:
            if k not in obj.poses and k % 3:  # some frames get no exact pose
                obj.poses[k] = (float(k), 0.0, 0.0)
                made.append(("p", k))

    def fresh() -> Any:
        obj = TrackedObject(color=0, blobs=[])
        obj.measurements[0] = "m0"  # type: ignore[assignment]  # made before either first run
        return obj

    first, alone, later = fresh(), fresh(), fresh()
    measure(first, range(6), "cube", "small")
    again = R._reusing(measure, [later], R._measured([first]))
    for which, shape in ((range(8), "cube"), (range(4), "circle"), (range(10), "cube")):
        made.clear()
        measure(alone, which, shape, "small")
        done_alone = list(made)
        made.clear()
        again(later, which, shape, "small")
        assert (later.measurements, later.poses, later.pose_shape) == (alone.measurements, alone.poses,
                                                                       alone.pose_shape)
        assert set(made) <= set(done_alone)
    assert made == [("m", 8), ("m", 9), ("p", 7), ("p", 8)]  # the last call: only what the first run did not make


def test_without_box2d_the_reader_uses_pymunk_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    assert R.reader_engines() == ("box2d", "pymunk")  # the default engine first
    assert R.reader_engines(first="pymunk") == ("pymunk", "box2d")  # the engine the dataset names first
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


def test_a_record_of_one_engine_with_the_physics_of_the_other_is_executed_with_the_physics() -> None:
    """The perceived scene's tracks and events are the record's run; its counterfactuals re-simulate with the
    physics, and the meta names the record's engine."""
    from craft_dsl.reader.perceive import perceive_frames, to_perceived
    from craft_dsl.render import frames as render_frames

    sim = simulate(2, seed=0, steps=300, engine="box2d")
    perception = perceive_frames(render_frames(sim), engines=["pymunk"])
    rec = replace(perception.reconstruction, physics="box2d")
    scene = to_perceived(rec, perception.objects, perception.layout)
    assert scene.physics == "box2d" and scene.meta["run_engine"] == "pymunk"
    assert scene.events == perception.scene.events  # the record's events, whatever the physics
    assert SceneModel(scene).engine.name == "box2d"
    assert "run_engine" not in perception.scene.meta  # one engine: record and physics agree
