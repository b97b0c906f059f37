"""Live physics: simulate CRAFT scenes, derive events, and make clean counterfactuals.

>>> from craft_dsl.physics import simulate
>>> sim = simulate(7, seed=3)            # doctest: +SKIP
>>> sim.counterfactual(0).events         # doctest: +SKIP
"""

from __future__ import annotations

from .engine import ContactLog, PhysicsEngine, RawRun, ReplayPlan
from .events import events_from_log
from .live import LiveSimulation, clean_counterfactual, get_engine, perturb_world, simulate

__all__ = [
    "ContactLog",
    "LiveSimulation",
    "PhysicsEngine",
    "RawRun",
    "ReplayPlan",
    "clean_counterfactual",
    "events_from_log",
    "get_engine",
    "perturb_world",
    "simulate",
]
