"""Readers of the CRAFT file formats: dataset.json, dataset_minimal.json, predictions and splits.

Every file is read by :mod:`craft_dsl.files` (predictions as a stream, by :class:`PredictionEntries`); every
error is a :class:`~craft_dsl.errors.DatasetFileError` or :class:`~craft_dsl.errors.PredictionsFileError` naming
the file, the record and the field. Indices (``video_index``, ``question_index``, ``question_family_index``) are
integers from 0 to :data:`MAX_INDEX`; answers are strings, booleans or numbers of at most 18 digits.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Union

from pydantic import BaseModel, ConfigDict, Field, StrictInt, ValidationError, field_validator

from ..errors import DatasetFileError, PredictionsFileError
from ..files import describe, key_text, read_json
from ..jsonstream import iter_lines, iter_members
from ..templates import templates
from .answers import MAX_ANSWER_DIGITS, answer_problem
from .categories import category_of, family_of, question_type_of

PathLike = Union[str, "os.PathLike[str]"]

#: The largest video or question index a file may give (12 digits).
MAX_INDEX = 10**12 - 1
Index = Annotated[StrictInt, Field(ge=0, le=MAX_INDEX)]


def _read_json(path: PathLike, what: str) -> Any:
    return read_json(path, f"{what} file", error=DatasetFileError)


def _validation_message(err: ValidationError) -> str:
    parts = []
    for e in err.errors()[:3]:
        loc = ".".join(key_text(x) for x in e["loc"])
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] in ("greater_than_equal", "less_than_equal"):
            msg = f"must be an integer from 0 to {MAX_INDEX:,}, found {describe(e.get('input'))}"
        parts.append(f"field '{loc}': {msg}" if loc else msg)
    more = len(err.errors()) - 3
    return "; ".join(parts) + (f" (and {more} more)" if more > 0 else "")


def _check_answer(value: Any) -> Any:
    if not isinstance(value, (bool, int, str)):
        raise ValueError(f"must be a boolean, an integer or a string, found {describe(value)}")
    problem = answer_problem(value)
    if problem is not None:
        raise ValueError(problem)
    return value


class _Record(BaseModel):
    model_config = ConfigDict(extra="allow")


class _DatasetQuestion(_Record):
    question: str = ""
    program: list[dict[str, Any]]
    answer: Any
    template_filename: str
    question_family_index: Index
    question_index: Index
    video_index: Index | None = None
    video: str | None = None

    _answer = field_validator("answer")(_check_answer)


class _QuestionsBlock(_Record):
    info: dict[str, Any] = {}
    questions: list[Any]


class _DatasetVideo(_Record):
    simulation_id: str | Index | None = None
    video_path: str | None = None
    questions: _QuestionsBlock


class _MinimalQuestion(_Record):
    question: str = ""
    answer: Any
    answer_type: str | None = None
    template_filename: str | None = None
    question_family_index: Index | None = None
    template_id: str | None = None
    video_index: Index
    question_index: Index
    simulation_id: str | Index | None = None
    question_type: str | None = None

    _answer = field_validator("answer")(_check_answer)


class _Key(_Record):
    video_index: Index
    question_index: Index


@dataclass(frozen=True)
class Question:
    """One question, from either file format.

    ``answer`` is as recorded (raw JSON value in ``dataset.json``, a string in ``dataset_minimal.json``);
    ``program`` is the node list (``dataset.json`` only); ``where`` locates the record for messages.
    """

    video_index: int
    question_index: int
    template_id: str
    answer: Any
    question: str = ""
    program: tuple[Mapping[str, Any], ...] | None = None
    video: str = ""
    simulation_id: str | None = None
    where: str = ""

    @property
    def key(self) -> tuple[int, int]:
        return (self.video_index, self.question_index)

    @property
    def family(self) -> str:
        return family_of(self.template_id)

    @property
    def category(self) -> str:
        return category_of(self.template_id)

    @property
    def question_type(self) -> str:
        return question_type_of(self.template_id)


def _template_id(where: str, filename: str | None, index: int | None, given: str | None) -> str:
    derived = None
    if filename is not None and index is not None:
        derived = f"{Path(filename).stem}_{index}"
    tid = given or derived
    if tid is None:
        raise DatasetFileError(f"{where}: needs 'template_id', or 'template_filename' and 'question_family_index'")
    if given and derived and given != derived:
        raise DatasetFileError(f"{where}: template_id {describe(given)} disagrees with "
                               f"template_filename/question_family_index ({describe(derived)})")
    if tid not in templates():
        field_name = "template_id" if given else "template_filename/question_family_index"
        raise DatasetFileError(f"{where}: field '{field_name}': {describe(tid)} is not a CRAFT template id "
                               "(descriptive_0-39, counterfactual_0-8, cause/enable/prevent_0-5)")
    return tid


def _check_unique(questions: Sequence[Question]) -> None:
    seen: dict[tuple[int, int], str] = {}
    for q in questions:
        if q.key in seen:
            raise DatasetFileError(f"{q.where}: video_index {q.video_index}, question_index {q.question_index} "
                                   f"already used by {seen[q.key]}")
        seen[q.key] = q.where


def parse_dataset(data: Any, name: str = "dataset.json") -> list[Question]:
    """The questions of a parsed ``dataset.json`` (list of videos); errors name file, record and field."""
    if not isinstance(data, list):
        raise DatasetFileError(f"{name}: expected a JSON list of video records, found {type(data).__name__}")
    out: list[Question] = []
    for i, raw_video in enumerate(data):
        vwhere = f"{name}: video record {i}"
        try:
            video = _DatasetVideo.model_validate(raw_video)
        except ValidationError as err:
            raise DatasetFileError(f"{vwhere}: {_validation_message(err)}") from None
        info_index = video.questions.info.get("video_index")
        for j, raw_q in enumerate(video.questions.questions):
            where = f"{vwhere}, question {j}"
            try:
                q = _DatasetQuestion.model_validate(raw_q)
            except ValidationError as err:
                raise DatasetFileError(f"{where}: {_validation_message(err)}") from None
            vi = q.video_index if q.video_index is not None else info_index
            if not isinstance(vi, int) or isinstance(vi, bool):
                raise DatasetFileError(f"{where}: field 'video_index': missing (and no questions.info.video_index)")
            tid = _template_id(where, q.template_filename, q.question_family_index,
                               getattr(q, "template_id", None))
            out.append(Question(
                video_index=vi, question_index=q.question_index, template_id=tid, answer=q.answer,
                question=q.question, program=tuple(q.program), video=q.video or f"{vi:06d}",
                simulation_id=None if video.simulation_id is None else str(video.simulation_id), where=where,
            ))
    _check_unique(out)
    return out


def parse_minimal(data: Any, name: str = "dataset_minimal.json") -> list[Question]:
    """The questions of a parsed ``dataset_minimal.json`` (flat list); errors name file, record and field."""
    if not isinstance(data, list):
        raise DatasetFileError(f"{name}: expected a JSON list of question records, found {type(data).__name__}")
    out: list[Question] = []
    for i, raw in enumerate(data):
        where = f"{name}: record {i}"
        try:
            q = _MinimalQuestion.model_validate(raw)
        except ValidationError as err:
            raise DatasetFileError(f"{where}: {_validation_message(err)}") from None
        tid = _template_id(where, q.template_filename, q.question_family_index, q.template_id)
        out.append(Question(
            video_index=q.video_index, question_index=q.question_index, template_id=tid, answer=q.answer,
            question=q.question, video=f"{q.video_index:06d}",
            simulation_id=None if q.simulation_id is None else str(q.simulation_id), where=where,
        ))
    _check_unique(out)
    return out


def parse_questions(data: Any, name: str = "questions") -> list[Question]:
    """Either format, recognised by its records: ``dataset.json`` videos hold a ``questions`` object."""
    if isinstance(data, list) and data and isinstance(data[0], Mapping) and isinstance(data[0].get("questions"),
                                                                                        Mapping):
        return parse_dataset(data, name)
    return parse_minimal(data, name)


def read_dataset(path: PathLike) -> list[Question]:
    """Read ``dataset.json`` (videos with question records holding programs and raw answers)."""
    return parse_dataset(_read_json(path, "dataset.json"), str(path))


def read_minimal(path: PathLike) -> list[Question]:
    """Read ``dataset_minimal.json`` (flat question records with string answers)."""
    return parse_minimal(_read_json(path, "dataset_minimal.json"), str(path))


def read_questions(path: PathLike) -> list[Question]:
    """Read either ``dataset.json`` or ``dataset_minimal.json`` (recognised by content)."""
    return parse_questions(_read_json(path, "questions"), str(path))


_KEY = re.compile(r"\s*([0-9]{1,12})_([0-9]{1,12})\s*")


def parse_key(key: Any) -> tuple[int, int] | None:
    """``(video_index, question_index)`` of a ``"<video_index>_<question_index>"`` key, or None."""
    if type(key) is not str:
        return None
    video, sep, question = key.partition("_")
    if sep and 0 < len(video) <= 12 and 0 < len(question) <= 12 and key.isascii() and video.isdigit() \
            and question.isdigit():
        return (int(video), int(question))  # the common case, without the regular expression
    m = _KEY.fullmatch(key)
    return (int(m.group(1)), int(m.group(2))) if m else None


def _key_problem(key: Any) -> str:
    return (f"key {describe(key)} is not '<video_index>_<question_index>' (e.g. '42_3'; each index 0 to "
            f"{MAX_INDEX:,})")


class PredictionEntries:
    """The entries of a predictions file (read as a stream) or of parsed predictions JSON.

    Three forms: an object ``{"<video_index>_<question_index>": value}``, a list of records
    ``[{"video_index", "question_index", ...}]`` and JSON Lines (``.jsonl``, one record per line; a record may give
    ``"key": "<v>_<q>"`` instead of the two indices). Iterating yields ``(key, value, label)``: ``key`` is
    ``(video_index, question_index)``, ``value`` the object's value or the whole record, ``label`` what
    :meth:`where` turns into the entry's place for messages. Keys are checked; values are the reader's business;
    a key given twice is the caller's to find (it knows which keys are the same).
    """

    def __init__(self, source: PathLike | Mapping[str, Any] | Sequence[Any], name: str | None = None) -> None:
        self.source = source
        self.in_memory = not isinstance(source, (str, os.PathLike))
        self.name = name or ("predictions" if self.in_memory else str(source))
        self.form = "lines" if not self.in_memory and Path(source).suffix == ".jsonl" else "object"  # type: ignore

    def where(self, label: Any) -> str:
        """The place of an entry: ``file: key '3_4'``, ``file: record 7`` or ``file: line 8``."""
        if self.form == "object":
            return f"{self.name}: key {describe(label)}"
        return f"{self.name}: {'line' if self.form == 'lines' else 'record'} {label}"

    def __iter__(self) -> Iterator[tuple[tuple[int, int], Any, Any]]:
        for label, value in self._items():
            if type(label) is str:
                self.form = "object"
                key = parse_key(label)
                if key is None:
                    raise PredictionsFileError(f"{self.name}: {_key_problem(label)}", path=self._path)
                yield key, value, label
            else:
                if self.form == "object":
                    self.form = "array"
                yield self._record_key(value, label), value, label

    def answers(self) -> Iterator[tuple[tuple[int, int], Any, Any]]:
        """``(key, answer, label)`` of every entry: the value, or the ``answer`` field of an object or record
        (see :func:`prediction_answer`). One loop for the common object form: it runs once per prediction."""
        items = self._items()
        for label, value in items:
            if type(label) is not str:
                for key, value2, label2 in self._records(label, value, items):
                    yield key, prediction_answer(value2, self, label2), label2
                return
            self.form = "object"
            video, sep, question = label.partition("_")
            if sep and len(label) <= 25 and label.isascii() and video.isdigit() and question.isdigit():
                key = (int(video), int(question))
            else:
                found = parse_key(label)
                if found is None:
                    raise PredictionsFileError(f"{self.name}: {_key_problem(label)}", path=self._path)
                key = found
            if type(value) is str and len(value) <= MAX_ANSWER_DIGITS:  # a short text is always a valid answer
                yield key, value, label
            else:
                yield key, prediction_answer(value, self, label), label

    def _records(self, label: Any, value: Any, items: Iterator[tuple[Any, Any]]) -> Iterator[tuple[Any, Any, Any]]:
        if self.form == "object":
            self.form = "array"
        yield self._record_key(value, label), value, label
        for label, value in items:
            yield self._record_key(value, label), value, label

    def _items(self) -> Iterator[tuple[Any, Any]]:
        if self.in_memory:
            return self._memory_items()
        if self.form == "lines":
            return iter_lines(self.source, "predictions file", error=PredictionsFileError)  # type: ignore[arg-type]
        return iter_members(self.source, "predictions file", error=PredictionsFileError)  # type: ignore[arg-type]

    @property
    def _path(self) -> str | None:
        return None if self.in_memory else self.name

    def _memory_items(self) -> Iterator[tuple[Any, Any]]:
        data = self.source
        if isinstance(data, Mapping):
            for k, v in data.items():
                yield (k if type(k) is str else describe(k)), v
        elif isinstance(data, list):
            yield from enumerate(data)
        else:
            raise PredictionsFileError(f"{self.name}: expected an object {{'<video>_<question>': answer}} or a list "
                                       f"of {{video_index, question_index, answer}}, found {type(data).__name__}")

    def _record_key(self, record: Any, label: Any) -> tuple[int, int]:
        if not isinstance(record, Mapping):
            raise PredictionsFileError(f"{self.where(label)}: expected an object with video_index and "
                                       f"question_index, found {describe(record)}", path=self._path)
        if "key" in record and "video_index" not in record and "question_index" not in record:
            key = parse_key(record["key"])
            if key is None:
                raise PredictionsFileError(f"{self.where(label)}, field 'key': {_key_problem(record['key'])}",
                                           path=self._path, field="key")
            return key
        out = []
        for name in ("video_index", "question_index"):
            v = record.get(name)
            if type(v) is not int or not 0 <= v <= MAX_INDEX:
                raise PredictionsFileError(f"{self.where(label)}, field '{name}': expected an integer from 0 to "
                                           f"{MAX_INDEX:,}, found {describe(v)}", path=self._path, field=name)
            out.append(v)
        return (out[0], out[1])


def repeated_prediction(key: tuple[int, int], first: str, second: str) -> PredictionsFileError:
    """The error for a question predicted twice, at the places ``first`` and ``second`` (``file: key '3_4'``)."""
    if first == second:
        return PredictionsFileError(f"{second} appears twice; a question may be predicted only once")
    name = first.rsplit(": ", 1)[0] + ": "
    shown = first.removeprefix(name) if second.startswith(name) else first
    return PredictionsFileError(f"{second}: question {key[0]}_{key[1]} is already predicted by {shown}")


def prediction_answer(value: Any, entries: PredictionEntries, label: Any) -> Any:
    """The answer of one entry: the value itself, or the ``answer`` field of an object or record."""
    if isinstance(value, Mapping):
        if "answer" not in value:
            raise PredictionsFileError(f"{entries.where(label)}, field 'answer': missing (scoring reads answers; "
                                       "`craft-dsl evaluate` reads programs, traces and distributions)",
                                       path=entries._path, field="answer")
        answer, at = value["answer"], f"{entries.where(label)}, field 'answer'"
    else:
        answer, at = value, entries.where(label)
    problem = answer_problem(answer)
    if problem is not None:
        raise PredictionsFileError(f"{at}: {problem}", path=entries._path)
    return answer


def parse_predictions(data: Any, name: str = "predictions") -> dict[tuple[int, int], Any]:
    """Predictions keyed by (video_index, question_index).

    Accepts ``{"<video_index>_<question_index>": answer}`` or ``[{"video_index", "question_index", "answer"}]``;
    an answer is a string, a number or a boolean (or an object whose ``answer`` field is one). A question
    predicted twice (``"3_4"`` and ``"03_4"`` too) is an error naming both entries.
    """
    return _collect(PredictionEntries(data, name))


def read_predictions(path: PathLike) -> dict[tuple[int, int], Any]:
    """Read a predictions file (``.json`` or ``.jsonl``; see :func:`parse_predictions`). For large files,
    :func:`craft_dsl.verify.score` reads the path itself as a stream instead of holding this dict."""
    return _collect(PredictionEntries(path))


def _collect(entries: PredictionEntries) -> dict[tuple[int, int], Any]:
    out: dict[tuple[int, int], Any] = {}
    labels: dict[tuple[int, int], Any] = {}
    for key, value, label in entries:
        answer = prediction_answer(value, entries, label)
        if key in out:
            raise repeated_prediction(key, entries.where(labels[key]), entries.where(label))
        out[key] = answer
        labels[key] = label
    return out


def parse_split(data: Any, part: str, name: str = "split") -> set[tuple[int, int]]:
    """The (video_index, question_index) keys of one part (train, validation, test) of a split file."""
    if not isinstance(data, Mapping):
        raise DatasetFileError(f"{name}: expected an object with 'train', 'validation', 'test', "
                               f"found {type(data).__name__}")
    if part not in data:
        raise DatasetFileError(f"{name}: has no part {describe(part)} (parts: "
                               f"{', '.join(describe(k)[1:-1] for k in sorted(map(str, data))[:10]) or 'none'})")
    items = data[part]
    if not isinstance(items, list):
        raise DatasetFileError(f"{name}: field '{part}': expected a list of {{video_index, question_index}}, "
                               f"found {type(items).__name__}")
    out = set()
    for i, raw in enumerate(items):
        try:
            k = _Key.model_validate(raw)
        except ValidationError as err:
            raise DatasetFileError(f"{name}: field '{part}', record {i}: {_validation_message(err)}") from None
        out.add((k.video_index, k.question_index))
    return out


def read_split(path: PathLike, part: str) -> set[tuple[int, int]]:
    """Read one part of ``split_info_random.json`` / ``split_info_hard.json``."""
    return parse_split(_read_json(path, "split"), part, str(path))
