"""Live physics: simulate CRAFT scenes, derive events, and make clean counterfactuals.

>>> from craft_dsl.physics import simulate
>>> sim = simulate(7, seed=3)            # doctest: +SKIP
>>> sim.counterfactual(0).events         # doctest: +SKIP
>>> simulate(7, seed=3, engine="box2d")  # doctest: +SKIP  (the optional extra: pip install 'craft-dsl[box2d]')
"""

from __future__ import annotations

from .engine import ContactLog, PhysicsEngine, RawRun, ReplayPlan
from .events import events_from_log
from .live import ENGINES, LiveSimulation, clean_counterfactual, get_engine, perturb_world, simulate

__all__ = [
    "ENGINES",
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
