"""Implementations of the functional modules.

Every function takes the simulation first, then its inputs, then its side inputs, and never sees
INVALID (the evaluator propagates it). Values: Object = int id; ObjectSet = tuple of ids in ascending
order; Event = :class:`~craft_dsl.simulation.Event`; EventSet = tuple of events in (step, id) order;
*List types = tuples of those; Bool, Integer, and strings for colours, shapes and sizes.
"""

from __future__ import annotations

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
    by_id = sim._by_id
    return tuple(o for o in objs if by_id[o].color == color)


def filter_shape(sim: Simulation, objs: ObjectSet, shape: str) -> ObjectSet:
    by_id = sim._by_id
    return tuple(o for o in objs if by_id[o].shape == shape)


def filter_size(sim: Simulation, objs: ObjectSet, size: str) -> ObjectSet:
    by_id = sim._by_id
    return tuple(o for o in objs if by_id[o].size == size)


def filter_dynamic(sim: Simulation, objs: ObjectSet) -> ObjectSet:
    dyn = sim.dynamic_ids
    return tuple(o for o in objs if o in dyn)


def filter_moving(sim: Simulation, objs: ObjectSet, state_index: int) -> ObjectSet:
    moving = sim.moving(state_index)
    return tuple(o for o in objs if o in moving)


def filter_stationary(sim: Simulation, objs: ObjectSet, state_index: int) -> ObjectSet:
    moving = sim.moving(state_index)
    return tuple(o for o in objs if o not in moving)


def unique(sim: Simulation, objs: ObjectSet) -> int | _Invalid:
    return objs[0] if len(objs) == 1 else INVALID


def as_list(sim: Simulation, obj: int) -> ObjectSet:
    return (obj,)


# -- queries ------------------------------------------------------------------------------------------


def query_color(sim: Simulation, obj: int) -> str:
    return sim._by_id[obj].color


def query_shape(sim: Simulation, obj: int) -> str:
    return sim._by_id[obj].shape


def query_size(sim: Simulation, obj: int) -> str:
    return sim._by_id[obj].size


# -- set algebra ----------------------------------------------------------------------------------------


def intersect(sim: Simulation, a: ObjectSet, b: ObjectSet) -> ObjectSet:
    bs = set(b)
    return tuple(o for o in a if o in bs)


def union(sim: Simulation, a: ObjectSet, b: ObjectSet) -> ObjectSet:
    return tuple(sorted(set(a).union(b)))


def difference(sim: Simulation, a: ObjectSet, b: ObjectSet) -> ObjectSet:
    bs = set(b)
    return tuple(o for o in a if o not in bs)


def intersect_list(sim: Simulation, sets: tuple[ObjectSet, ...], b: ObjectSet) -> tuple[ObjectSet, ...]:
    bs = set(b)
    return tuple(tuple(o for o in s if o in bs) for s in sets)


# -- counting and logic -------------------------------------------------------------------------------------


def count(sim: Simulation, items: tuple[object, ...]) -> int:
    return len(items)


def exist(sim: Simulation, items: tuple[object, ...]) -> bool:
    return len(items) > 0


def exist_list(sim: Simulation, lists: tuple[tuple[object, ...], ...]) -> tuple[bool, ...]:
    return tuple(len(s) > 0 for s in lists)


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


def filter_events(sim: Simulation, evs: EventSet, obj: int) -> EventSet:
    return tuple(e for e in evs if obj in e.objects)


def filter_collision(sim: Simulation, evs: EventSet) -> EventSet:
    return tuple(e for e in evs if e.type == COLLISION)


def filter_collision_with_dynamics(sim: Simulation, evs: EventSet) -> EventSet:
    dyn = sim.dynamic_ids
    return tuple(
        e for e in evs
        if e.type == COLLISION and e.objects and all(o in dyn for o in e.objects)
    )


def _collide_with(evs: EventSet, target: int) -> EventSet:
    return tuple(e for e in evs if e.type == COLLISION and target in e.objects)


def filter_collide_ground(sim: Simulation, evs: EventSet) -> EventSet:
    return _collide_with(evs, sim.ground_id)


def filter_collide_basket(sim: Simulation, evs: EventSet) -> EventSet:
    return _collide_with(evs, sim.basket_id)


def filter_enter_basket(sim: Simulation, evs: EventSet) -> EventSet:
    return tuple(e for e in evs if e.type == ENTER_BASKET)


def filter_collide_ground_list(sim: Simulation, lists: tuple[EventSet, ...]) -> tuple[EventSet, ...]:
    return tuple(_collide_with(evs, sim.ground_id) for evs in lists)


def filter_collide_basket_list(sim: Simulation, lists: tuple[EventSet, ...]) -> tuple[EventSet, ...]:
    return tuple(_collide_with(evs, sim.basket_id) for evs in lists)


def filter_enter_basket_list(sim: Simulation, lists: tuple[EventSet, ...]) -> tuple[EventSet, ...]:
    return tuple(filter_enter_basket(sim, evs) for evs in lists)


def filter_first(sim: Simulation, evs: EventSet) -> Event | _Invalid:
    return evs[0] if evs else INVALID


def filter_last(sim: Simulation, evs: EventSet) -> Event | _Invalid:
    return evs[-1] if evs else INVALID


def filter_before(sim: Simulation, evs: EventSet, ref: Event) -> EventSet:
    return tuple(e for e in evs if e.step < ref.step)


def filter_after(sim: Simulation, evs: EventSet, ref: Event) -> EventSet:
    return tuple(e for e in evs if e.step > ref.step)


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
    found: set[int] = set()
    for e in evs:
        found.update(e.objects)
    return tuple(sorted(found))


def filter_objects_from_events(sim: Simulation, evs: EventSet) -> ObjectSet:
    return _objects_of(evs)


def filter_objects_from_events_list(sim: Simulation, lists: tuple[EventSet, ...]) -> tuple[ObjectSet, ...]:
    return tuple(_objects_of(evs) for evs in lists)


# -- counterfactuals -----------------------------------------------------------------------------------------


def get_counterfact_events(sim: Simulation, obj: int) -> EventSet:
    return sim.counterfactual(obj).events


def get_counterfact_events_list(sim: Simulation, objs: ObjectSet) -> tuple[EventSet, ...]:
    return tuple(sim.counterfactual(o).events for o in objs)
