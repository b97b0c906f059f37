"""The perceived-scene schema: validation, every bad-input case (strict and lenient), the committed JSON Schema."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from perception_helpers import tiny_data, tiny_scene

from craft_dsl.cli import main
from craft_dsl.errors import CraftError, PerceptionError
from craft_dsl.perception import PerceivedScene, check_scene, load_perceived, parse_scene, save_perceived
from craft_dsl.perception.schema import SCHEMA_VERSION, json_schema_text

ROOT = Path(__file__).resolve().parents[1]


def test_a_sound_scene_loads_and_round_trips_byte_for_byte(tmp_path: Path) -> None:
    scene = tiny_scene()
    path = save_perceived(scene, tmp_path / "p.json")
    loaded, dropped = load_perceived(path)
    assert dropped == []
    assert loaded == scene
    assert loaded.dumps() == path.read_text(encoding="utf-8")
    assert loaded.schema_version == SCHEMA_VERSION
    assert loaded.steps == 30


def test_committed_json_schema_is_up_to_date() -> None:
    committed = (ROOT / "docs" / "perceived_scene.schema.json").read_text(encoding="utf-8")
    assert committed == json_schema_text(), "run: craft-dsl perceive schema --out docs/perceived_scene.schema.json"
    schema = json.loads(committed)
    assert "schema_version" in schema["properties"]
    assert {"objects", "events", "video", "scene"} <= set(schema["properties"])


def _strict_error(data: dict[str, Any]) -> PerceptionError:
    with pytest.raises(PerceptionError) as info:
        parse_scene(data, "p.json")
    assert isinstance(info.value, CraftError)
    return info.value


def test_unknown_attribute_value_names_object_and_field_and_lists_allowed() -> None:
    data = tiny_data()
    data["objects"][2]["color"] = {"pink": 1.0}
    err = _strict_error(data)
    assert "object 1" in str(err) and "field color.pink" in str(err)
    assert "allowed: gray, red, blue" in str(err)
    scene, dropped = parse_scene(data, lenient=True)
    assert scene.object(1).color is None  # dropped: the colour is now unknown
    assert [p.field for p in dropped] == ["color.pink"] and dropped[0].action == "color dropped"


def test_probabilities_not_summing_to_one() -> None:
    data = tiny_data()
    data["objects"][3]["shape"] = {"circle": 0.5, "cube": 0.3}
    err = _strict_error(data)
    assert "object 0" in str(err) and "field shape" in str(err) and "sum to 0.8" in str(err)
    scene, dropped = parse_scene(data, lenient=True)
    assert scene.object(0).shape is None and len(dropped) == 1


def test_probability_outside_unit_interval() -> None:
    data = tiny_data()
    data["objects"][2]["dynamic"] = 1.5
    err = _strict_error(data)
    assert "object 1, field dynamic" in str(err)
    scene, _ = parse_scene(data, lenient=True)
    assert scene.object(1).dynamic is None


def test_tracks_of_different_lengths() -> None:
    data = tiny_data()
    data["objects"][2]["track"]["x"] = data["objects"][2]["track"]["x"][:-1]
    err = _strict_error(data)
    assert "object 1" in str(err) and "field track.y" in str(err) and "29" in str(err)
    data = tiny_data()
    for key in ("x", "y", "angle"):
        data["objects"][3]["track"][key] = data["objects"][3]["track"][key] + [1.0]
    err = _strict_error(data)
    assert "object 0" in str(err) and "31 frames" in str(err) and "30 frames" in str(err)
    scene, dropped = parse_scene(data, lenient=True)
    assert scene.object(0).track is None and dropped[0].action == "track dropped"
    assert scene.object(1).track is not None


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_nan_or_infinite_position_names_object_frame_and_field(bad: float) -> None:
    data = tiny_data()
    data["objects"][2]["track"]["y"][7] = bad
    err = _strict_error(data)
    assert "object 1, frame 7, field track.y" in str(err) and "not a finite number" in str(err)
    assert err.problems[0].object == 1 and err.problems[0].frame == 7
    scene, dropped = parse_scene(data, lenient=True)
    track = scene.object(1).track
    assert track is not None and track.x[7] is None and track.y[7] is None and track.visible is not None
    assert track.visible[7] is False and sum(track.visible) == 29
    assert dropped[0].action == "frame dropped"


def test_json_nan_literal_is_caught_too(tmp_path: Path) -> None:
    data = tiny_data()
    data["objects"][3]["track"]["x"][0] = math.nan
    text = json.dumps(data)  # Python writes the NaN literal that many JSON writers emit
    assert "NaN" in text
    path = tmp_path / "p.json"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(PerceptionError, match="object 0, frame 0, field track.x"):
        load_perceived(path)


def test_events_naming_unknown_objects() -> None:
    data = tiny_data()
    data["events"].append({"type": "Collision", "objects": [1, 42], "frame": 5})
    err = _strict_error(data)
    assert "event 2, frame 5, field objects" in str(err) and "object 42" in str(err)
    scene, dropped = parse_scene(data, lenient=True)
    assert scene.events is not None and len(scene.events) == 2 and dropped[0].action == "event dropped"


@pytest.mark.parametrize("event, field", [
    ({"type": "Bump", "objects": [1, 0], "frame": 5}, "type"),
    ({"type": "Collision", "objects": [1], "frame": 5}, "objects"),
    ({"type": "Collision", "objects": [1, 0], "frame": 30}, "frame"),
    ({"type": "Collision", "objects": [1, 0], "frame": 5, "confidence": 2.0}, "confidence"),
    ({"type": "EnterBasket", "objects": [1, 0], "frame": 5}, "objects"),
])
def test_other_bad_events(event: dict[str, Any], field: str) -> None:
    data = tiny_data()
    data["events"].append(event)
    err = _strict_error(data)
    assert f"event 2, frame {event['frame']}, field {field}" in str(err)


def test_structural_errors_are_named_and_lenient_drops_the_object() -> None:
    data = tiny_data()
    data["objects"][2]["track"]["x"][3] = "left"
    err = _strict_error(data)
    assert "objects[2].track.x[3]" in str(err)
    scene, dropped = parse_scene(data, lenient=True)
    assert 1 not in {o.id for o in scene.objects} and dropped[0].action == "object dropped"
    assert dropped[0].object == 1 and dropped[0].frame == 3


def test_duplicate_ids_and_scene_level_defects() -> None:
    data = tiny_data()
    data["objects"].append(dict(data["objects"][2]))
    assert "used twice" in str(_strict_error(data))
    scene, _ = parse_scene(data, lenient=True)
    assert len(scene.objects) == 4
    for key, value, message in (("schema_version", "2.0", "schema version '2.0'"),
                                ("video", {"fps": 60, "frames": 30, "width": 256, "height": 128}, "square")):
        data = tiny_data()
        data[key] = value
        with pytest.raises(PerceptionError, match=message):
            parse_scene(data, lenient=True)  # not droppable


def test_several_problems_are_all_listed() -> None:
    data = tiny_data()
    data["objects"][2]["color"] = {"pink": 1.0}
    data["objects"][3]["track"]["x"][2] = math.nan
    err = _strict_error(data)
    assert "2 problems" in str(err) and len(err.problems) == 2


def test_check_scene_for_scenes_built_in_python() -> None:
    scene = tiny_scene()
    bad = scene.model_copy(update={"objects": [*scene.objects[:2],
                                               scene.objects[2].model_copy(update={"size": {"huge": 1.0}}),
                                               scene.objects[3]]})
    with pytest.raises(PerceptionError, match="unknown size 'huge'"):
        check_scene(bad)
    fixed, problems = check_scene(bad, lenient=True)
    assert fixed.object(1).size is None and len(problems) == 1
    assert isinstance(fixed, PerceivedScene)


def test_cli_check_exits_2_naming_the_problem(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tiny_data()
    data["objects"][2]["track"]["x"][4] = math.inf
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    assert main(["perceive", "check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "object 1, frame 4, field track.x" in err
    assert main(["perceive", "check", str(path), "--lenient", "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["dropped"] == ["object 1, frame 4, field track.x: inf is not a finite number "
                                                   "(frame dropped)"]
    assert "dropped: object 1, frame 4" in captured.err
