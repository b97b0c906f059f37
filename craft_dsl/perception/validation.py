"""Checking a perceived scene: every defect named by object, frame and field; strict or lenient loading.

Strict (the default): any defect raises :class:`~craft_dsl.errors.PerceptionError` listing them. Lenient: the bad
parts are dropped and listed, and the rest is kept:

==========================================  =====================================================================
defect                                      lenient action
==========================================  =====================================================================
an attribute distribution with an unknown   the distribution is dropped (the attribute is then unknown)
value, a probability outside [0, 1] or not
finite, or probabilities not summing to 1
a probability flag outside [0, 1]           the flag is dropped
a pose with a number that is not finite or  the pose is dropped
beyond 1,000,000 in magnitude
a track frame with a NaN or infinite value  that frame is dropped (all its values become null, visible false)
or one beyond 1,000,000 in magnitude
track lists of different lengths, or a      the track is dropped
track whose length does not match the
video's frame count at the track's rate
an object id used twice                     the later object is dropped
an unknown event type, an event naming      the event is dropped
unknown objects, a frame outside the video,
a bad confidence
an object or event that does not fit the    that object or event is dropped
schema at all (wrong types)
==========================================  =====================================================================

Defects of the scene as a whole (not JSON, wrong schema version, a non-square video, a video wider than 65,536
pixels or a run longer than 216,000 steps) are errors in both modes.

Every way of building a :class:`PerceivedScene` runs the strict checks: the constructor, ``model_validate``,
``model_validate_json`` and :func:`parse_scene` / :func:`load_perceived` all go through :func:`validate_scene` (the
model's validator), so a scene that exists has been checked, and a defect raises the same
:class:`~craft_dsl.errors.PerceptionError` (never pydantic's ``ValidationError``) whatever the path. Only pydantic's
explicit bypasses (``model_copy(update=...)``, ``model_construct``) and changes made in place skip them;
:func:`check_scene` checks such a scene, and :class:`~craft_dsl.perception.world.SceneModel` checks every scene it
executes that was not checked when built (:func:`checked`; a scene checked when built is not checked twice).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ..errors import PerceptionError
from .schema import (  # the checks live beside the model they validate; re-exported here
    _TRACK_VALUE_FIELDS,
    DEFAULT_SOURCE,
    MAX_MAGNITUDE,
    MAX_STEPS,
    MAX_WIDTH,
    SOURCE_KEY,
    SUM_TOLERANCE,
    PerceivedEvent,
    PerceivedObject,
    PerceivedScene,
    Problem,
    Track,
    _error,
    _structure_problems,
    checked,
    find_problems,
    most_likely,
    validate_scene,
)

__all__ = [
    "DEFAULT_SOURCE", "MAX_MAGNITUDE", "MAX_STEPS", "MAX_WIDTH", "SOURCE_KEY", "SUM_TOLERANCE", "Problem",
    "check_scene", "checked", "find_problems", "load_perceived", "most_likely", "parse_scene", "repair",
    "save_perceived", "validate_scene",
]


# -- lenient repair ------------------------------------------------------------------------------------------


def _blank_frames(track: Track, frames: set[int]) -> Track:
    update: dict[str, Any] = {}
    for name in _TRACK_VALUE_FIELDS:
        values = getattr(track, name)
        if values is not None:
            update[name] = [None if k in frames else v for k, v in enumerate(values)]
    visible = track.visible if track.visible is not None else [True] * track.length
    update["visible"] = [False if k in frames else v for k, v in enumerate(visible)]
    return track.model_copy(update=update)


def repair(scene: PerceivedScene, problems: Iterable[Problem]) -> PerceivedScene:
    """``scene`` with the parts named by ``problems`` dropped (see the module docstring)."""
    problems = list(problems)
    by_object: dict[int, list[Problem]] = {}
    for p in problems:
        if p.object is not None:
            by_object.setdefault(p.object, []).append(p)
    bad_events = {p.event for p in problems if p.event is not None}
    objects = []
    seen: set[int] = set()
    for obj in scene.objects:
        if obj.id in seen:
            continue
        seen.add(obj.id)
        update: dict[str, Any] = {}
        frames: set[int] = set()
        for p in by_object.get(obj.id, ()):
            top = p.field.split(".")[0]
            if p.action == "track dropped":
                update["track"] = None
            elif p.action == "frame dropped" and p.frame is not None:
                frames.add(p.frame)
            elif top in ("color", "shape", "size", "dynamic", "moving_start", "moving_end", "pose"):
                update[top] = None
        if frames and "track" not in update and obj.track is not None:
            update["track"] = _blank_frames(obj.track, frames)
        objects.append(obj.model_copy(update=update) if update else obj)
    events = scene.events
    if events is not None:
        events = [e for i, e in enumerate(events) if i not in bad_events]
    return scene.model_copy(update={"objects": objects, "events": events})


def _parse_items(raw: Any, parse: Callable[[Any], Any], field: str, is_event: bool,
                 problems: list[Problem]) -> list[Any]:
    if not isinstance(raw, list):
        raise PerceptionError(f"field {field}: expected a list, got {type(raw).__name__}")
    kept = []
    for i, item in enumerate(raw):
        try:
            kept.append(parse(item))
        except ValidationError as err:
            oid = item.get("id") if isinstance(item, dict) and isinstance(item.get("id"), int) else None
            problems += _structure_problems(err, f"{field}[{i}]", None if is_event else oid,
                                            i if is_event else None,
                                            "event dropped" if is_event else "object dropped")
    return kept


def parse_scene(data: Any, source: str = DEFAULT_SOURCE, lenient: bool = False
                ) -> tuple[PerceivedScene, list[Problem]]:
    """A checked :class:`PerceivedScene` from parsed JSON, and the problems lenient mode dropped (else [])."""
    if not isinstance(data, dict):
        raise PerceptionError(f"{source}: a perceived scene is a JSON object, got {type(data).__name__}")
    context = {SOURCE_KEY: source}
    if not lenient:  # the model's validator runs every check (once)
        return PerceivedScene.model_validate(data, context=context), []
    dropped: list[Problem] = []
    head = {k: v for k, v in data.items() if k not in ("objects", "events")}
    # the header alone: only the schema version, structure and video can be wrong, all fatal
    scene = PerceivedScene.model_validate(head, context=context)
    objects = _parse_items(data.get("objects", []), PerceivedObject.model_validate, "objects", False, dropped)
    events = None
    if data.get("events") is not None:
        events = _parse_items(data["events"], PerceivedEvent.model_validate, "events", True, dropped)
    # model_copy does not validate: the parts kept are checked (and the bad ones dropped) just below
    scene = scene.model_copy(update={"objects": objects, "events": events})
    problems = find_problems(scene)
    fatal = [p for p in problems if not p.action]
    if fatal:
        raise _error(source, fatal)
    return repair(scene, problems), dropped + problems


def check_scene(scene: PerceivedScene, source: str = DEFAULT_SOURCE, lenient: bool = False
                ) -> tuple[PerceivedScene, list[Problem]]:
    """Check a scene that skipped validation (made by ``model_copy(update=...)``, ``model_construct`` or changed in
    place): strict raises on any defect; lenient drops the bad parts and lists them."""
    problems = find_problems(scene)
    if problems and (not lenient or any(not p.action for p in problems)):
        raise _error(source, [p for p in problems if not lenient or not p.action])
    return (repair(scene, problems) if problems else scene), problems


def load_perceived(path: str | Path, lenient: bool = False) -> tuple[PerceivedScene, list[Problem]]:
    """Read a perceived-scene JSON file; returns the scene and what lenient mode dropped (else [])."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as err:
        raise PerceptionError(f"cannot read perceived scene {p}: {err.strerror}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise PerceptionError(f"{p}: not valid JSON (line {err.lineno}, column {err.colno}): {err.msg}") from None
    return parse_scene(data, str(p), lenient)


def save_perceived(scene: PerceivedScene, path: str | Path) -> Path:
    """Write ``scene`` as JSON atomically (canonical bytes: the same scene gives the same file)."""
    from ..atomic import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(scene.dumps(), encoding="utf-8")
    return Path(path)
