"""Exceptions raised by craft_dsl. Every one says what is wrong, where, and what is allowed."""

from __future__ import annotations


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
