"""The contact flicker of the original simulator's polygon circles, added to a run's contact log.

The original CRAFT simulator builds its circles as 128-gons. Rolling on the ground, a platform or the basket, a
128-gon's Box2D contact keeps losing its manifold and beginning again: measured there, a circle rolling at 2 m/s
on the ground makes a new contact every 5-15 steps, at 4-8 m/s every 3-4 steps, at 1 m/s every 12-20 steps, and
at 0.5 m/s contacts of 40-60 steps follow each other. Each short contact (at most 20 steps) is a Collision in the
original's event rules, so a rolling circle "collides with the ground" again and again, where a true circle's one
long contact is a single touch, and the questions that count ground hits or order collisions read these events.

:func:`add_flicker` splits the touching intervals of circles with static bodies as the original's would split:
while the circle moves faster than :data:`MIN_SPEED`, the contact ends and begins again (one step later) every
``FLICKER_STEP_METRES / speed`` steps (at least :data:`MIN_PERIOD`), which reproduces the periods above; slower, the
contact is left whole. Deterministic: the breaks follow from the run's own speeds.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np

from ..simulation import Trajectory
from .engine import ContactLog, Interval

#: A rolling circle's contact begins again after it has moved this far (metres), on average.
FLICKER_STEP_METRES = 13.0 / 60.0
#: Never more often than every this many steps (measured: 3-4 steps at 4 to 8 m/s).
MIN_PERIOD = 3
#: Slower than this (m/s), the contact stays whole.
MIN_SPEED = 0.25


def _split(interval: Interval, speeds: np.ndarray) -> list[Interval]:
    """``interval`` [start, end) cut where a contact of a circle moving at ``speeds[row]`` would begin again."""
    start, end = interval
    pieces: list[Interval] = []
    piece_start = start
    travelled = 0.0
    step = start
    while step < end - 1:
        speed = float(speeds[step + 1])  # step + 1 < end: a row of the run
        if speed < MIN_SPEED:
            travelled = 0.0
        else:
            travelled += speed / 60.0
        if travelled >= FLICKER_STEP_METRES and step + 1 - piece_start >= MIN_PERIOD:
            pieces.append((piece_start, step + 1))  # the manifold empties after this step
            piece_start = step + 2  # and is found again a step later
            travelled = 0.0
            step += 2
            continue
        step += 1
    if piece_start < end:
        pieces.append((piece_start, end))
    return pieces


def add_flicker(log: ContactLog, trajectory: Trajectory, circles: Collection[int],
                statics: Collection[int]) -> ContactLog:
    """``log`` with the touching intervals of each circle in ``circles`` (dynamic uids) with each body in
    ``statics`` split as the original's 128-gons' contacts are (see the module docstring). Row ``r`` of
    ``trajectory`` is the state after ``r`` steps; an interval [b, e) touches in frames b..e-1."""
    if not circles:
        return log
    circle_set, static_set = set(circles), set(statics)
    speeds: dict[int, np.ndarray] = {}
    contacts = dict(log.contacts)
    for key, intervals in log.contacts.items():
        a, _, b, _ = key
        circle = b if b in circle_set and a in static_set else a if a in circle_set and b in static_set else None
        if circle is None:
            continue
        if circle not in speeds:
            v = trajectory.velocities[:, trajectory.column(circle)]
            speeds[circle] = np.hypot(v[:, 0], v[:, 1])
        split = tuple(piece for iv in intervals for piece in _split(iv, speeds[circle]))
        contacts[key] = split
    return ContactLog(log.steps, contacts, log.sensors)
