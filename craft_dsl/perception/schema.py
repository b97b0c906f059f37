"""What a perception model writes about one CRAFT video: the :class:`PerceivedScene` (pydantic, versioned).

Coordinates are those of the video as :mod:`craft_dsl.render` draws it: pixels of a square frame (256 x 256 by
default), column ``x`` to the right and row ``y`` downwards from the top-left corner, angles in radians
counter-clockwise as seen in the video. Frame ``k`` (0-based) of a video at ``fps`` frames per second shows the
state after ``round((k + 1) * 60 / fps)`` physics steps (the renderer's rule; there is no frame of the initial
state). Every field a model cannot give may be left out; ``docs/perception.md`` says what each execution mode then
does. The structure is checked here; the semantics (known attribute values, probabilities summing to 1, track
lengths, finite numbers, known objects) by :mod:`craft_dsl.perception.validation`. Every way of building a
:class:`PerceivedScene` (constructor, ``model_validate``, ``model_validate_json``, the file loader) runs both and
raises :class:`~craft_dsl.errors.PerceptionError` naming object, frame and field.
"""

from __future__ import annotations

import json
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ModelWrapValidatorHandler, ValidationInfo, model_validator

from ..vocabulary import COLORS, SHAPES, SIZES, STATIC_COLOR

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
        runs :func:`craft_dsl.perception.validation.validate_scene`: a defect raises
        :class:`~craft_dsl.errors.PerceptionError` naming object, frame and field (pydantic passes it through, as
        it is no ValueError). ``model_validate(data, context={"source": "p.json"})`` names the source in the
        message (default ``"perceived scene"``)."""
        from .validation import validate_scene  # validation imports this module

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
