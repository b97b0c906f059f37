"""craft_dsl: a typed DSL for CRAFT-style causal video question answering."""

from .simulation import Event, ObjectState, SimObject, Simulation, Trajectory
from .world import BodySpec, Geometry, WorldSpec

__all__ = [
    "BodySpec",
    "Event",
    "Geometry",
    "ObjectState",
    "SimObject",
    "Simulation",
    "Trajectory",
    "WorldSpec",
]
__version__ = "0.1.0"
