"""Exceptions raised by craft_dsl. Every one says what is wrong, where, and what is allowed."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any


class CraftError(Exception):
    """Base class of every craft_dsl error."""


class ProgramError(CraftError):
    """A program is wrong: it does not parse, names an unknown module, or does not type-check."""

    def __init__(self, message: str, line: int | None = None, column: int | None = None) -> None:
        self.line = line
        self.column = column
        where = f"line {line}, column {column}: " if line is not None and column is not None else ""
        super().__init__(where + message)
        self.message = message


class ParseError(ProgramError):
    """The program text is malformed."""


class UnknownModuleError(ProgramError):
    """A module name is not in the registry (the message lists the nearest names)."""


class TypeCheckError(ProgramError):
    """An argument has the wrong type (the message names module, argument, expected and found type)."""


class SideInputError(ProgramError):
    """A side input (colour, shape, size) has a value outside the vocabulary."""


class NodeListError(ProgramError):
    """A CLEVR/CRAFT node list is malformed."""


class SimulationFileError(CraftError):
    """A recorded simulation file is malformed; the message names the defect."""


class CounterfactualUnavailable(CraftError):
    """A program asked for a counterfactual that the simulation cannot provide."""


class EvaluationError(CraftError):
    """A program asked for something the simulation does not have (e.g. a state index out of range)."""


class PerceptionError(CraftError):
    """A perceived scene is malformed or cannot be executed; the message names the object, frame and field.

    ``problems`` lists every defect found (each with ``object``, ``frame``, ``field`` and ``message``).
    """

    def __init__(self, message: str, problems: Sequence[Any] = ()) -> None:
        super().__init__(message)
        self.problems: list[Any] = list(problems)
