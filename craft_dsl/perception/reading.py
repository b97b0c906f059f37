"""Readings of a perceived scene: one concrete value for every uncertain attribute, flag and event.

The *most likely reading* takes the most probable value of each attribute distribution (ties: the first listed),
a flag when its probability is at least 1/2, and every event whose confidence is at least 1/2. What a missing
field means:

==================  =========================================================================================
missing field       meaning
==================  =========================================================================================
``color``           dynamic object: "unknown" in the most likely reading (no colour filter keeps it;
                    QueryColor answers "unknown"), uniform over the 8 colours in the answer distribution;
                    static object: black
``size``            the same with the 2 sizes (static: large)
``shape``           the same with the 3 dynamic shapes; a static object without a shape is left out of the
                    physics (its role, e.g. the basket, is unknown)
``dynamic``         0 if the most likely shape is a static element, else 1
``moving_start``,   from the track (the fitted initial velocity, the last rows' velocity); without a track the
``moving_end``      object is not moving
``events``          derived from the tracks and the scene geometry (:mod:`craft_dsl.perception.events`)
==================  =========================================================================================

Static shapes are never enumerated: an object whose most likely shape is a static element keeps it in every
reading, so the ground and the basket keep their roles.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from ..vocabulary import COLORS, SHAPES, SIZES, STATIC_COLOR, STATIC_SIZE
from .schema import STATIC_SHAPE_NAMES, PerceivedObject, PerceivedScene
from .validation import most_likely

#: The value of an attribute the model did not give, in the most likely reading.
UNKNOWN = "unknown"
#: Probability at or above which a flag holds and an event is taken as happened in the most likely reading.
DECISION_THRESHOLD = 0.5


@dataclass(frozen=True)
class ObjectReading:
    """One object's attributes in a reading."""

    id: int
    color: str
    shape: str
    size: str
    dynamic: bool


@dataclass(frozen=True)
class Reading:
    """One concrete reading of a scene: objects, moving flags, and which perceived events happened."""

    objects: tuple[ObjectReading, ...]
    moving_start: frozenset[int]
    moving_end: frozenset[int]
    events: frozenset[int]

    def object(self, object_id: int) -> ObjectReading:
        for o in self.objects:
            if o.id == object_id:
                return o
        raise KeyError(object_id)


def is_static_shape(shape: str | None) -> bool:
    return shape in STATIC_SHAPE_NAMES


def dynamic_probability(obj: PerceivedObject) -> float:
    """P(dynamic): the model's, else 0 for a static-element shape, else 1."""
    if obj.dynamic is not None:
        return obj.dynamic
    return 0.0 if is_static_shape(most_likely(obj.shape)) else 1.0


def attribute_distribution(obj: PerceivedObject, name: str) -> dict[str, float]:
    """The distribution used by the answer distribution for attribute ``name`` (missing fields: see above)."""
    given: dict[str, float] | None = getattr(obj, name)
    shape = most_likely(obj.shape)
    if name == "shape" and is_static_shape(shape):
        assert shape is not None
        return {shape: 1.0}
    if given:
        total = sum(given.values())
        return {k: v / total for k, v in given.items() if v > 0}
    static = is_static_shape(shape) or (obj.dynamic is not None and obj.dynamic < DECISION_THRESHOLD)
    if static:
        default = {"color": STATIC_COLOR, "size": STATIC_SIZE, "shape": UNKNOWN}[name]
        return {default: 1.0}
    values = {"color": COLORS, "size": SIZES, "shape": SHAPES}[name]
    return {v: 1.0 / len(values) for v in values}


def most_likely_attribute(obj: PerceivedObject, name: str) -> str:
    given: dict[str, float] | None = getattr(obj, name)
    if given:
        value = most_likely(given)
        assert value is not None
        return value
    dist = attribute_distribution(obj, name)
    return next(iter(dist)) if len(dist) == 1 else UNKNOWN


def most_likely_objects(scene: PerceivedScene) -> tuple[ObjectReading, ...]:
    return tuple(
        ObjectReading(o.id, most_likely_attribute(o, "color"), most_likely_attribute(o, "shape"),
                      most_likely_attribute(o, "size"), dynamic_probability(o) >= DECISION_THRESHOLD)
        for o in sorted(scene.objects, key=lambda o: o.id)
    )


def most_likely_reading(scene: PerceivedScene, moving_start: Mapping[int, float],
                        moving_end: Mapping[int, float]) -> Reading:
    """The most likely reading, given each object's probability of moving at the start and at the end."""
    objects = most_likely_objects(scene)
    dynamic = {o.id for o in objects if o.dynamic}
    return Reading(
        objects=objects,
        moving_start=frozenset(i for i, p in moving_start.items() if p >= DECISION_THRESHOLD and i in dynamic),
        moving_end=frozenset(i for i, p in moving_end.items() if p >= DECISION_THRESHOLD and i in dynamic),
        events=frozenset(i for i, e in enumerate(scene.events or ()) if e.confidence >= DECISION_THRESHOLD),
    )
