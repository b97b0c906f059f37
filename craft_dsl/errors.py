"""Exceptions raised by craft_dsl. Every one says what is wrong, where, and what is allowed."""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any


class CraftError(Exception):
    """Base class of every craft_dsl error."""


class ProgramError(CraftError):
    """A program is wrong: it does not parse, names an unknown module, or does not type-check.

    ``line``/``column`` locate the problem in program text; ``location`` describes where it is in other
    forms (``"token 4"``, ``"node 7"``) and ``index`` is then that token's or node's 0-based index.
    """

    def __init__(self, message: str, line: int | None = None, column: int | None = None, *,
                 location: str | None = None, index: int | None = None) -> None:
        self.line = line
        self.column = column
        self.index = index
        if location is None and line is not None and column is not None:
            location = f"line {line}, column {column}"
        self.location = location
        super().__init__(f"{location}: {message}" if location else message)
        self.message = message

    def relocated(self, location: str, index: int | None) -> ProgramError:
        """A copy of this error placed at ``location`` (a token or a node of another program form)."""
        new = copy.copy(self)
        new.line = new.column = None
        new.location, new.index = location, index
        new.args = (f"{location}: {self.message}",)
        return new


class ParseError(ProgramError):
    """The program text is malformed."""


class UnknownModuleError(ProgramError):
    """A module name is not in the registry (the message lists the nearest names)."""


class TypeCheckError(ProgramError):
    """An argument has the wrong type (the message names module, argument, expected and found type).

    ``module``, ``argument`` (1-based), ``expected`` and ``found`` repeat those facts for programs that read
    them (``expected`` lists the allowed types); any of them is None where it does not apply.
    """

    def __init__(self, message: str, line: int | None = None, column: int | None = None, *,
                 module: str | None = None, argument: int | None = None,
                 expected: tuple[str, ...] | None = None, found: str | None = None, **where: Any) -> None:
        super().__init__(message, line, column, **where)
        self.module = module
        self.argument = argument
        self.expected = expected
        self.found = found


class SideInputError(ProgramError):
    """A side input (colour, shape, size) has a value outside the vocabulary."""


class NodeListError(ProgramError):
    """A CLEVR/CRAFT node list is malformed."""


class TokenError(ProgramError):
    """A program token sequence is malformed (unknown token, too few or too many tokens)."""


class MissingExtraError(CraftError, ModuleNotFoundError):
    """A feature needs an optional extra that is not installed; the message names the ``pip install`` to run."""

    def __init__(self, feature: str, extra: str, missing: str | None = None) -> None:
        super().__init__(
            f"{feature} needs {missing or extra}, which is not installed: pip install 'craft-dsl[{extra}]'")
        self.name = missing
        self.extra = extra


class SimulationFileError(CraftError):
    """A recorded simulation file is malformed; the message names the defect."""


class CounterfactualUnavailable(CraftError):
    """A program asked for a counterfactual that the simulation cannot provide."""


class EvaluationError(CraftError):
    """A program asked for something the simulation does not have (e.g. a state index out of range)."""


class QuestionParseError(CraftError):
    """A question text matches no CRAFT template.

    The message names the closest template (id and paraphrase) and the word where the question diverged from it;
    the same facts are attributes: ``question``, ``template_id``, ``paraphrase`` (index), ``word_index`` (1-based;
    ``len(words) + 1`` when the question ended too early), ``found`` (the word, or None at the end) and
    ``expected`` (the words allowed there; ``"<end>"`` stands for the end of the question).
    """

    def __init__(
        self,
        message: str,
        *,
        question: str,
        template_id: str | None = None,
        paraphrase: int | None = None,
        word_index: int | None = None,
        found: str | None = None,
        expected: tuple[str, ...] = (),
    ) -> None:
        super().__init__(message)
        self.question = question
        self.template_id = template_id
        self.paraphrase = paraphrase
        self.word_index = word_index
        self.found = found
        self.expected = expected


class PerceptionError(CraftError):
    """A perceived scene is malformed or cannot be executed; the message names the object, frame and field.

    ``problems`` lists every defect found (each with ``object``, ``frame``, ``field`` and ``message``).
    """

    def __init__(self, message: str, problems: Sequence[Any] = ()) -> None:
        super().__init__(message)
        self.problems: list[Any] = list(problems)
