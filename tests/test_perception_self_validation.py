"""The perceived-scene model validates itself: the constructor, ``model_validate``, ``model_validate_json`` and the
file loader run the same checks and raise the same PerceptionError naming object, frame and field; a scene that
validated runs without a raw Python exception; a valid scene round-trips unchanged."""

from __future__ import annotations

import contextlib
import copy
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from perception_helpers import tiny_data, tiny_scene
from pydantic import ValidationError

from craft_dsl import Program
from craft_dsl.errors import CounterfactualUnavailable, CraftError, PerceptionError
from craft_dsl.perception import (
    ExecutionOptions,
    PerceivedScene,
    SceneModel,
    check_scene,
    export_perceived,
    load_perceived,
    most_likely_world,
    parse_scene,
    save_perceived,
)
from craft_dsl.perception import schema as schema_module
from craft_dsl.perception import validation as validation_module
from craft_dsl.perception.answering import answer_all, template_questions
from craft_dsl.perception.distribution import answer_distributions
from craft_dsl.perception.noise import NoiseModel, degrade
from craft_dsl.render.raster import frame_steps
from craft_dsl.strategies import simulations
from craft_dsl.vocabulary import COLORS, SHAPES, SIZES

# -- the five malformed scenes of the issue, through every path --------------------------------------------------


def _nan_position(d: dict[str, Any]) -> None:
    d["objects"][2]["track"]["y"][7] = math.nan


def _unknown_colour(d: dict[str, Any]) -> None:
    d["objects"][2]["color"] = {"pink": 1.0}


def _event_naming_a_missing_object(d: dict[str, Any]) -> None:
    d["events"].append({"type": "Collision", "objects": [1, 42], "frame": 5})


def _probabilities_summing_to_half(d: dict[str, Any]) -> None:
    d["objects"][3]["shape"] = {"circle": 0.3, "cube": 0.2}


def _track_cut_to_half_length(d: dict[str, Any]) -> None:
    track = d["objects"][2]["track"]
    for key in ("x", "y", "angle"):
        track[key] = track[key][:15]


#: (how the scene is broken, where the message says it is (object or event, frame, field), what it says,
#: the first problem's (object, event, frame, field)).
MALFORMED = {
    "NaN position": (_nan_position, "object 1, frame 7, field track.y", "nan is not a finite number",
                     (1, None, 7, "track.y")),
    "unknown colour": (_unknown_colour, "object 1, field color.pink", "unknown color 'pink'; allowed: gray",
                       (1, None, None, "color.pink")),
    "event naming a missing object": (_event_naming_a_missing_object, "event 2, frame 5, field objects",
                                      "names object 42, which is not in the scene", (None, 2, 5, "objects")),
    "probabilities summing to 0.5": (_probabilities_summing_to_half, "object 0, field shape",
                                     "probabilities sum to 0.5, not 1", (0, None, None, "shape")),
    "track cut to half length": (_track_cut_to_half_length, "object 1, field track.x",
                                 "the track has 15 frames; a 30-frame video", (1, None, None, "track.x")),
}


def _via_constructor(data: dict[str, Any], tmp_path: Path) -> Any:
    return PerceivedScene(**data)


def _via_model_validate(data: dict[str, Any], tmp_path: Path) -> Any:
    return PerceivedScene.model_validate(data)


def _via_model_validate_json(data: dict[str, Any], tmp_path: Path) -> Any:
    text = json.dumps(data)  # NaN is written as the NaN literal, which pydantic's JSON parser reads
    return PerceivedScene.model_validate_json(text)


def _via_loader(data: dict[str, Any], tmp_path: Path) -> Any:
    path = tmp_path / "p.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return load_perceived(path)


PATHS: dict[str, Callable[[dict[str, Any], Path], Any]] = {
    "constructor": _via_constructor,
    "model_validate": _via_model_validate,
    "model_validate_json": _via_model_validate_json,
    "load_perceived": _via_loader,
}


def _malformed(case: str) -> dict[str, Any]:
    data = tiny_data()
    MALFORMED[case][0](data)
    return data


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("case", MALFORMED)
def test_every_path_raises_the_same_perception_error(case: str, path: str, tmp_path: Path) -> None:
    _, where, what, (obj, event, frame, field) = MALFORMED[case]
    with pytest.raises(PerceptionError) as info:
        PATHS[path](_malformed(case), tmp_path)
    err = info.value
    assert not isinstance(err, ValidationError) and isinstance(err, CraftError)
    source = str(tmp_path / "p.json") if path == "load_perceived" else "perceived scene"
    assert str(err) == f"{source}: {where}: {err.problems[0].message}"
    assert what in str(err)
    problem = err.problems[0]
    assert (problem.object, problem.event, problem.frame, problem.field) == (obj, event, frame, field)


@pytest.mark.parametrize("case", MALFORMED)
def test_the_messages_agree_across_paths_and_with_parse_scene(case: str, tmp_path: Path) -> None:
    messages = set()
    for name, build in PATHS.items():
        with pytest.raises(PerceptionError) as info:
            build(_malformed(case), tmp_path)
        source = str(tmp_path / "p.json") if name == "load_perceived" else "perceived scene"
        messages.add(str(info.value).removeprefix(f"{source}: "))
    with pytest.raises(PerceptionError) as info:
        parse_scene(_malformed(case), "q.json")
    messages.add(str(info.value).removeprefix("q.json: "))
    assert len(messages) == 1


def test_perception_error_is_no_value_error_so_pydantic_passes_it_through() -> None:
    # pydantic turns a ValueError raised in a validator into its ValidationError (losing object, frame and field)
    assert not issubclass(PerceptionError, ValueError | AssertionError)


def test_model_validate_names_the_source_given_in_the_context() -> None:
    with pytest.raises(PerceptionError, match=r"^seen\.json: object 1, frame 7, field track\.y"):
        PerceivedScene.model_validate(_malformed("NaN position"), context={"source": "seen.json"})


def test_structural_defects_and_the_schema_version_are_perception_errors_too(tmp_path: Path) -> None:
    data = tiny_data()
    data["objects"][2]["track"]["x"][3] = "left"
    for build in PATHS.values():
        with pytest.raises(PerceptionError, match=r"objects\[2\]\.track\.x\[3\]"):
            build(copy.deepcopy(data), tmp_path)
    data = tiny_data()
    data["schema_version"] = "2.0"
    for build in PATHS.values():
        with pytest.raises(PerceptionError, match="schema version '2.0' is not readable"):
            build(copy.deepcopy(data), tmp_path)
    with pytest.raises(PerceptionError, match="field video: Input should be a valid dictionary"):
        PerceivedScene(video="x")  # type: ignore[arg-type]
    with pytest.raises(PerceptionError, match="Input should be a valid dictionary or instance of PerceivedScene"):
        PerceivedScene.model_validate([1, 2])


@pytest.mark.parametrize("change, where", [
    ({"video": {"fps": 60, "frames": 30, "steps": 10**12}}, "field video.steps: video.steps 1000000000000 is more"),
    ({"video": {"fps": 1e-300, "frames": 30}}, "field video.frames: 30 frames at 1e-300 fps show more than"),
    ({"video": {"fps": 1e-10, "frames": 10**300}}, "field video.frames"),
    ({"video": {"fps": 60, "frames": 30, "width": 10**400, "height": 10**400}}, "field video.width"),
])
def test_absurd_videos_are_refused_before_anything_is_allocated(change: dict[str, Any], where: str) -> None:
    data = tiny_data()
    data.update(change)
    with pytest.raises(PerceptionError, match=where):
        PerceivedScene.model_validate(data)


def test_values_beyond_a_million_are_refused_like_non_finite_ones() -> None:
    data = tiny_data()
    data["objects"][2]["track"]["vx"] = [0.0] * 29 + [1e300]
    data["objects"][0]["pose"]["x"] = -2e6
    with pytest.raises(PerceptionError) as info:
        PerceivedScene.model_validate(data)
    text = str(info.value)
    assert "object 6, field pose.x: -2000000.0 is out of range; allowed: -1,000,000 to 1,000,000" in text
    assert "object 1, frame 29, field track.vx: 1e+300 is out of range" in text
    scene, dropped = parse_scene(data, lenient=True)
    assert scene.object(6).pose is None and scene.object(1).track is not None
    assert {p.action for p in dropped} == {"pose dropped", "frame dropped"}


# -- one validation per scene: loaders do not check twice, model_copy is not validated ---------------------------


@pytest.fixture
def find_problems_calls(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    original = validation_module.find_problems

    def counting(scene: PerceivedScene) -> list[Any]:
        calls.append(len(scene.objects))
        return original(scene)

    for module in (schema_module, validation_module):  # the model's validator and the loaders
        monkeypatch.setattr(module, "find_problems", counting)
    return calls


def test_loading_and_executing_checks_the_scene_once(find_problems_calls: list[int], tmp_path: Path) -> None:
    path = save_perceived(tiny_scene(), tmp_path / "p.json")
    find_problems_calls.clear()
    scene, _ = load_perceived(path)
    assert len(find_problems_calls) == 1
    SceneModel(scene).simulation()
    most_likely_world(scene)
    assert len(find_problems_calls) == 1  # a scene checked when it was built is not checked again
    PerceivedScene.model_validate_json(path.read_text(encoding="utf-8"))
    PerceivedScene(**json.loads(path.read_text(encoding="utf-8")))
    assert len(find_problems_calls) == 3


def test_model_copy_is_not_validated_but_executing_the_copy_checks_it(find_problems_calls: list[int]) -> None:
    scene = tiny_scene()
    cube = scene.objects[2]
    assert cube.track is not None
    half = cube.track.model_copy(update={k: getattr(cube.track, k)[:15] for k in ("x", "y", "angle")})
    bad = scene.model_copy(update={"objects": [*scene.objects[:2], cube.model_copy(update={"track": half}),
                                               scene.objects[3]]})
    find_problems_calls.clear()
    for run in (most_likely_world, SceneModel):
        with pytest.raises(PerceptionError, match="object 1, field track.x: the track has 15 frames"):
            run(bad)  # no raw IndexError deep in the track code
    with pytest.raises(PerceptionError, match="the track has 15 frames"):
        check_scene(bad)
    with pytest.raises(PerceptionError, match="the track has 15 frames"):
        PerceivedScene.model_validate(bad)  # handing the instance over checks it too
    good = scene.model_copy(update={"meta": {"source": "a copy"}})
    find_problems_calls.clear()
    SceneModel(good)
    SceneModel(good)
    assert len(find_problems_calls) == 1  # checked once, then known to be sound


def test_lenient_loading_still_builds_partial_scenes() -> None:
    data = tiny_data()
    _nan_position(data)
    _unknown_colour(data)
    _event_naming_a_missing_object(data)
    scene, dropped = parse_scene(data, lenient=True)
    assert scene.object(1).color is None and len(dropped) == 3
    most_likely_world(scene)  # the repaired scene (a model_copy) executes


def test_an_object_left_out_of_the_physics_with_perceived_events_raises_no_key_error() -> None:
    data = tiny_data()
    data["objects"][2]["track"].update(x=[None] * 30, y=[None] * 30)  # the cube is never seen: a valid scene
    world = most_likely_world(PerceivedScene.model_validate(data))
    with pytest.raises(CounterfactualUnavailable, match="object 1 has perceived events but is not in the physics"):
        world.counterfactual(0)  # the circle's removal would keep the cube's perceived Collision


# -- properties ------------------------------------------------------------------------------------------------

STATICS = ("ground", "basket", "wall_l", "wall_r", "platform", "ramp", "static_ball")
EVENT_NAMES = ("Collision", "TouchStart", "TouchEnd", "EnterBasket", "StartTouching", "EndTouching",
               "ContainerEndUp", "Start", "End")
_number = st.one_of(st.floats(-300.0, 300.0), st.floats(-1e6, 1e6))
_probability = st.floats(0.0, 1.0)


@st.composite
def _distributions(draw: st.DrawFn, values: tuple[str, ...]) -> dict[str, float]:
    chosen = draw(st.lists(st.sampled_from(values), min_size=1, max_size=3, unique=True))
    weights = [draw(st.floats(0.01, 1.0)) for _ in chosen]
    return {v: w / sum(weights) for v, w in zip(chosen, weights)}


@st.composite
def _tracks(draw: st.DrawFn, n: int, fps: float | None) -> dict[str, Any]:
    def column(values: st.SearchStrategy[Any], holes: bool = True) -> list[Any]:
        return draw(st.lists(st.one_of(st.none(), values) if holes else values, min_size=n, max_size=n))

    track: dict[str, Any] = {"x": column(_number), "y": column(_number)}
    if fps is not None:
        track["fps"] = fps
    if draw(st.booleans()):
        track["angle"] = column(_number)
    if draw(st.booleans()):
        track["visible"] = column(st.booleans(), holes=False)
    if draw(st.booleans()):
        track.update(vx=column(_number), vy=column(_number), angular_velocity=column(_number))
    return track


@st.composite
def scene_data(draw: st.DrawFn) -> dict[str, Any]:
    """Perceived scenes as parsed JSON, valid by construction: any frame rate, missing attributes, flags, tracks
    with holes and at lower rates (empty ones too), poses, perceived events of every type or none."""
    fps = draw(st.sampled_from((60.0, 30.0, 20.0, 7.0, 0.5)))
    steps = draw(st.integers(1, 60))
    frames = int(frame_steps(steps, fps).size)
    if frames == 0:  # too short a run for one frame at this rate
        steps = math.ceil(60 / fps)
        frames = int(frame_steps(steps, fps).size)
    statics = [s for s in ("ground", "basket") if draw(st.integers(0, 9)) > 0]  # a simulation needs both
    statics += draw(st.lists(st.sampled_from(STATICS[2:]), max_size=2))
    n_dynamic = draw(st.integers(0, 3))
    ids = draw(st.lists(st.integers(0, 2**40), min_size=len(statics) + n_dynamic,
                        max_size=len(statics) + n_dynamic, unique=True))
    objects: list[dict[str, Any]] = []
    for oid, shape in zip(ids, statics):
        obj: dict[str, Any] = {"id": oid, "shape": {shape: 1.0}}
        if draw(st.booleans()):
            obj["pose"] = {"x": draw(_number), "y": draw(_number), "angle": draw(_number)}
        if draw(st.integers(0, 4)) == 0:
            obj["dynamic"] = draw(_probability)
        objects.append(obj)
    for oid in ids[len(statics):]:
        obj = {"id": oid}
        for name, values in (("color", COLORS), ("shape", SHAPES), ("size", SIZES)):
            if draw(st.integers(0, 3)) > 0:
                obj[name] = draw(_distributions(values))
        for name in ("dynamic", "moving_start", "moving_end"):
            if draw(st.booleans()):
                obj[name] = draw(_probability)
        where = draw(st.sampled_from(("track", "track", "pose", "none")))
        if where == "track":
            track_fps = draw(st.sampled_from((None, None, 10.0, 0.5)))
            track_fps = None if track_fps is not None and track_fps >= fps else track_fps
            obj["track"] = draw(_tracks(int(frame_steps(steps, track_fps or fps).size), track_fps))
        elif where == "pose":
            obj["pose"] = {"x": draw(_number), "y": draw(_number), "angle": draw(_number)}
        objects.append(obj)
    data: dict[str, Any] = {"video": {"fps": fps, "frames": frames, "steps": steps}, "objects": objects}
    if draw(st.booleans()):
        data["scene"] = draw(st.integers(1, 20))
    basket = [o["id"] for o in objects if o.get("shape") == {"basket": 1.0}]
    if len(ids) >= 2 and draw(st.booleans()):
        events = []
        for _ in range(draw(st.integers(0, 4))):
            kind = draw(st.sampled_from(EVENT_NAMES))
            pair = draw(st.lists(st.sampled_from(ids), min_size=2, max_size=2, unique=True))
            if kind in ("EnterBasket", "ContainerEndUp") and basket and basket[0] not in pair:
                pair[0] = basket[0]
            events.append({"type": kind, "objects": pair, "frame": draw(st.integers(0, frames - 1)),
                           "confidence": draw(_probability)})
        data["events"] = events
    return data


_ODD_VALUES = st.one_of(st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(), st.text(max_size=5),
                        st.just([]), st.just({}), st.just([None]), st.just({"pink": 1.0}))


def _leaves(value: Any, at: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    if isinstance(value, dict):
        return [at] + [p for k, v in value.items() for p in _leaves(v, (*at, k))]
    if isinstance(value, list):
        return [at] + [p for i, v in enumerate(value) for p in _leaves(v, (*at, i))]
    return [at]


@st.composite
def damaged_scene_data(draw: st.DrawFn) -> dict[str, Any]:
    """A valid scene with one value anywhere in it replaced by an odd one (NaN, a string, a huge int, [] ...)."""
    data = draw(scene_data())
    place = draw(st.sampled_from(_leaves(data)[1:]))
    parent = data
    for key in place[:-1]:
        parent = parent[key]
    parent[place[-1]] = draw(_ODD_VALUES)
    return data


@settings(suppress_health_check=[HealthCheck.too_slow])
@given(damaged_scene_data())
def test_building_a_scene_from_any_data_gives_a_scene_or_a_perception_error(data: dict[str, Any]) -> None:
    outcomes = []
    for build in (lambda: PerceivedScene.model_validate(copy.deepcopy(data)),
                  lambda: PerceivedScene(**copy.deepcopy(data)),
                  lambda: parse_scene(copy.deepcopy(data), "perceived scene")[0]):
        try:
            outcomes.append(build().dumps())
        except PerceptionError as err:  # never a ValidationError, a ValueError or an OverflowError
            outcomes.append(str(err))
    assert len(set(outcomes)) == 1  # every path agrees


#: Programs over events, moving flags, attributes and counterfactuals, run on every scene that validated.
PROGRAMS = [Program.parse(text) for text in (
    "Count(FilterCollideGround(Events()))",
    "Exist(FilterMoving(SceneAtStart(), StartSceneStep()))",
    "Count(FilterStationary(SceneAtEnd(), EndSceneStep()))",
    "Count(FilterObjectsFromEvents(FilterEnterBasket(Events())))",
    "QueryColor(Unique(FilterDynamic(SceneAtStart())))",
    "AnyTrue(ExistList(FilterEnterBasketList(GetCounterfactEventsList(FilterDynamic(SceneAtStart())))))",
    'Exist(FilterCollisionWithDynamics(GetCounterfactEvents(Unique(FilterShape(SceneAtStart(), "cube")))))',
)]


@settings(suppress_health_check=[HealthCheck.too_slow])
@given(scene_data(), st.sampled_from(("auto", "perceived", "derived")), st.sampled_from(("replay", "resimulate")))
def test_a_scene_that_validated_runs_without_a_raw_exception(data: dict[str, Any], events: str,
                                                             counterfactual: str) -> None:
    scene = PerceivedScene.model_validate(data)
    assert PerceivedScene.model_validate_json(scene.dumps()) == scene
    options = ExecutionOptions(events=events, counterfactual=counterfactual)  # type: ignore[arg-type]
    # A CraftError (no basket, a counterfactual that cannot be made...) is an answer; any other exception a bug.
    try:
        model = SceneModel(scene, options)
        world = most_likely_world(scene, options)
    except CraftError:
        return
    for program in PROGRAMS:
        with contextlib.suppress(CraftError):
            program.run(world)
    with contextlib.suppress(CraftError):
        answer_distributions(model, PROGRAMS, bound=16, samples=4)
    with contextlib.suppress(CraftError):
        answer_all(model, template_questions(model), distribution=True, bound=16, samples=4)


@st.composite
def exported_scenes(draw: st.DrawFn) -> PerceivedScene:
    sim = draw(st.one_of(simulations(), simulations(live=True, steps=60)))
    fps = draw(st.sampled_from((60.0, 30.0, 20.0, 12.0)))
    scene = export_perceived(sim, fps=fps, size=draw(st.sampled_from((64, 256))), velocities=draw(st.booleans()))
    if draw(st.booleans()):
        noise = NoiseModel(position_sigma_px=draw(st.floats(0, 3)), attribute_confusion=draw(st.floats(0, 0.3)),
                           event_miss_rate=draw(st.floats(0, 0.3)), event_false_alarm_rate=draw(st.floats(0, 0.3)),
                           gap_rate=draw(st.floats(0, 1)), identity_swap_rate=draw(st.floats(0, 1)))
        scene = degrade(scene, noise, draw(st.integers(0, 2**32 - 1)))
    return scene


@settings(suppress_health_check=[HealthCheck.too_slow])
@given(exported_scenes())
def test_a_valid_exported_scene_round_trips_through_model_validate_unchanged(scene: PerceivedScene) -> None:
    data = scene.to_json()
    again = PerceivedScene.model_validate(data)
    assert again == scene and again.dumps() == scene.dumps()
    assert data == scene.to_json()  # validation does not change its input
    assert PerceivedScene.model_validate_json(scene.dumps()) == scene
    assert PerceivedScene(**data) == scene
    assert parse_scene(json.loads(scene.dumps())) == (scene, [])
