"""Exceptions raised by craft_dsl. Every one says what is wrong, where, and what is allowed."""

from __future__ import annotations

import copy
import re
from collections.abc import Sequence
from typing import Any

#: The longest message an error carries: one that quotes a 5,000-character token or a whole node is shortened.
MAX_MESSAGE_LENGTH = 1500
_QUOTED_LIMIT = 60
_LONG_QUOTED = re.compile("'([^'\n]{80,})'|\"([^\"\n]{80,})\"")  # quoted values longer than _QUOTED_LIMIT + 20


def shorten_message(message: str) -> str:
    """``message`` with every long quoted value cut to its start (and its length), and the whole cut in the
    middle if it is still longer than :data:`MAX_MESSAGE_LENGTH` (the start says what, the end what is allowed)."""
    def cut(m: re.Match[str]) -> str:
        quote = "'" if m.group(1) is not None else '"'
        text = m.group(1) if m.group(1) is not None else m.group(2)
        return f"{quote}{text[:_QUOTED_LIMIT]}...{quote} ({len(text):,} characters)"

    if len(message) > _QUOTED_LIMIT + 20:
        message = _LONG_QUOTED.sub(cut, message)
    if len(message) > MAX_MESSAGE_LENGTH:
        keep = MAX_MESSAGE_LENGTH // 2
        message = f"{message[:keep]} ...({len(message) - 2 * keep:,} characters)... {message[-keep:]}"
    return message


class CraftError(Exception):
    """Base class of every craft_dsl error. A message quoting a huge input is shortened (see
    :func:`shorten_message`)."""

    def __init__(self, *args: Any) -> None:
        if args and isinstance(args[0], str):
            args = (shorten_message(args[0]), *args[1:])
        super().__init__(*args)


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
        new.args = (shorten_message(f"{location}: {self.message}"),)
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
    """A feature needs an optional extra that is not installed; the message names the ``pip install`` to run.

    ``feature`` needs ``missing`` (the library, default: the extra's name), which the extra ``extra`` installs;
    ``alternative`` (e.g. ``"or use --no-charts"``) is added in parentheses."""

    def __init__(self, feature: str, extra: str, missing: str | None = None, alternative: str = "") -> None:
        super().__init__(
            f"{feature} needs {missing or extra}, which is not installed: pip install 'craft-dsl[{extra}]'"
            + (f" ({alternative})" if alternative else ""))
        self.name = missing
        self.extra = extra
        self._fields = (feature, extra, missing, alternative)

    def __reduce__(self) -> tuple[Any, ...]:  # raised in a worker process, it crosses back pickled
        return (type(self), self._fields)


class InputFileError(CraftError):
    """An input file cannot be read as asked, or its content is malformed.

    Raised for a missing file, a directory, an unreadable file, text that is not UTF-8, invalid JSON, JSON
    nested too deeply, a key given twice in one object, or a number out of range (see docs/errors.md).
    ``path`` is the file (None for data handed over in memory), ``line``/``column`` (1-based) locate the
    problem in the file's text where known, ``field`` names the JSON field (``"variations_outputs.3"``).
    The subclasses name the kind of file.
    """

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None,
                 column: int | None = None, field: str | None = None) -> None:
        super().__init__(message)
        self.path = path
        self.line = line
        self.column = column
        self.field = field


class SimulationFileError(InputFileError):
    """A recorded simulation file is malformed; the message names the defect."""


class SceneFileError(InputFileError):
    """A scene layout file is malformed or cannot be sampled; the message names file, field and what is
    allowed."""


class ExpressionError(CraftError, ValueError):
    """An expression string of a scene layout is not in the safe arithmetic subset, or cannot be evaluated."""


class DatasetFileError(InputFileError):
    """A dataset file (``dataset.json``, ``dataset_minimal.json``, ``annotations.json``, a split file) is
    malformed; the message names file, record and field."""


class PredictionsFileError(InputFileError):
    """A predictions file is malformed (a key given twice, an answer out of range...); the message names file,
    record and field."""


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


class ReaderError(CraftError):
    """The video reader cannot read a video or a questions file (the message names the file and the defect)."""
