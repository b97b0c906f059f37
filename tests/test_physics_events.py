"""Contact log -> events rules (pure function, no engine)."""

from __future__ import annotations

from craft_dsl.physics.engine import ContactLog, clip, coalesce, pair_key, splice
from craft_dsl.physics.events import events_from_log


def _tuples(log: ContactLog) -> list[tuple[str, int, tuple[int, ...]]]:
    return [(e.type, e.step, e.objects) for e in events_from_log(log)]


def test_short_contact_is_one_collision_at_its_start() -> None:
    log = ContactLog(100, {(5, 0, 1, 0): ((10, 30),)})
    assert _tuples(log) == [("Start", -1, ()), ("Collision", 10, (5, 1)), ("End", 100, ())]


def test_long_contact_is_touch_start_and_touch_end() -> None:
    log = ContactLog(100, {(5, 0, 1, 0): ((10, 31),)})
    assert _tuples(log)[1:-1] == [("TouchStart", 10, (5, 1)), ("TouchEnd", 31, (5, 1))]


def test_open_contact_touch_start_only_if_checked_before_the_end() -> None:
    # still touching at the end: TouchStart iff begin + 21 < steps (the original's after-step check)
    assert _tuples(ContactLog(100, {(5, 0, 1, 0): ((78, 100),)}))[1:-1] == [("TouchStart", 78, (5, 1))]
    assert _tuples(ContactLog(100, {(5, 0, 1, 0): ((79, 100),)}))[1:-1] == []
    assert _tuples(ContactLog(100, {(5, 0, 1, 0): ((95, 100),)}))[1:-1] == []


def test_every_sensor_entry_fires_and_basket_comes_first() -> None:
    log = ContactLog(100, {}, {(7, 2): ((0, 5), (40, 100))})
    assert _tuples(log)[1:-1] == [("EnterBasket", 0, (7, 2)), ("EnterBasket", 40, (7, 2))]


def test_two_basket_edges_give_two_contacts_and_ids_follow_order() -> None:
    log = ContactLog(200, {(7, 0, 1, 0): ((50, 52),), (7, 1, 1, 0): ((50, 120),), (9, 0, 3, 0): ((20, 23),)})
    events = events_from_log(log)
    assert [e.id for e in events] == list(range(len(events)))
    assert [(e.type, e.step) for e in events] == [
        ("Start", -1), ("Collision", 20), ("Collision", 50), ("TouchStart", 50), ("TouchEnd", 120), ("End", 200)
    ]
    assert events == events_from_log(log)


def test_interval_helpers() -> None:
    assert pair_key(1, 0, 5, 2) == (5, 2, 1, 0)
    assert clip([(0, 10), (20, 30)], 5, 25) == [(5, 10), (20, 25)]
    assert coalesce([(20, 30), (0, 10), (10, 12)]) == ((0, 12), (20, 30))
    assert splice([(0, 50)], [(40, 60), (70, 80)], 40, 100) == ((0, 60), (70, 80))
    assert splice([(0, 50)], [(41, 60)], 40, 100) == ((0, 40), (41, 60))
