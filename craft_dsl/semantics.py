"""Implementations of the functional modules.

Every function takes the simulation first, then its inputs, then its side inputs, and never sees
INVALID (the evaluator propagates it). Values: Object = int id; ObjectSet = tuple of ids in ascending
order; Event = :class:`~craft_dsl.simulation.Event`; EventSet = tuple of events in (step, id) order;
*List types = tuples of those; Bool, Integer, and strings for colours, shapes and sizes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .simulation import Event, Simulation
from .types import INVALID, _Invalid
from .vocabulary import COLLISION, ENTER_BASKET

ObjectSet = tuple[int, ...]
EventSet = tuple[Event, ...]

# -- scenes and steps ----------------------------------------------------------------------------


def scene_at_start(sim: Simulation) -> ObjectSet:
    return sim.all_ids


def scene_at_end(sim: Simulation) -> ObjectSet:
    return sim.all_ids


def start_scene_step(sim: Simulation) -> int:
    return 0


def end_scene_step(sim: Simulation) -> int:
    return -1


def events(sim: Simulation) -> EventSet:
    return sim.events


# -- object filters ---------------------------------------------------------------------------------


def filter_color(sim: Simulation, objs: ObjectSet, color: str) -> ObjectSet:
    color_of = sim.color_of
    return tuple([o for o in objs if color_of[o] == color])


def filter_shape(sim: Simulation, objs: ObjectSet, shape: str) -> ObjectSet:
    shape_of = sim.shape_of
    return tuple([o for o in objs if shape_of[o] == shape])


def filter_size(sim: Simulation, objs: ObjectSet, size: str) -> ObjectSet:
    size_of = sim.size_of
    return tuple([o for o in objs if size_of[o] == size])


def filter_dynamic(sim: Simulation, objs: ObjectSet) -> ObjectSet:
    dyn = sim.dynamic_ids
    return tuple([o for o in objs if o in dyn])


def filter_moving(sim: Simulation, objs: ObjectSet, state_index: int) -> ObjectSet:
    moving = sim.moving(state_index)
    return tuple([o for o in objs if o in moving])


def filter_stationary(sim: Simulation, objs: ObjectSet, state_index: int) -> ObjectSet:
    moving = sim.moving(state_index)
    return tuple([o for o in objs if o not in moving])


def unique(sim: Simulation, objs: ObjectSet) -> int | _Invalid:
    return objs[0] if len(objs) == 1 else INVALID


def as_list(sim: Simulation, obj: int) -> ObjectSet:
    return (obj,)


# -- queries ------------------------------------------------------------------------------------------


def query_color(sim: Simulation, obj: int) -> str:
    return sim.color_of[obj]


def query_shape(sim: Simulation, obj: int) -> str:
    return sim.shape_of[obj]


def query_size(sim: Simulation, obj: int) -> str:
    return sim.size_of[obj]


# -- set algebra ----------------------------------------------------------------------------------------


def intersect(sim: Simulation, a: ObjectSet, b: ObjectSet) -> ObjectSet:
    bs = set(b)
    return tuple([o for o in a if o in bs])


def union(sim: Simulation, a: ObjectSet, b: ObjectSet) -> ObjectSet:
    return tuple(sorted(set(a).union(b)))


def difference(sim: Simulation, a: ObjectSet, b: ObjectSet) -> ObjectSet:
    bs = set(b)
    return tuple([o for o in a if o not in bs])


def intersect_list(sim: Simulation, sets: tuple[ObjectSet, ...], b: ObjectSet) -> tuple[ObjectSet, ...]:
    bs = set(b)
    return tuple([tuple([o for o in s if o in bs]) for s in sets])


# -- counting and logic -------------------------------------------------------------------------------------


def count(sim: Simulation, items: tuple[object, ...]) -> int:
    return len(items)


def exist(sim: Simulation, items: tuple[object, ...]) -> bool:
    return len(items) > 0


def exist_list(sim: Simulation, lists: tuple[tuple[object, ...], ...]) -> tuple[bool, ...]:
    return tuple([len(s) > 0 for s in lists])


def any_true(sim: Simulation, flags: tuple[bool, ...]) -> bool:
    return True in flags


def any_false(sim: Simulation, flags: tuple[bool, ...]) -> bool:
    return False in flags


def equal(sim: Simulation, a: object, b: object) -> bool:
    return a == b


def less_than(sim: Simulation, a: int, b: int) -> bool:
    return a < b


def greater_than(sim: Simulation, a: int, b: int) -> bool:
    return a > b


# -- event filters -------------------------------------------------------------------------------------------
#
# Filters applied to a simulation's whole event list (Events(), GetCounterfactEvents(o)) are memoised on the
# simulation that owns the list: programs filter the same lists again and again.


def _memoised(sim: Simulation, evs: EventSet, key: Any, compute: Callable[[Simulation, EventSet], Any]) -> Any:
    owner = sim.owner_of(evs)
    if owner is None:
        return compute(sim, evs)
    memo = owner.memo
    found = memo.get(key)
    if found is None:
        found = memo[key] = compute(owner, evs)
    return found



def _filter_events(sim: Simulation, evs: EventSet, obj: int) -> EventSet:
    return tuple([e for e in evs if obj in e.objects])


def filter_events(sim: Simulation, evs: EventSet, obj: int) -> EventSet:
    return _memoised(sim, evs, ("events_of", obj), lambda s, x: _filter_events(s, x, obj))


def _collisions(sim: Simulation, evs: EventSet) -> EventSet:
    return tuple([e for e in evs if e.type == COLLISION])


def filter_collision(sim: Simulation, evs: EventSet) -> EventSet:
    return _memoised(sim, evs, "collisions", _collisions)


def _collisions_with_dynamics(sim: Simulation, evs: EventSet) -> EventSet:
    dyn = sim.dynamic_ids
    return tuple([e for e in evs if e.type == COLLISION and e.objects and all([o in dyn for o in e.objects])])


def filter_collision_with_dynamics(sim: Simulation, evs: EventSet) -> EventSet:
    return _memoised(sim, evs, "collisions_with_dynamics", _collisions_with_dynamics)


def _collide_with(evs: EventSet, target: int) -> EventSet:
    return tuple([e for e in evs if e.type == COLLISION and target in e.objects])


def _ground_collisions(sim: Simulation, evs: EventSet) -> EventSet:
    return _collide_with(evs, sim.ground_id)


def _basket_collisions(sim: Simulation, evs: EventSet) -> EventSet:
    return _collide_with(evs, sim.basket_id)


def filter_collide_ground(sim: Simulation, evs: EventSet) -> EventSet:
    return _memoised(sim, evs, "ground_collisions", _ground_collisions)


def filter_collide_basket(sim: Simulation, evs: EventSet) -> EventSet:
    return _memoised(sim, evs, "basket_collisions", _basket_collisions)


def _basket_entries(sim: Simulation, evs: EventSet) -> EventSet:
    return tuple([e for e in evs if e.type == ENTER_BASKET])


def filter_enter_basket(sim: Simulation, evs: EventSet) -> EventSet:
    return _memoised(sim, evs, "basket_entries", _basket_entries)


def filter_collide_ground_list(sim: Simulation, lists: tuple[EventSet, ...]) -> tuple[EventSet, ...]:
    return tuple([filter_collide_ground(sim, evs) for evs in lists])


def filter_collide_basket_list(sim: Simulation, lists: tuple[EventSet, ...]) -> tuple[EventSet, ...]:
    return tuple([filter_collide_basket(sim, evs) for evs in lists])


def filter_enter_basket_list(sim: Simulation, lists: tuple[EventSet, ...]) -> tuple[EventSet, ...]:
    return tuple([filter_enter_basket(sim, evs) for evs in lists])


def filter_first(sim: Simulation, evs: EventSet) -> Event | _Invalid:
    return evs[0] if evs else INVALID


def filter_last(sim: Simulation, evs: EventSet) -> Event | _Invalid:
    return evs[-1] if evs else INVALID


def filter_before(sim: Simulation, evs: EventSet, ref: Event) -> EventSet:
    return tuple([e for e in evs if e.step < ref.step])


def filter_after(sim: Simulation, evs: EventSet, ref: Event) -> EventSet:
    return tuple([e for e in evs if e.step > ref.step])


def is_before(sim: Simulation, a: Event, b: Event) -> bool:
    return a.step < b.step


def is_after(sim: Simulation, a: Event, b: Event) -> bool:
    return a.step > b.step


def event_partner(sim: Simulation, ev: Event, obj: int) -> int | _Invalid:
    objs = ev.objects
    if len(objs) != 2 or obj not in objs:
        return INVALID
    return objs[1] if objs[0] == obj else objs[0]


def _objects_of(evs: EventSet) -> ObjectSet:
    return tuple(sorted({o for e in evs for o in e.objects}))


def filter_objects_from_events(sim: Simulation, evs: EventSet) -> ObjectSet:
    return _memoised(sim, evs, "objects", lambda s, x: _objects_of(x))


def filter_objects_from_events_list(sim: Simulation, lists: tuple[EventSet, ...]) -> tuple[ObjectSet, ...]:
    return tuple([filter_objects_from_events(sim, evs) for evs in lists])


# -- counterfactuals -----------------------------------------------------------------------------------------


def get_counterfact_events(sim: Simulation, obj: int) -> EventSet:
    return sim.counterfactual(obj).events


def get_counterfact_events_list(sim: Simulation, objs: ObjectSet) -> tuple[EventSet, ...]:
    return tuple([sim.counterfactual(o).events for o in objs])
