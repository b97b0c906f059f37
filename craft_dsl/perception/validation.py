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
import math
import weakref
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ..errors import PerceptionError
from ..render.raster import frame_steps
from ..vocabulary import END, ENTER_BASKET, START, canonical_event_type
from .schema import (
    ATTRIBUTE_VALUES,
    SCHEMA_VERSION,
    PerceivedEvent,
    PerceivedObject,
    PerceivedScene,
    Track,
)

#: The longest run a perceived scene may show, in physics steps (an hour of video; CRAFT runs are 600 steps).
MAX_STEPS = 216_000
#: The widest video a perceived scene may come from, in pixels.
MAX_WIDTH = 65_536
#: The largest magnitude of a position (pixels), angle (radians) or velocity (per second) in a pose or track: a
#: thousand frame widths and more is no observation (and would overflow the physics).
MAX_MAGNITUDE = 1e6
#: Attribute probabilities must sum to 1 within this tolerance (models write float32 softmax outputs).
SUM_TOLERANCE = 1e-3
_TRACK_VALUE_FIELDS = ("x", "y", "angle", "vx", "vy", "angular_velocity")
_TRACK_FIELDS = _TRACK_VALUE_FIELDS + ("visible",)
_MAX_LISTED = 5
#: How an error names a scene that came from no file (the constructor, ``model_validate``...).
DEFAULT_SOURCE = "perceived scene"
#: The pydantic validation-context key naming the scene's source in error messages:
#: ``PerceivedScene.model_validate(data, context={SOURCE_KEY: "p.json"})``.
SOURCE_KEY = "source"


@dataclass(frozen=True)
class Problem:
    """One defect of a perceived scene: where (object id or event index, frame, field) and what."""

    message: str
    object: int | None = None
    event: int | None = None
    frame: int | None = None
    field: str = ""
    #: What lenient loading does about it (also the text of the "dropped" list).
    action: str = ""

    def where(self) -> str:
        parts = []
        if self.object is not None:
            parts.append(f"object {self.object}")
        if self.event is not None:
            parts.append(f"event {self.event}")
        if self.frame is not None:
            parts.append(f"frame {self.frame}")
        if self.field:
            parts.append(f"field {self.field}")
        return ", ".join(parts) or "scene"

    def __str__(self) -> str:
        return f"{self.where()}: {self.message}" + (f" ({self.action})" if self.action else "")


def _error(source: str, problems: Sequence[Problem]) -> PerceptionError:
    shown = "; ".join(f"{p.where()}: {p.message}" for p in problems[:_MAX_LISTED])
    more = f" (and {len(problems) - _MAX_LISTED} more)" if len(problems) > _MAX_LISTED else ""
    count = f"{len(problems)} problems: " if len(problems) > 1 else ""
    return PerceptionError(f"{source}: {count}{shown}{more}", problems)


# -- semantic checks -----------------------------------------------------------------------------------------


def _finite(value: float | None) -> bool:
    return value is not None and math.isfinite(value)


def _bad_number(v: float) -> str:
    """What is wrong with a pose or track value outside [-MAX_MAGNITUDE, MAX_MAGNITUDE]."""
    if not math.isfinite(v):
        return f"{v!r} is not a finite number"
    return f"{v!r} is out of range; allowed: -{MAX_MAGNITUDE:,.0f} to {MAX_MAGNITUDE:,.0f}"


def _check_distribution(obj: PerceivedObject, name: str, dist: dict[str, float]) -> list[Problem]:
    allowed = ATTRIBUTE_VALUES[name]
    action = f"{name} dropped"
    out = []
    if not dist:
        return [Problem(f"empty {name} distribution; give at least one of {', '.join(allowed)}", obj.id,
                        field=name, action=action)]
    for value, p in dist.items():
        if value not in allowed:
            out.append(Problem(f"unknown {name} {value!r}; allowed: {', '.join(allowed)}", obj.id,
                               field=f"{name}.{value}", action=action))
        if not _finite(p) or not 0.0 <= p <= 1.0:
            out.append(Problem(f"probability {p!r} is not a number in [0, 1]", obj.id, field=f"{name}.{value}",
                               action=action))
    total = sum(p for p in dist.values() if _finite(p))
    if not out and abs(total - 1.0) > SUM_TOLERANCE:
        out.append(Problem(f"probabilities sum to {total:.6g}, not 1 (tolerance {SUM_TOLERANCE:g})", obj.id,
                           field=name, action=action))
    return out


def _check_track(obj: PerceivedObject, track: Track, scene: PerceivedScene) -> list[Problem]:
    n = track.length
    for name in _TRACK_FIELDS[1:]:
        values = getattr(track, name)
        if values is not None and len(values) != n:
            return [Problem(f"track.{name} has {len(values)} entries but track.x has {n}; every list of a track "
                            "has one entry per track frame", obj.id, field=f"track.{name}", action="track dropped")]
    fps = track.fps or scene.video.fps
    expected = int(frame_steps(scene.steps, fps).size) if fps <= 60 else -1
    if n != expected:
        return [Problem(f"the track has {n} frames; a {scene.video.frames}-frame video at {scene.video.fps:g} fps "
                        f"({scene.steps} steps) has {expected} frames at the track's {fps:g} fps; every track must "
                        "cover the whole video", obj.id, field="track.x", action="track dropped")]
    out = []
    lo, hi = -MAX_MAGNITUDE, MAX_MAGNITUDE
    for name in _TRACK_VALUE_FIELDS:
        values = getattr(track, name)
        if values is None:
            continue
        # (the hot loop of validation: a comprehension; the test is False for NaN too)
        for k in [k for k, v in enumerate(values) if v is not None and not lo <= v <= hi]:
            out.append(Problem(_bad_number(values[k]), obj.id, frame=k, field=f"track.{name}",
                               action="frame dropped"))
    return out


def _check_object(obj: PerceivedObject, scene: PerceivedScene) -> list[Problem]:
    out: list[Problem] = []
    for name in ("color", "shape", "size"):
        dist = getattr(obj, name)
        if dist is not None:
            out += _check_distribution(obj, name, dist)
    for name in ("dynamic", "moving_start", "moving_end"):
        p = getattr(obj, name)
        if p is not None and (not math.isfinite(p) or not 0.0 <= p <= 1.0):
            out.append(Problem(f"probability {p!r} is not a number in [0, 1]", obj.id, field=name,
                               action=f"{name} dropped"))
    if obj.pose is not None:
        for name in ("x", "y", "angle"):
            v = getattr(obj.pose, name)
            if not -MAX_MAGNITUDE <= v <= MAX_MAGNITUDE:
                out.append(Problem(_bad_number(v), obj.id, field=f"pose.{name}", action="pose dropped"))
    if obj.track is not None:
        out += _check_track(obj, obj.track, scene)
    return out


def most_likely(dist: dict[str, float] | None) -> str | None:
    """The most probable value of a distribution (ties: the first listed), or None."""
    if not dist:
        return None
    return max(dist, key=lambda k: dist[k])


def _check_event(index: int, e: PerceivedEvent, scene: PerceivedScene, ids: set[int],
                 basket_ids: set[int]) -> list[Problem]:
    action = "event dropped"
    try:
        kind = canonical_event_type(e.type)
    except ValueError as err:
        return [Problem(str(err), event=index, frame=e.frame, field="type", action=action)]
    if kind in (START, END):
        return []
    out = []
    unknown = [o for o in e.objects if o not in ids]
    if unknown:
        out.append(Problem(f"{kind} names object {unknown[0]}, which is not in the scene (objects: {sorted(ids)})",
                           event=index, frame=e.frame, field="objects", action=action))
    elif len(e.objects) != 2 or e.objects[0] == e.objects[1]:
        out.append(Problem(f"{kind} needs two different objects, got {e.objects}", event=index, frame=e.frame,
                           field="objects", action=action))
    elif kind == ENTER_BASKET and basket_ids and not basket_ids & set(e.objects):
        out.append(Problem(f"EnterBasket names objects {e.objects}, none of which is the basket "
                           f"(id {sorted(basket_ids)[0]})", event=index, frame=e.frame, field="objects",
                           action=action))
    if not 0 <= e.frame < scene.video.frames:
        out.append(Problem(f"frame {e.frame} is outside the video (frames 0..{scene.video.frames - 1})",
                           event=index, frame=e.frame, field="frame", action=action))
    if not math.isfinite(e.confidence) or not 0.0 <= e.confidence <= 1.0:
        out.append(Problem(f"confidence {e.confidence!r} is not a number in [0, 1]", event=index, frame=e.frame,
                           field="confidence", action=action))
    return out


def _check_video(scene: PerceivedScene) -> list[Problem]:
    video = scene.video
    out = []
    if video.width != video.height:
        out.append(Problem(f"the video is {video.width} x {video.height} pixels; CRAFT videos are square",
                           field="video.height"))
    if video.width > MAX_WIDTH:
        out.append(Problem(f"the video is {video.width} pixels wide; allowed: at most {MAX_WIDTH}",
                           field="video.width"))
    try:
        steps = scene.steps
    except OverflowError:  # round(frames * 60 / fps) of an absurd frame count or rate
        steps = MAX_STEPS + 1
    if steps > MAX_STEPS:
        if video.steps is not None:
            out.append(Problem(f"video.steps {video.steps} is more than {MAX_STEPS} steps (an hour at 60 steps per "
                               "second; CRAFT runs are 600 steps)", field="video.steps"))
        else:
            out.append(Problem(f"{video.frames} frames at {video.fps:g} fps show more than {MAX_STEPS} steps (an hour "
                               "at 60 steps per second; CRAFT runs are 600 steps); give video.steps or fix "
                               "video.frames", field="video.frames"))
        return out
    expected = int(frame_steps(steps, video.fps).size)
    if expected != video.frames:
        out.append(Problem(f"{video.frames} frames at {video.fps:g} fps cannot show a run of {scene.steps} steps "
                           f"(that takes {expected} frames); give video.steps or fix video.frames",
                           field="video.frames"))
    return out


def find_problems(scene: PerceivedScene) -> list[Problem]:
    """Every semantic defect of ``scene`` (empty if it is sound). Problems without an ``action`` concern the
    scene as a whole and cannot be dropped."""
    out: list[Problem] = _check_video(scene)
    if out:
        return out
    seen: set[int] = set()
    for i, obj in enumerate(scene.objects):
        if obj.id in seen:
            out.append(Problem(f"object id {obj.id} is used twice (objects[{i}]); ids must be unique", obj.id,
                               field="id", action="later object dropped"))
            continue
        seen.add(obj.id)
        out += _check_object(obj, scene)
    basket_ids = {o.id for o in scene.objects if most_likely(o.shape) == "basket"}
    for i, e in enumerate(scene.events or ()):
        out += _check_event(i, e, scene, seen, basket_ids)
    return out


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


# -- parsing and loading -------------------------------------------------------------------------------------


def _loc_text(loc: Sequence[int | str]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _structure_problems(err: ValidationError, prefix: str, object_id: int | None = None,
                        event: int | None = None, action: str = "") -> list[Problem]:
    out = []
    for e in err.errors():
        loc = list(e["loc"])
        frame = None
        if len(loc) >= 3 and loc[0] == "track" and isinstance(loc[2], int):
            frame = loc[2]
        field = _loc_text(loc)
        if prefix and object_id is None and event is None:
            field = f"{prefix}.{field}" if field else prefix
        out.append(Problem(f"{e['msg']} (got {e.get('input')!r})", object_id, event, frame, field, action))
    return out


def _check_header(data: dict[str, Any], source: str) -> None:
    version = data.get("schema_version", SCHEMA_VERSION)
    if not isinstance(version, str) or version.split(".")[0] != SCHEMA_VERSION.split(".")[0]:
        raise _error(source, [Problem(f"schema version {version!r} is not readable by this release; allowed: "
                                      f"{SCHEMA_VERSION.split('.')[0]}.x (current {SCHEMA_VERSION})",
                                      field="schema_version")])


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


def _source(context: Any) -> str:
    source = context.get(SOURCE_KEY) if isinstance(context, dict) else None
    return source if isinstance(source, str) else DEFAULT_SOURCE


# The scenes validate_scene passed, by identity and weakly (an entry goes when its scene is freed), so that executing
# a scene that was checked when built does not check it again. A copy made by model_copy is another object.
_VALIDATED: dict[int, weakref.ReferenceType[PerceivedScene]] = {}


def _remember(scene: PerceivedScene) -> None:
    key = id(scene)
    _VALIDATED[key] = weakref.ref(scene, lambda _ref: _VALIDATED.pop(key, None))


def _was_validated(scene: PerceivedScene) -> bool:
    ref = _VALIDATED.get(id(scene))
    return ref is not None and ref() is scene


def validate_scene(data: Any, handler: Callable[[Any], PerceivedScene], context: Any = None) -> PerceivedScene:
    """The checks every :class:`PerceivedScene` passes, whatever builds it (the model's wrap validator calls this).

    ``data`` is what pydantic was handed (a dict, or a scene), ``handler`` pydantic's own validation of it and
    ``context`` the validation context (:data:`SOURCE_KEY` names the source in messages). Raises
    :class:`~craft_dsl.errors.PerceptionError` naming object, frame and field: for a schema version this release
    cannot read, for a structural defect (pydantic's errors, each located) and for every semantic defect
    (:func:`find_problems`)."""
    source = _source(context)
    if isinstance(data, dict):
        _check_header(data, source)
    try:
        scene = handler(data)
    except ValidationError as err:
        raise _error(source, _structure_problems(err, "")) from None
    problems = find_problems(scene)
    if problems:
        raise _error(source, problems)
    _remember(scene)
    return scene


def checked(scene: PerceivedScene, source: str = DEFAULT_SOURCE) -> PerceivedScene:
    """``scene`` itself, once it is known to be sound: a scene that passed validation when it was built is not
    checked again; one that skipped it (``model_copy(update=...)``, ``model_construct``) is checked now, strictly.
    (A scene changed in place after it was built is not noticed: build a new one, or use :func:`check_scene`.)"""
    if not _was_validated(scene):
        problems = find_problems(scene)
        if problems:
            raise _error(source, problems)
        _remember(scene)
    return scene


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
