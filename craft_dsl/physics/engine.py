"""Engine-agnostic types: the protocol a physics engine implements and the contact log it returns.

An engine runs a :class:`~craft_dsl.world.WorldSpec` for a number of 1/60-s frames and returns a
:class:`RawRun`: the per-frame :class:`~craft_dsl.simulation.Trajectory` plus a :class:`ContactLog`.
Everything else (events, counterfactuals, perturbations) is built on these types only, so a new engine
(e.g. Box2D) is one file implementing :class:`PhysicsEngine`.

Frame convention: frame ``k`` (0 <= k < steps) is the world step from state row ``k`` to row ``k + 1``;
it is stamped ``k`` like the original's contact callbacks (the number of completed steps). A pair
"touches in frame k" if it touches at any sub-step of that frame. Touching is stored as half-open frame
intervals ``[start, end)``; ``end == steps`` means the pair still touches when the run ends.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from ..simulation import Trajectory
from ..world import WorldSpec

#: One contact identity: (uid_a, part_a, uid_b, part_b) with uid_a > uid_b. ``part`` numbers the shapes of
#: a body (the basket's three edges are parts 0, 1, 2; every other body has one part, 0).
PairKey = tuple[int, int, int, int]
#: A sensor overlap identity: (uid of the sensor's body, i.e. the basket; uid of the dynamic body).
SensorKey = tuple[int, int]
#: Half-open frame interval [start, end).
Interval = tuple[int, int]


def pair_key(uid_a: int, part_a: int, uid_b: int, part_b: int) -> PairKey:
    """Canonical pair key: the body with the larger uid first (statics have the larger uids)."""
    if uid_a > uid_b or (uid_a == uid_b and part_a >= part_b):
        return (uid_a, part_a, uid_b, part_b)
    return (uid_b, part_b, uid_a, part_a)


@dataclass(frozen=True)
class ContactLog:
    """Which shape pairs touch, and which dynamic bodies overlap the basket sensor, frame by frame."""

    steps: int
    contacts: Mapping[PairKey, tuple[Interval, ...]] = field(default_factory=dict)
    sensors: Mapping[SensorKey, tuple[Interval, ...]] = field(default_factory=dict)

    def touching(self, key: PairKey, frame: int) -> bool:
        return any(s <= frame < e for s, e in self.contacts.get(key, ()))

    def without_uid(self, uid: int) -> ContactLog:
        """The log with every pair involving ``uid`` dropped."""
        return ContactLog(
            self.steps,
            {k: v for k, v in self.contacts.items() if k[0] != uid and k[2] != uid},
            {k: v for k, v in self.sensors.items() if uid not in k},
        )


@dataclass(frozen=True)
class ReplayPlan:
    """How to re-run a world against a recorded base run (used for clean counterfactuals).

    ``activation[uid] = a`` means the body is simulated dynamically from frame ``a`` on, starting from the
    base trajectory's row ``a`` exactly. Dynamic bodies without an entry are replayed for the whole run:
    they follow the base trajectory kinematically (rows copied bit for bit) and collide only with
    dynamically simulated bodies. Rows and contacts before ``min(activation)`` are not simulated at all.
    """

    base: Trajectory
    base_awake: np.ndarray
    activation: Mapping[int, int]

    @property
    def first_frame(self) -> int:
        return min(self.activation.values()) if self.activation else self.base.steps


@dataclass(frozen=True)
class RawRun:
    """What an engine returns: the trajectory, per-row awake flags [T+1, N] and the contact log.

    For a replayed run, rows of replayed bodies are the base rows, and ``log`` holds only pairs involving
    a dynamically simulated body, from ``ReplayPlan.first_frame`` on.
    """

    trajectory: Trajectory
    awake: np.ndarray
    log: ContactLog


class PhysicsEngine(Protocol):
    """A physics engine adapter."""

    name: str

    def run(self, world: WorldSpec, steps: int, replay: ReplayPlan | None = None) -> RawRun:
        """Simulate ``world`` for ``steps`` frames of 1/60 s (or re-run it against ``replay``)."""
        ...


# -- interval helpers ------------------------------------------------------------------------------


def clip(intervals: Iterable[Interval], lo: int, hi: int) -> list[Interval]:
    """The parts of ``intervals`` inside [lo, hi)."""
    out = []
    for s, e in intervals:
        s2, e2 = max(s, lo), min(e, hi)
        if s2 < e2:
            out.append((s2, e2))
    return out


def coalesce(intervals: Iterable[Interval]) -> tuple[Interval, ...]:
    """Sort and join touching or overlapping intervals ([a, m) + [m, b) -> [a, b))."""
    out: list[list[int]] = []
    for s, e in sorted(intervals):
        if out and s <= out[-1][1]:
            out[-1][1] = max(out[-1][1], e)
        else:
            out.append([s, e])
    return tuple((s, e) for s, e in out)


def splice(base: Iterable[Interval], run: Iterable[Interval], switch: int, steps: int) -> tuple[Interval, ...]:
    """Base intervals before frame ``switch``, run intervals from it on, joined across the switch."""
    return coalesce(clip(base, 0, switch) + clip(run, switch, steps))


# -- perturbations -----------------------------------------------------------------------------------


def perturb_world(world: WorldSpec, seed: int, amount: float = 0.02) -> WorldSpec:
    """The original simulator's perturbation noise, once per dynamic body with one seeded generator (creation order):
    r ~ U(-1, 1); angle and velocity scaled by (1 + a r); x and y shifted by 10 a r / (1 + a r) when
    vx != 0."""
    rng = np.random.default_rng(seed)
    bodies = []
    for b in world.bodies:
        if not b.dynamic:
            bodies.append(b)
            continue
        r = float(rng.uniform(-1.0, 1.0))
        f = 1.0 + amount * r
        shift = 10.0 * amount * r / f if b.velocity[0] != 0 else 0.0
        bodies.append(replace(
            b,
            angle=b.angle * f,
            velocity=(b.velocity[0] * f, b.velocity[1] * f),
            position=(b.position[0] + shift, b.position[1] + shift),
        ))
    return replace(world, bodies=tuple(bodies))
