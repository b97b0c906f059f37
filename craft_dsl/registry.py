"""The module registry: the single source of truth for every functional module.

Each :class:`ModuleSpec` gives the canonical (paper) name, its overloads (input types -> output type,
with the original engine's name for that overload), side inputs, a one-line description, the
implementation, and the original snake_case aliases with their argument order. The type checker, the
node-list importer/exporter, the CLI's ``modules`` listing and docs/modules.md all read this table.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from . import semantics as sem
from .types import DslType as T

Impl = Callable[..., Any]


@dataclass(frozen=True)
class Overload:
    """One signature of a module. ``original`` is the original engine's name for it (None: no such node)."""

    inputs: tuple[T, ...]
    output: T
    original: str | None


@dataclass(frozen=True)
class ModuleSpec:
    """A functional module of the DSL."""

    name: str
    overloads: tuple[Overload, ...]
    impl: Impl
    description: str
    category: str
    side_inputs: tuple[T, ...] = ()
    aliases: tuple[str, ...] = ()
    #: Original node input order as indexes into our inputs (None = same order).
    original_order: tuple[int, ...] | None = None
    #: Whether the module can return INVALID on valid inputs (Unique of a set whose size is not 1, ...).
    may_invalidate: bool = False
    #: Number of inputs (side inputs not counted); derived from the overloads.
    n_inputs: int = field(init=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "n_inputs", len(self.overloads[0].inputs))

    @property
    def arity(self) -> int:
        return len(self.overloads[0].inputs) + len(self.side_inputs)

    def signature_text(self) -> str:
        parts = []
        for ov in self.overloads:
            args = ", ".join([str(t) for t in ov.inputs] + [f'"{t}"' for t in self.side_inputs])
            parts.append(f"{self.name}({args}) -> {ov.output}")
        return " | ".join(parts)


def _m(name: str, inputs: tuple[T, ...], output: T, impl: Impl, description: str, category: str,
       original: str | None, side_inputs: tuple[T, ...] = (), aliases: tuple[str, ...] = (),
       original_order: tuple[int, ...] | None = None, may_invalidate: bool = False) -> ModuleSpec:
    return ModuleSpec(name, (Overload(inputs, output, original),), impl, description, category,
                      side_inputs, aliases or ((original,) if original else ()), original_order, may_invalidate)


_OS, _O, _OSL = T.OBJECT_SET, T.OBJECT, T.OBJECT_SET_LIST
_E, _ES, _ESL = T.EVENT, T.EVENT_SET, T.EVENT_SET_LIST
_I, _B, _BL = T.INTEGER, T.BOOL, T.BOOL_LIST

MODULES: tuple[ModuleSpec, ...] = (
    # scenes and steps
    _m("SceneAtStart", (), _OS, sem.scene_at_start, "All objects of the first frame (static ones included).",
       "scene", "start_scene"),
    _m("SceneAtEnd", (), _OS, sem.scene_at_end, "All objects of the last frame (static ones included).",
       "scene", "end_scene"),
    _m("StartSceneStep", (), _I, sem.start_scene_step, "Index of the start state (0), for FilterMoving.",
       "scene", "start_scene_step"),
    _m("EndSceneStep", (), _I, sem.end_scene_step, "Index of the end state (-1), for FilterMoving.",
       "scene", "end_scene_step"),
    _m("Events", (), _ES, sem.events, "All events of the video, Start and End included, in time order.",
       "events", "events"),
    # object filters
    _m("FilterColor", (_OS,), _OS, sem.filter_color, "Objects of the given colour.", "objects",
       "filter_color", (T.COLOR,)),
    _m("FilterShape", (_OS,), _OS, sem.filter_shape, "Objects of the given shape (never static ones).",
       "objects", "filter_shape", (T.SHAPE,)),
    _m("FilterSize", (_OS,), _OS, sem.filter_size, "Objects of the given size.", "objects",
       "filter_size", (T.SIZE,)),
    _m("FilterDynamic", (_OS,), _OS, sem.filter_dynamic, "Dynamic objects only.", "objects",
       "filter_dynamic_objects"),
    _m("FilterMoving", (_OS, _I), _OS, sem.filter_moving,
       "Objects moving (|vx| or |vy| > 0.001) in the given state.", "objects", "filter_moving_objects"),
    _m("FilterStationary", (_OS, _I), _OS, sem.filter_stationary,
       "Objects not moving in the given state (static ones included).", "objects",
       "filter_stationary_objects"),
    _m("Unique", (_OS,), _O, sem.unique, "The single object of a set; INVALID unless the set has one.",
       "objects", "unique", may_invalidate=True),
    _m("AsList", (_O,), _OS, sem.as_list, "The set holding just this object.", "objects", "as_list"),
    # queries
    _m("QueryColor", (_O,), T.COLOR, sem.query_color, "Colour of an object.", "query", "query_color"),
    _m("QueryShape", (_O,), T.SHAPE, sem.query_shape, "Shape of an object.", "query", "query_shape"),
    _m("QuerySize", (_O,), T.SIZE, sem.query_size, "Size of an object.", "query", "query_size"),
    # set algebra
    _m("Intersect", (_OS, _OS), _OS, sem.intersect, "Objects in both sets.", "sets", "intersect"),
    _m("Union", (_OS, _OS), _OS, sem.union, "Objects in either set.", "sets", "union"),
    _m("Difference", (_OS, _OS), _OS, sem.difference, "Objects of the first set not in the second.",
       "sets", "difference"),
    _m("IntersectList", (_OSL, _OS), _OSL, sem.intersect_list, "Intersect every set of a list with a set.",
       "sets", "intersect_list"),
    # counting and logic
    ModuleSpec("Count", (Overload((_OS,), _I, "count"), Overload((_ES,), _I, "count")), sem.count,
               "Number of objects or events in a set.", "logic", aliases=("count",)),
    ModuleSpec("Exist", (Overload((_OS,), _B, "exist"), Overload((_ES,), _B, "event_exist")), sem.exist,
               "Whether a set of objects or events is non-empty.", "logic",
               aliases=("exist", "event_exist")),
    ModuleSpec("ExistList", (Overload((_OSL,), _BL, "exist_list"), Overload((_ESL,), _BL, "exist_list")),
               sem.exist_list, "Non-emptiness of every set of a list.", "logic", aliases=("exist_list",)),
    _m("AnyTrue", (_BL,), _B, sem.any_true, "Whether any flag is true (false for an empty list).", "logic",
       "any_true"),
    _m("AnyFalse", (_BL,), _B, sem.any_false, "Whether any flag is false (false for an empty list).",
       "logic", "any_false"),
    _m("EqualColor", (T.COLOR, T.COLOR), _B, sem.equal, "Whether two colours are equal.", "compare",
       "equal_color"),
    _m("EqualShape", (T.SHAPE, T.SHAPE), _B, sem.equal, "Whether two shapes are equal.", "compare",
       "equal_shape"),
    _m("EqualSize", (T.SIZE, T.SIZE), _B, sem.equal, "Whether two sizes are equal.", "compare",
       "equal_size"),
    _m("EqualInteger", (_I, _I), _B, sem.equal, "Whether two integers are equal.", "compare",
       "equal_integer"),
    _m("EqualObject", (_O, _O), _B, sem.equal, "Whether two objects are the same object.", "compare",
       "equal_object"),
    _m("LessThan", (_I, _I), _B, sem.less_than, "Whether the first integer is smaller.", "compare",
       "less_than"),
    _m("GreaterThan", (_I, _I), _B, sem.greater_than, "Whether the first integer is larger.", "compare",
       "greater_than"),
    # events
    _m("FilterEvents", (_ES, _O), _ES, sem.filter_events, "Events that involve the object.", "events",
       "filter_events"),
    _m("FilterCollision", (_ES,), _ES, sem.filter_collision, "Collision events (short contacts).",
       "events", "filter_collision"),
    _m("FilterCollisionWithDynamics", (_ES,), _ES, sem.filter_collision_with_dynamics,
       "Collisions between two dynamic objects.", "events", "filter_collision_with_dynamics"),
    _m("FilterCollideGround", (_ES,), _ES, sem.filter_collide_ground, "Collisions with the ground.",
       "events", "filter_collide_ground"),
    _m("FilterCollideGroundList", (_ESL,), _ESL, sem.filter_collide_ground_list,
       "FilterCollideGround on every set of a list.", "events", "filter_collide_ground_list"),
    _m("FilterCollideBasket", (_ES,), _ES, sem.filter_collide_basket, "Collisions with the basket.",
       "events", "filter_collide_basket"),
    _m("FilterCollideBasketList", (_ESL,), _ESL, sem.filter_collide_basket_list,
       "FilterCollideBasket on every set of a list.", "events", "filter_collide_basket_list"),
    _m("FilterEnterBasket", (_ES,), _ES, sem.filter_enter_basket, "Events of an object entering the basket.",
       "events", "filter_enter_container"),
    _m("FilterEnterBasketList", (_ESL,), _ESL, sem.filter_enter_basket_list,
       "FilterEnterBasket on every set of a list.", "events", "filter_enter_container_list"),
    _m("FilterBefore", (_ES, _E), _ES, sem.filter_before, "Events strictly before the reference event's step.",
       "events", "filter_before"),
    _m("FilterAfter", (_ES, _E), _ES, sem.filter_after, "Events strictly after the reference event's step.",
       "events", "filter_after"),
    _m("FilterFirst", (_ES,), _E, sem.filter_first, "The earliest event; INVALID for an empty set.",
       "events", "filter_first", may_invalidate=True),
    _m("FilterLast", (_ES,), _E, sem.filter_last, "The latest event; INVALID for an empty set.", "events",
       "filter_last", may_invalidate=True),
    _m("IsBefore", (_E, _E), _B, sem.is_before, "Whether the first event's step is strictly earlier.",
       "events", "is_before"),
    _m("IsAfter", (_E, _E), _B, sem.is_after, "Whether the first event's step is strictly later.",
       "events", "is_after"),
    _m("EventPartner", (_E, _O), _O, sem.event_partner,
       "The other object of a two-object event; INVALID if the object is not in it.", "events",
       "event_partner", original_order=(1, 0), may_invalidate=True),
    _m("FilterObjectsFromEvents", (_ES,), _OS, sem.filter_objects_from_events,
       "Objects taking part in any of the events (static partners included).", "events",
       "filter_objects_from_events"),
    _m("FilterObjectsFromEventsList", (_ESL,), _OSL, sem.filter_objects_from_events_list,
       "FilterObjectsFromEvents on every set of a list.", "events", "filter_objects_from_events_list"),
    # counterfactuals
    _m("GetCounterfactEvents", (_O,), _ES, sem.get_counterfact_events,
       "Events of the same video re-simulated without the object.", "counterfactual", "counterfact_events"),
    _m("GetCounterfactEventsList", (_OS,), _ESL, sem.get_counterfact_events_list,
       "GetCounterfactEvents for every object of a set.", "counterfactual", "counterfact_events_list"),
)

#: Canonical name -> spec.
REGISTRY: dict[str, ModuleSpec] = {m.name: m for m in MODULES}
#: Canonical name -> implementation (the evaluator's hot path).
IMPLS: dict[str, Impl] = {m.name: m.impl for m in MODULES}
#: Canonical names of the modules that can return INVALID on valid inputs.
MAY_INVALIDATE: frozenset[str] = frozenset(m.name for m in MODULES if m.may_invalidate)
#: Any accepted name (canonical or alias) -> spec.
NAMES: dict[str, ModuleSpec] = {**{a: m for m in MODULES for a in m.aliases}, **REGISTRY}

#: Original CLEVR modules that CRAFT registers but that cannot work on CRAFT scenes.
UNSUPPORTED_ORIGINAL = {
    "relate": "CRAFT scenes carry no spatial relationships",
    "same_color": "the original indexes by list position, not object id",
    "same_shape": "the original indexes by list position, not object id",
    "same_size": "the original indexes by list position, not object id",
    "filter_objectcategory": "CRAFT objects have no object category",
}


def lookup(name: str) -> ModuleSpec | None:
    """The spec for a canonical or alias name, or None."""
    return NAMES.get(name)


def suggest(name: str, n: int = 3) -> list[str]:
    """The nearest known module names, best first (case-insensitive)."""
    lowered = {k.lower(): k for k in NAMES}
    hits = difflib.get_close_matches(name.lower(), list(lowered), n=n, cutoff=0.5)
    out: list[str] = []
    for h in hits:
        canonical = NAMES[lowered[h]].name
        if canonical not in out:
            out.append(canonical)
    return out
