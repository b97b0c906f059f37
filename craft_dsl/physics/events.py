"""Contact log -> events, by the original simulator's rules.

For every touching interval [b, e) of a shape pair (``e == steps``: still touching at the end):

* ``e - b <= 20`` (:data:`COLLISION_MAX_STEPS`): one Collision stamped ``b``;
* otherwise, if the original's after-step check ``counter - b > 20`` runs before the end (``b + 21 < steps``):
  TouchStart stamped ``b``, plus TouchEnd stamped ``e`` if the contact ends (``e < steps``);
* otherwise (opened in the last 21 frames and still open at the end): nothing, as in the original.

EnterBasket [basket, body] fires at the first frame of every sensor-overlap interval (frame 0 if the body
starts inside). Start is at step -1, End at step ``steps``.

Ordering among events of one step is deterministic: by the frame at which the original would have
detected the event (Collision and TouchEnd at the contact's end, TouchStart 21 frames after its begin,
EnterBasket at once), then by type, objects and basket edge. Ids are 0..n-1 in that order.
"""

from __future__ import annotations

from ..simulation import Event
from ..vocabulary import COLLISION, COLLISION_MAX_STEPS, END, ENTER_BASKET, START, TOUCH_END, TOUCH_START
from .engine import ContactLog

_TYPE_RANK = {START: 0, ENTER_BASKET: 1, COLLISION: 2, TOUCH_START: 3, TOUCH_END: 4, END: 5}


def events_from_log(log: ContactLog) -> list[Event]:
    """The events of a run, in (step, id) order with ids 0..n-1."""
    steps = log.steps
    raw: list[tuple[int, int, int, tuple[int, ...], int, str]] = []
    for (ua, pa, ub, pb), intervals in log.contacts.items():
        objs: tuple[int, ...] = (ua, ub)
        part = pa * 1000 + pb
        for b, e in intervals:
            if e < steps and e - b <= COLLISION_MAX_STEPS:
                raw.append((b, e, _TYPE_RANK[COLLISION], objs, part, COLLISION))
            elif b + COLLISION_MAX_STEPS + 1 < steps:
                raw.append((b, b + COLLISION_MAX_STEPS + 1, _TYPE_RANK[TOUCH_START], objs, part, TOUCH_START))
                if e < steps:
                    raw.append((e, e, _TYPE_RANK[TOUCH_END], objs, part, TOUCH_END))
    for (basket, body), intervals in log.sensors.items():
        for b, _e in intervals:
            raw.append((b, b, _TYPE_RANK[ENTER_BASKET], (basket, body), 0, ENTER_BASKET))
    raw.sort()
    events = [Event(0, START, -1, ())]
    for step, _detect, _rank, objs, _part, kind in raw:
        events.append(Event(len(events), kind, step, objs))
    events.append(Event(len(events), END, steps, ()))
    return events
