"""craft_dsl: a typed DSL for CRAFT-style causal video question answering.

>>> from craft_dsl import parse, load_simulation
>>> sim = load_simulation("tests/data/e1.json")
>>> parse("Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))").run(sim)
2
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .errors import (
    CounterfactualUnavailable,
    CraftError,
    EvaluationError,
    MissingExtraError,
    NodeListError,
    ParseError,
    ProgramError,
    QuestionParseError,
    SideInputError,
    SimulationFileError,
    TokenError,
    TypeCheckError,
    UnknownModuleError,
)
from .program import Program, parse
from .question_parsing import QuestionMatch, match_question, question_to_program
from .registry import MODULES, REGISTRY
from .simulation import Event, ObjectState, SimObject, Simulation, Trajectory
from .types import INVALID, DslType
from .world import BodySpec, Geometry, WorldSpec

if TYPE_CHECKING:
    from .physics import simulate
    from .recorded import load_simulation, save_simulation

__all__ = [
    "INVALID",
    "MODULES",
    "REGISTRY",
    "BodySpec",
    "CounterfactualUnavailable",
    "CraftError",
    "DslType",
    "EvaluationError",
    "Event",
    "Geometry",
    "MissingExtraError",
    "NodeListError",
    "ObjectState",
    "ParseError",
    "Program",
    "ProgramError",
    "QuestionMatch",
    "QuestionParseError",
    "SideInputError",
    "SimObject",
    "Simulation",
    "SimulationFileError",
    "TokenError",
    "Trajectory",
    "TypeCheckError",
    "UnknownModuleError",
    "WorldSpec",
    "load_simulation",
    "match_question",
    "parse",
    "question_to_program",
    "save_simulation",
    "simulate",
]
__version__ = "0.1.0"


def __getattr__(name: str) -> Any:
    # Physics (pymunk) and the recorded-file loader (pydantic) load on first use: `import craft_dsl` stays light.
    if name == "simulate":
        from .physics import simulate

        return simulate
    if name in ("load_simulation", "save_simulation"):
        from . import recorded

        return getattr(recorded, name)
    raise AttributeError(f"module 'craft_dsl' has no attribute {name!r}")
