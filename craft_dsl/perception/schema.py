"""What a perception model writes about one CRAFT video: the :class:`PerceivedScene` (pydantic, versioned).

Coordinates are those of the video as :mod:`craft_dsl.render` draws it: pixels of a square frame (256 x 256 by
default), column ``x`` to the right and row ``y`` downwards from the top-left corner, angles in radians
counter-clockwise as seen in the video. Frame ``k`` (0-based) of a video at ``fps`` frames per second shows the
state after ``round((k + 1) * 60 / fps)`` physics steps (the renderer's rule; there is no frame of the initial
state). Every field a model cannot give may be left out; ``docs/perception.md`` says what each execution mode then
does. The structure and the semantics (known attribute values, probabilities summing to 1, track lengths, finite
numbers, known objects) are both checked here, by the model's own validator (:func:`validate_scene`);
:mod:`craft_dsl.perception.validation` adds lenient loading and the file reader and writer. Every way of building a
:class:`PerceivedScene` (constructor, ``model_validate``, ``model_validate_json``, the file loader) runs both and
raises :class:`~craft_dsl.errors.PerceptionError` naming object, frame and field.
"""

from __future__ import annotations

import json
import math
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ModelWrapValidatorHandler,
    ValidationError,
    ValidationInfo,
    model_validator,
)

from ..errors import PerceptionError
from ..render.raster import frame_steps
from ..vocabulary import COLORS, END, ENTER_BASKET, SHAPES, SIZES, START, STATIC_COLOR, canonical_event_type

#: The schema version written by this release ("major.minor"); files of the same major version are read.
SCHEMA_VERSION = "1.0"

#: Static shapes a perceived scene may name (the elements of the 20 CRAFT layouts).
STATIC_SHAPE_NAMES: tuple[str, ...] = ("ground", "wall_l", "wall_r", "basket", "platform", "ramp", "static_ball")
#: Allowed values of each perceived attribute.
ATTRIBUTE_VALUES: dict[str, tuple[str, ...]] = {
    "color": COLORS + (STATIC_COLOR,),
    "shape": SHAPES + STATIC_SHAPE_NAMES,
    "size": SIZES,
}

Distribution = dict[str, float]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class VideoInfo(_Model):
    """The video the scene was perceived from."""

    fps: float = Field(default=60.0, gt=0, le=60,
                       description="frames per second (the simulator steps at 60 per second)")
    frames: int = Field(default=600, ge=1, description="number of frames")
    steps: int | None = Field(default=None, ge=1,
                              description="physics steps of the run (default round(frames * 60 / fps))")
    width: int = Field(default=256, ge=8, description="frame width in pixels (the view is 50 m wide)")
    height: int = Field(default=256, ge=8, description="frame height in pixels (must equal the width)")


class Pose(_Model):
    """Where an object that never moves is: its reference point in pixels and its angle."""

    x: float = Field(description="column of the reference point (pixels)")
    y: float = Field(description="row of the reference point (pixels, downwards)")
    angle: float = Field(default=0.0, description="radians, counter-clockwise as seen in the video")


class Track(_Model):
    """Per-frame observations of one object; every list has one entry per track frame."""

    fps: float | None = Field(default=None, gt=0, le=60, description="frame rate of the track (default: the video's)")
    x: list[float | None] = Field(description="column of the reference point per frame (pixels); null: not seen")
    y: list[float | None] = Field(description="row of the reference point per frame (pixels, downwards)")
    angle: list[float | None] | None = Field(default=None,
                                             description="radians, counter-clockwise as seen in the video")
    visible: list[bool] | None = Field(default=None,
                                       description="whether the object is seen in the frame (default: all)")
    vx: list[float | None] | None = Field(default=None, description="velocity, pixels per second to the right")
    vy: list[float | None] | None = Field(default=None, description="velocity, pixels per second downwards")
    angular_velocity: list[float | None] | None = Field(default=None,
                                                        description="radians per second, counter-clockwise")

    @property
    def length(self) -> int:
        return len(self.x)


class PerceivedObject(_Model):
    """One object: attribute distributions, static/dynamic, and where it is."""

    id: int = Field(ge=0, description="the model's object id (events refer to it)")
    color: Distribution | None = Field(default=None, description="probability of each colour (gray ... yellow, black)")
    shape: Distribution | None = Field(default=None,
                                       description="probability of each shape (cube, triangle, circle, or a static "
                                                   "element: ground, wall_l, wall_r, basket, platform, ramp, "
                                                   "static_ball)")
    size: Distribution | None = Field(default=None, description="probability of each size (small, large)")
    dynamic: float | None = Field(default=None, description="probability that the object is dynamic (can move)")
    moving_start: float | None = Field(default=None, description="probability that it moves in the first state")
    moving_end: float | None = Field(default=None, description="probability that it moves in the last state")
    pose: Pose | None = Field(default=None, description="position of an object that never moves")
    track: Track | None = Field(default=None, description="per-frame positions of an object")


class PerceivedEvent(_Model):
    """One event the model saw."""

    type: str = Field(description="Collision, TouchStart, TouchEnd, EnterBasket (original names accepted); "
                                  "Start and End are implied and ignored")
    objects: list[int] = Field(default_factory=list, description="the two object ids (EnterBasket: basket and body)")
    frame: int = Field(description="0-based video frame at which the event is first seen")
    confidence: float = Field(default=1.0, description="probability that the event happened")


class PerceivedScene(_Model):
    """Everything a perception model saw in one CRAFT video."""

    # (The docstring above is the JSON Schema's description.) Building a scene checks it whole, see _checked.

    schema_version: str = Field(default=SCHEMA_VERSION, description="'major.minor' of this schema")
    scene: int | None = Field(default=None, ge=1, le=20, description="the CRAFT scene layout (1-20), if known")
    video: VideoInfo = Field(default_factory=VideoInfo)
    objects: list[PerceivedObject] = Field(default_factory=list)
    events: list[PerceivedEvent] | None = Field(
        default=None,
        description="the events seen; null or absent: the model gives none (they are derived from tracks)")
    physics: Literal["pymunk", "box2d"] | None = Field(
        default=None,
        description="the physics engine whose runs reproduce the video best (a reader measures it against the "
                    "frames); runs without an object are re-simulated with it. Null or absent: the executor's "
                    "default (box2d)")
    meta: dict[str, Any] = Field(default_factory=dict, description="free-form provenance")

    @model_validator(mode="wrap")
    @classmethod
    def _checked(cls, data: Any, handler: ModelWrapValidatorHandler[PerceivedScene],
                 info: ValidationInfo) -> PerceivedScene:
        """Every way of building a scene (constructor, ``model_validate``, ``model_validate_json``, the loader)
        runs :func:`validate_scene`: a defect raises
        :class:`~craft_dsl.errors.PerceptionError` naming object, frame and field (pydantic passes it through, as
        it is no ValueError). ``model_validate(data, context={"source": "p.json"})`` names the source in the
        message (default ``"perceived scene"``)."""
        return validate_scene(data, handler, info.context)

    @property
    def steps(self) -> int:
        """Physics steps of the run the video shows."""
        if self.video.steps is not None:
            return self.video.steps
        return int(round(self.video.frames * 60 / self.video.fps))

    def object(self, object_id: int) -> PerceivedObject:
        for o in self.objects:
            if o.id == object_id:
                return o
        raise KeyError(object_id)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (None fields left out)."""
        data: dict[str, Any] = self.model_dump(mode="json", exclude_none=True)
        return data

    def dumps(self) -> str:
        """Canonical JSON text (the same scene gives the same bytes)."""
        return json.dumps(self.to_json(), indent=1, allow_nan=False) + "\n"


def json_schema() -> dict[str, Any]:
    """The JSON Schema of :class:`PerceivedScene` (written to ``docs/perceived_scene.schema.json``)."""
    schema: dict[str, Any] = PerceivedScene.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = f"CRAFT perceived scene, schema version {SCHEMA_VERSION}"
    return schema


def json_schema_text() -> str:
    return json.dumps(json_schema(), indent=2, sort_keys=True) + "\n"


# -- checks: the model's validator -----------------------------------------------------------------------

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
