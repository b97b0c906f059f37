"""A question's premise as evidence about the scene.

A CRAFT question is asked only of a video that holds the objects it names ("the small red cube" is there, and is
the only one). When a program is INVALID in every reading of the perceived scene, the perception has most likely
misread one of those objects: at a low resolution a small cube shows as a circle, a red body as brown. The readings
that change one object's colour, shape or size, or two of them (every object keeping a distinct (colour, shape,
size)), are tried from the most probable down, and the first in which the program has a value is taken. A reading's
probability relative to the most likely one is the product of the changed attributes' probability ratios, each
probability at least :data:`PROBABILITY_FLOOR` (a reading the perception gave no weight can still be the one the
question names); among equally probable readings, nearer colours first (a red body is read as brown sooner than as
yellow).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace

from ..errors import CraftError
from ..program import Program
from ..types import INVALID
from ..vocabulary import COLOR_RGB, COLORS, SHAPES, SIZES
from .reading import ObjectReading, Reading, attribute_distribution
from .world import SceneModel

#: The least probability an attribute value counts with (the perception's own may be 0).
PROBABILITY_FLOOR = 1e-3
#: The most attributes of the one object a premise reading changes.
MAX_CHANGES = 2
#: The values each attribute may be changed to.
ATTRIBUTE_VALUES: dict[str, tuple[str, ...]] = {"color": tuple(COLORS), "shape": tuple(SHAPES),
                                                 "size": tuple(SIZES)}


@dataclass(frozen=True)
class PremiseReading:
    """The reading near the most likely one that gives the program a value: one object read otherwise."""

    object_id: int
    #: The attributes changed: name -> (value in the most likely reading, value in this one).
    changes: tuple[tuple[str, str, str], ...]
    #: log of the reading's probability relative to the most likely reading (<= 0 unless a most likely value was
    #: floored).
    log_ratio: float
    value: object

    def describe(self) -> str:
        read = ", ".join(f"{now} instead of {was}" for _name, was, now in self.changes)
        return f"object {self.object_id} read as {read}, as the question names it"


def premise_reading(model: SceneModel, program: Program) -> PremiseReading | None:
    """The most probable reading that differs from the most likely one in at most :data:`MAX_CHANGES` attributes of
    one object and in which ``program`` has a value (among equally probable readings, the one whose changes are the
    most alike, then objects by id and values in vocabulary order); None if there is none."""
    base = model.most_likely_reading()
    perceived = {o.id: o for o in model.scene.objects}
    triples = {o.id: (o.color, o.shape, o.size) for o in base.objects if o.dynamic}
    candidates: list[tuple[float, float, int, int, ObjectReading, tuple[tuple[str, str, str], ...]]] = []
    for obj in sorted(base.objects, key=lambda o: o.id):
        if not obj.dynamic or obj.id not in perceived:
            continue
        others = {t for i, t in triples.items() if i != obj.id}
        dists = {name: attribute_distribution(perceived[obj.id], name) for name in ATTRIBUTE_VALUES}
        for color, shape, size in itertools.product(*ATTRIBUTE_VALUES.values()):
            now = {"color": color, "shape": shape, "size": size}
            changes = tuple((name, getattr(obj, name), now[name]) for name in ATTRIBUTE_VALUES
                            if now[name] != getattr(obj, name))
            if not changes or len(changes) > MAX_CHANGES or (color, shape, size) in others:
                continue  # (two objects never share all three attributes)
            log_ratio = sum(math.log(max(dists[name].get(new, 0.0), PROBABILITY_FLOOR))
                            - math.log(max(dists[name].get(was, 0.0), PROBABILITY_FLOOR))
                            for name, was, new in changes)
            changed = replace(obj, color=color, shape=shape, size=size)
            candidates.append((-log_ratio, _likeness(changes), len(candidates), obj.id, changed, changes))
    candidates.sort(key=lambda c: c[:3])
    for neg_ratio, _likeness_cost, _order, object_id, changed, changes in candidates:
        value = _value(model, _with_object(base, changed), program)
        if value is not INVALID:
            return PremiseReading(object_id, changes, -neg_ratio, value)
    return None


def _likeness(changes: tuple[tuple[str, str, str], ...]) -> float:
    """How unlike the changed values are (the order among equally probable readings): a colour by the distance of
    the two colours (RGB, over 255; red for brown 0.24, red for yellow 0.86), a shape or a size 0.5."""
    cost = 0.0
    for name, was, now in changes:
        if name == "color" and was in COLOR_RGB and now in COLOR_RGB:
            cost += math.dist(COLOR_RGB[was], COLOR_RGB[now]) / 255.0
        else:
            cost += 0.5
    return cost


def _with_object(reading: Reading, changed: ObjectReading) -> Reading:
    return replace(reading, objects=tuple(changed if o.id == changed.id else o for o in reading.objects))


def _value(model: SceneModel, reading: Reading, program: Program) -> object:
    try:
        return program.run(model.simulation(reading))
    except CraftError:
        return INVALID
