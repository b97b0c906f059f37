"""Readers of the CRAFT file formats: dataset.json, dataset_minimal.json, predictions and splits."""

from __future__ import annotations

import json
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Union

from pydantic import BaseModel, ConfigDict, StrictInt, ValidationError, field_validator

from ..errors import CraftError
from ..templates import templates
from .categories import category_of, family_of, question_type_of

PathLike = Union[str, "os.PathLike[str]"]


def _read_json(path: PathLike, what: str) -> Any:
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CraftError(f"{p}: no such file ({what})") from None
    except IsADirectoryError:
        raise CraftError(f"{p}: is a directory, expected the {what} JSON file") from None
    except OSError as err:
        raise CraftError(f"{p}: cannot read ({err.strerror})") from None
    except UnicodeDecodeError as err:
        raise CraftError(f"{p}: not UTF-8 text ({err.reason} at byte {err.start})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise CraftError(
            f"{p}: not valid JSON (line {err.lineno}, column {err.colno}: {err.msg}); the file may be truncated"
        ) from None


def _validation_message(err: ValidationError) -> str:
    parts = []
    for e in err.errors()[:3]:
        loc = ".".join(str(x) for x in e["loc"])
        msg = e["msg"].removeprefix("Value error, ")
        parts.append(f"field '{loc}': {msg}" if loc else msg)
    more = len(err.errors()) - 3
    return "; ".join(parts) + (f" (and {more} more)" if more > 0 else "")


def _check_answer(value: Any) -> Any:
    if isinstance(value, (bool, int, str)):
        return value
    raise ValueError(f"must be a boolean, an integer or a string, found {json.dumps(value)}")


class _Record(BaseModel):
    model_config = ConfigDict(extra="allow")


class _DatasetQuestion(_Record):
    question: str = ""
    program: list[dict[str, Any]]
    answer: Any
    template_filename: str
    question_family_index: StrictInt
    question_index: StrictInt
    video_index: StrictInt | None = None
    video: str | None = None

    _answer = field_validator("answer")(_check_answer)


class _QuestionsBlock(_Record):
    info: dict[str, Any] = {}
    questions: list[Any]


class _DatasetVideo(_Record):
    simulation_id: str | StrictInt | None = None
    video_path: str | None = None
    questions: _QuestionsBlock


class _MinimalQuestion(_Record):
    question: str = ""
    answer: Any
    answer_type: str | None = None
    template_filename: str | None = None
    question_family_index: StrictInt | None = None
    template_id: str | None = None
    video_index: StrictInt
    question_index: StrictInt
    simulation_id: str | StrictInt | None = None
    question_type: str | None = None

    _answer = field_validator("answer")(_check_answer)


class _Key(_Record):
    video_index: StrictInt
    question_index: StrictInt


def _check_prediction(value: Any) -> Any:
    if isinstance(value, (bool, int, float, str)):
        return value
    raise ValueError(f"must be a string, a number or a boolean, found {json.dumps(value)}")


class _Prediction(_Key):
    answer: Any

    _answer = field_validator("answer")(_check_prediction)


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
        raise CraftError(f"{where}: needs 'template_id', or 'template_filename' and 'question_family_index'")
    if given and derived and given != derived:
        raise CraftError(f"{where}: template_id {given!r} disagrees with template_filename/question_family_index "
                         f"({derived!r})")
    if tid not in templates():
        field_name = "template_id" if given else "template_filename/question_family_index"
        raise CraftError(f"{where}: field '{field_name}': {tid!r} is not a CRAFT template id "
                         "(descriptive_0-39, counterfactual_0-8, cause/enable/prevent_0-5)")
    return tid


def _check_unique(questions: Sequence[Question]) -> None:
    seen: dict[tuple[int, int], str] = {}
    for q in questions:
        if q.key in seen:
            raise CraftError(f"{q.where}: video_index {q.video_index}, question_index {q.question_index} "
                             f"already used by {seen[q.key]}")
        seen[q.key] = q.where


def parse_dataset(data: Any, name: str = "dataset.json") -> list[Question]:
    """The questions of a parsed ``dataset.json`` (list of videos); errors name file, record and field."""
    if not isinstance(data, list):
        raise CraftError(f"{name}: expected a JSON list of video records, found {type(data).__name__}")
    out: list[Question] = []
    for i, raw_video in enumerate(data):
        vwhere = f"{name}: video record {i}"
        try:
            video = _DatasetVideo.model_validate(raw_video)
        except ValidationError as err:
            raise CraftError(f"{vwhere}: {_validation_message(err)}") from None
        info_index = video.questions.info.get("video_index")
        for j, raw_q in enumerate(video.questions.questions):
            where = f"{vwhere}, question {j}"
            try:
                q = _DatasetQuestion.model_validate(raw_q)
            except ValidationError as err:
                raise CraftError(f"{where}: {_validation_message(err)}") from None
            vi = q.video_index if q.video_index is not None else info_index
            if not isinstance(vi, int) or isinstance(vi, bool):
                raise CraftError(f"{where}: field 'video_index': missing (and no questions.info.video_index)")
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
        raise CraftError(f"{name}: expected a JSON list of question records, found {type(data).__name__}")
    out: list[Question] = []
    for i, raw in enumerate(data):
        where = f"{name}: record {i}"
        try:
            q = _MinimalQuestion.model_validate(raw)
        except ValidationError as err:
            raise CraftError(f"{where}: {_validation_message(err)}") from None
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


_KEY = re.compile(r"\s*(\d+)_(\d+)\s*")


def parse_predictions(data: Any, name: str = "predictions") -> dict[tuple[int, int], Any]:
    """Predictions keyed by (video_index, question_index).

    Accepts ``{"<video_index>_<question_index>": answer}`` or ``[{"video_index", "question_index", "answer"}]``;
    an answer is a string, a number or a boolean. A key given twice is an error.
    """
    out: dict[tuple[int, int], Any] = {}
    if isinstance(data, Mapping):
        for key, value in data.items():
            m = _KEY.fullmatch(str(key))
            if not m:
                raise CraftError(f"{name}: key {key!r} is not '<video_index>_<question_index>' (e.g. '42_3')")
            if not isinstance(value, (str, int, float, bool)):
                raise CraftError(f"{name}: key {key!r}: the answer must be a string, a number or a boolean, "
                                 f"found {json.dumps(value)}")
            k = (int(m.group(1)), int(m.group(2)))
            if k in out:
                raise CraftError(f"{name}: key {key!r} names question {k[0]}_{k[1]}, which is already predicted")
            out[k] = value
        return out
    if isinstance(data, list):
        for i, raw in enumerate(data):
            try:
                p = _Prediction.model_validate(raw)
            except ValidationError as err:
                raise CraftError(f"{name}: record {i}: {_validation_message(err)}") from None
            k = (p.video_index, p.question_index)
            if k in out:
                raise CraftError(f"{name}: record {i}: question {k[0]}_{k[1]} is already predicted")
            out[k] = p.answer
        return out
    raise CraftError(f"{name}: expected an object {{'<video>_<question>': answer}} or a list of "
                     f"{{video_index, question_index, answer}}, found {type(data).__name__}")


def read_predictions(path: PathLike) -> dict[tuple[int, int], Any]:
    """Read a predictions file (see :func:`parse_predictions`)."""
    return parse_predictions(_read_json(path, "predictions"), str(path))


def parse_split(data: Any, part: str, name: str = "split") -> set[tuple[int, int]]:
    """The (video_index, question_index) keys of one part (train, validation, test) of a split file."""
    if not isinstance(data, Mapping):
        raise CraftError(f"{name}: expected an object with 'train', 'validation', 'test', found {type(data).__name__}")
    if part not in data:
        raise CraftError(f"{name}: has no part {part!r} (parts: {', '.join(sorted(map(str, data))) or 'none'})")
    items = data[part]
    if not isinstance(items, list):
        raise CraftError(f"{name}: field '{part}': expected a list of {{video_index, question_index}}, "
                         f"found {type(items).__name__}")
    out = set()
    for i, raw in enumerate(items):
        try:
            k = _Key.model_validate(raw)
        except ValidationError as err:
            raise CraftError(f"{name}: field '{part}', record {i}: {_validation_message(err)}") from None
        out.add((k.video_index, k.question_index))
    return out


def read_split(path: PathLike, part: str) -> set[tuple[int, int]]:
    """Read one part of ``split_info_random.json`` / ``split_info_hard.json`` (spec §6.7)."""
    return parse_split(_read_json(path, "split"), part, str(path))
