"""Verification of CRAFT datasets and scoring of model predictions.

Two tools for a researcher holding the published CRAFT dataset (or one written in its formats):

* :func:`verify_dataset` re-answers every question of a ``dataset.json`` by running its saved program
  (``Program.from_nodes``) over its video's simulation from ``annotations.json``, and lists the questions whose
  recorded answer differs, and those that could not be re-answered (unreadable program, missing simulation).
* :func:`score` scores a model's predictions against ``dataset_minimal.json`` (or ``dataset.json``): accuracy
  overall, per paper column (C, CF, D, All), per paper sub-category (README §5), per question type and per
  template, optionally on one part of a split file; :data:`PAPER_RESULTS` holds the published numbers.

Formats (spec ``original-question-engine.md`` §4.9, §6.7-§6.11):

* ``dataset.json``: list of videos ``{"simulation_id", "video_path", "questions": {"info", "questions": [...]}}``;
  each question has ``program`` (node list with ``value_inputs``; ``_output`` is ignored), ``answer`` (raw JSON:
  bool, int, lowercase string), ``template_filename``, ``question_family_index``, ``question_index``,
  ``video_index`` (and ``video``, the id6 file stem);
* ``dataset_minimal.json``: flat list of ``{"question", "answer" (a string: "True", "2", "Red"), "answer_type",
  "template_filename", "template_id", "video_index", "question_index", "question_family_index",
  "simulation_id", "question_type"}``;
* ``annotations.json``: ``{"<id6>": <simulation with variations>}``. It can be several gigabytes, so it is
  indexed in one streaming pass and each simulation is parsed only when asked for (a directory of
  ``<id6>.json`` files, or an in-memory mapping, work too);
* split files: ``{"train": [{"video_index", "question_index"}, ...], "validation": [...], "test": [...]}``;
* predictions: ``{"<video_index>_<question_index>": answer}`` or ``[{"video_index", "question_index",
  "answer"}, ...]``.

Answers are compared after :func:`normalise_answer` (case, whitespace, booleans, yes/no, numbers).
"""

from __future__ import annotations

import codecs
import json
import os
import re
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Union

from pydantic import BaseModel, ConfigDict, StrictInt, ValidationError, field_validator

from .errors import CraftError
from .program import Program, to_json
from .simulation import Simulation
from .templates import DROPPED, question_text, templates

PathLike = Union[str, "os.PathLike[str]"]

# -- paper categories ----------------------------------------------------------------------------------------

#: The paper's columns: C (cause, enable, prevent), CF (counterfactual), D (descriptive).
FAMILIES: tuple[str, ...] = ("C", "CF", "D")
#: The paper's sub-categories, in table order (README §5).
CATEGORIES: tuple[str, ...] = ("D/2Q", "D/N-V", "D/N-T", "D/C", "D/S", "D/C-T", "D/TO", "CF/O", "CF/N", "C/A", "C/N")
#: Question types (the capitalised template file stems of ``question_type``).
QUESTION_TYPES: tuple[str, ...] = ("Descriptive", "Counterfactual", "Cause", "Enable", "Prevent")

_DESCRIPTIVE_RANGES = ((0, 3, "D/2Q"), (4, 15, "D/N-V"), (16, 21, "D/N-T"), (22, 23, "D/C"), (24, 25, "D/S"),
                       (26, 37, "D/C-T"), (38, 39, "D/TO"))


def _split_template_id(template_id: str) -> tuple[str, int]:
    if template_id not in templates():
        raise CraftError(f"{template_id!r} is not a CRAFT template id (e.g. 'descriptive_0' ... 'prevent_5')")
    family, index = template_id.rsplit("_", 1)
    return family, int(index)


def family_of(template_id: str) -> str:
    """The paper's column of a template: ``"D"``, ``"CF"`` or ``"C"`` (cause, enable, prevent)."""
    family, _ = _split_template_id(template_id)
    return {"descriptive": "D", "counterfactual": "CF"}.get(family, "C")


def category_of(template_id: str) -> str:
    """The paper's sub-category of a template (README §5), e.g. ``category_of("descriptive_22") == "D/C"``."""
    family, i = _split_template_id(template_id)
    if family == "descriptive":
        return next(code for lo, hi, code in _DESCRIPTIVE_RANGES if lo <= i <= hi)
    if family == "counterfactual":
        return "CF/N" if 3 <= i <= 5 else "CF/O"
    return "C/N" if 3 <= i <= 5 else "C/A"


def question_type_of(template_id: str) -> str:
    """``"Descriptive"``, ``"Counterfactual"``, ``"Cause"``, ``"Enable"`` or ``"Prevent"``."""
    return _split_template_id(template_id)[0].capitalize()


# -- published results ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PaperRow:
    """One row of the paper's main table: accuracies (%) as (C, CF, D, All) on the easy and hard splits."""

    group: str
    model: str
    easy: tuple[float, float, float, float]
    hard: tuple[float, float, float, float]


#: The CRAFT paper's test accuracies (spec ``paper-results.md``), columns (C, CF, D, All).
PAPER_RESULTS: tuple[PaperRow, ...] = (
    PaperRow("heuristic", "Random", (5.95, 5.25, 5.09, 5.24), (5.37, 4.62, 5.08, 4.98)),
    PaperRow("heuristic", "AT-Random", (36.67, 44.34, 33.95, 37.47), (33.67, 46.06, 34.16, 37.52)),
    PaperRow("heuristic", "MFA", (32.68, 43.28, 23.53, 30.72), (30.09, 43.94, 23.20, 29.98)),
    PaperRow("heuristic", "AT-MFA", (49.62, 47.21, 37.57, 42.03), (49.28, 47.17, 36.55, 41.12)),
    PaperRow("text-only", "LSTM", (53.04, 53.14, 38.29, 44.69), (52.51, 56.24, 37.25, 44.52)),
    PaperRow("text-only", "BERT", (48.43, 50.59, 37.55, 42.90), (49.28, 52.12, 36.52, 42.52)),
    PaperRow("single frame", "LSTM-CNN-F", (53.11, 55.23, 44.86, 49.07), (48.07, 48.12, 35.54, 40.64)),
    PaperRow("single frame", "LSTM-CNN-L", (54.86, 55.63, 43.12, 48.42), (49.86, 54.44, 38.88, 44.66)),
    PaperRow("single frame", "MAC-F", (53.18, 52.88, 44.40, 48.10), (51.86, 53.5, 42.12, 46.55)),
    PaperRow("single frame", "MAC-L", (49.97, 53.08, 44.54, 47.83), (50.21, 53.8, 41.46, 46.05)),
    PaperRow("video", "LSTM-CNN-V", (54.65, 61.42, 48.12, 53.01), (51.86, 54.89, 41.36, 46.50)),
    PaperRow("video", "MAC-V", (53.95, 57.72, 44.51, 49.74), (51.22, 54.71, 42.94, 47.31)),
    PaperRow("video", "TVQA", (53.67, 55.57, 36.89, 44.71), (51.00, 55.12, 36.31, 43.46)),
    PaperRow("video", "TVQA+", (54.86, 60.02, 40.22, 48.11), (51.00, 55.12, 39.09, 45.12)),
    PaperRow("video", "G-SWM", (53.54, 55.29, 37.05, 44.69), (51.00, 48.68, 37.77, 42.47)),
    PaperRow("oracle", "LSTM-D", (51.71, 55.89, 63.22, 59.53), (51.93, 56.00, 59.57, 57.64)),
    PaperRow("oracle", "BERT-D", (68.44, 80.05, 93.41, 86.20), (66.33, 79.34, 91.30, 84.90)),
)
#: Humans (481 questions, one study, not split-specific): (C, CF, D, All).
PAPER_HUMANS: tuple[float, float, float, float] = (71.27, 83.07, 87.45, 76.60)


# -- answers ----------------------------------------------------------------------------------------------------

_INT = re.compile(r"[+-]?\d+")
_INTEGRAL_FLOAT = re.compile(r"[+-]?\d+\.0*")
_BOOL_WORDS = {"true": "true", "yes": "true", "false": "false", "no": "false"}


def normalise_answer(value: Any) -> str:
    """The comparison key of an answer.

    * strings are stripped and lower-cased (``"Red"`` and ``"red"`` agree, so do ``"Cube"`` and ``"cube"``);
    * booleans: ``True``, ``"True"``, ``"true"`` and ``"yes"`` all become ``"true"``; likewise ``False``,
      ``"False"``, ``"no"`` become ``"false"`` (no CRAFT answer is literally "yes" or "no");
    * numbers: ``2``, ``2.0``, ``"2"``, ``" 02 "`` all become ``"2"``; a non-integral number keeps its text;
    * anything else (``None``, lists) becomes its JSON text, which matches no answer.

    No other synonyms are applied (``"grey"`` does not match ``"gray"``, ``"ball"`` not ``"circle"``).
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() else repr(value)
    if not isinstance(value, str):
        return json.dumps(value, sort_keys=True)
    text = value.strip().lower()
    if text in _BOOL_WORDS:
        return _BOOL_WORDS[text]
    if _INT.fullmatch(text) or _INTEGRAL_FLOAT.fullmatch(text):
        return str(int(float(text)))
    return text


def answers_agree(a: Any, b: Any) -> bool:
    """Whether two answers are the same after :func:`normalise_answer`."""
    return normalise_answer(a) == normalise_answer(b)


# -- reading JSON -----------------------------------------------------------------------------------------------


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


# -- annotations ----------------------------------------------------------------------------------------------

_WS = re.compile(r"[ \t\n\r]*")


class _Stream:
    """Incremental reader of one JSON document, keeping byte offsets of what it decodes."""

    def __init__(self, fh: IO[bytes], where: str, chunk_size: int) -> None:
        self.fh = fh
        self.where = where
        self.chunk_size = chunk_size
        self.decoder = codecs.getincrementaldecoder("utf-8")()
        self.json = json.JSONDecoder()
        self.text = ""
        self.base = 0  # byte offset of text[0]
        self.ascii = True
        self.i = 0
        self.eof = False

    def more(self) -> bool:
        if self.eof:
            return False
        data = self.fh.read(self.chunk_size)
        try:
            new = self.decoder.decode(data, final=not data)
        except UnicodeDecodeError as err:
            raise CraftError(f"{self.where}: not UTF-8 text near byte {self.base + len(self.text)}: "
                             f"{err.reason}") from None
        if not data:
            self.eof = True
        consumed = self.text[: self.i]
        self.base += len(consumed) if self.ascii else len(consumed.encode("utf-8"))
        self.text = self.text[self.i:] + new
        self.i = 0
        self.ascii = self.text.isascii()
        return True

    def offset(self, i: int) -> int:
        return self.base + (i if self.ascii else len(self.text[:i].encode("utf-8")))

    def peek(self) -> str:
        while True:
            self.i = _WS.match(self.text, self.i).end()  # type: ignore[union-attr]
            if self.i < len(self.text):
                return self.text[self.i]
            if not self.more():
                return ""

    def expect(self, chars: str, what: str) -> str:
        c = self.peek()
        if not c or c not in chars:
            found = repr(c) if c else "the end of the file (truncated?)"
            raise CraftError(f"{self.where}: expected {what} at byte {self.offset(self.i)}, found {found}")
        self.i += 1
        return c

    def value(self) -> tuple[Any, int, int]:
        """Decode the next value; return it with its byte span."""
        self.peek()
        while True:
            try:
                value, end = self.json.raw_decode(self.text, self.i)
            except json.JSONDecodeError as err:
                if self.more():
                    continue
                raise CraftError(f"{self.where}: not valid JSON at byte {self.offset(err.pos)}: {err.msg} "
                                 "(the file may be truncated)") from None
            if end == len(self.text) and self.more():
                continue  # a number may go on in the next chunk
            start = self.offset(self.i)
            self.i = end
            return value, start, self.offset(end)


def index_json_object(path: PathLike, chunk_size: int = 1 << 24) -> dict[str, tuple[int, int]]:
    """Byte spans ``{key: (start, end)}`` of the values of a top-level JSON object, in one streaming pass.

    Memory stays at about ``chunk_size`` plus one value, whatever the file size.
    """
    where = str(path)
    spans: dict[str, tuple[int, int]] = {}
    with open(path, "rb") as fh:
        s = _Stream(fh, where, chunk_size)
        s.expect("{", "a JSON object mapping video ids to simulations ('{')")
        if s.peek() == "}":
            return spans
        while True:
            if s.peek() != '"':
                s.expect('"', "a key string")
            key, _, _ = s.value()
            s.expect(":", "':'")
            _, start, end = s.value()
            if key in spans:
                raise CraftError(f"{where}: key {key!r} appears twice")
            spans[key] = (start, end)
            if s.expect(",}", "',' or '}'") == "}":
                break
        if s.peek():
            raise CraftError(f"{where}: extra data after the top-level object at byte {s.offset(s.i)}")
    return spans


class Annotations:
    """Simulations by video id (``"000042"``), loaded on demand.

    Build with :meth:`open` (``annotations.json``, or a directory of ``<id6>.json`` files) or
    :meth:`from_mapping` (an in-memory dict, e.g. from :func:`build_dataset`). A few recently used
    simulations are cached.
    """

    def __init__(self, name: str, loader: Callable[[str], Any], ids: Iterable[str], cache: int = 4) -> None:
        self.name = name
        self._loader = loader
        self._ids = list(ids)
        self._set = set(self._ids)
        self._cache: OrderedDict[str, Simulation] = OrderedDict()
        self._cache_size = cache

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], name: str = "annotations") -> Annotations:
        if not isinstance(data, Mapping):
            raise CraftError(f"{name}: expected an object mapping video ids to simulations, "
                             f"found {type(data).__name__}")
        return cls(name, lambda key: data[key], (str(k) for k in data))

    @classmethod
    def open(cls, path: PathLike, chunk_size: int = 1 << 24) -> Annotations:
        p = Path(path)
        if p.is_dir():
            files = {f.stem: f for f in sorted(p.rglob("*.json")) if f.stem.isdigit()}
            if not files:
                raise CraftError(f"{p}: directory holds no <id6>.json simulation files")
            return cls(str(p), lambda key: _read_json(files[key], "simulation"), files)
        if not p.exists():
            raise CraftError(f"{p}: no such file (annotations)")
        try:
            spans = index_json_object(p, chunk_size)
        except OSError as err:
            raise CraftError(f"{p}: cannot read ({err.strerror})") from None

        def load(key: str) -> Any:
            start, end = spans[key]
            with open(p, "rb") as fh:
                fh.seek(start)
                return json.loads(fh.read(end - start))

        return cls(str(p), load, spans)

    def ids(self) -> list[str]:
        """Every video id, in file order."""
        return list(self._ids)

    def __len__(self) -> int:
        return len(self._ids)

    def __contains__(self, key: object) -> bool:
        return key in self._set

    def resolve(self, video: str, video_index: int) -> str | None:
        """The key of a video: its id6 name, or its index written plainly; None if absent."""
        for key in (video, f"{video_index:06d}", str(video_index)):
            if key in self._set:
                return key
        return None

    def raw(self, key: str) -> Any:
        """The parsed JSON of one simulation."""
        if key not in self._set:
            raise CraftError(f"{self.name}: no simulation for video {key!r}")
        return self._loader(key)

    def simulation(self, key: str) -> Simulation:
        """One simulation, validated by :func:`craft_dsl.load_simulation`."""
        from .recorded import load_simulation

        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        data = self.raw(key)
        if not isinstance(data, Mapping):
            raise CraftError(f"{self.name}[{key!r}]: expected a simulation object, found {type(data).__name__}")
        try:
            sim = load_simulation(data)
        except CraftError as err:
            raise CraftError(f"{self.name}[{key!r}]: {str(err).removeprefix('<dict>: ')}") from None
        self._cache[key] = sim
        if len(self._cache) > self._cache_size:
            self._cache.popitem(last=False)
        return sim


def open_annotations(source: PathLike | Mapping[str, Any] | Annotations) -> Annotations:
    """An :class:`Annotations` from a path (file or directory), a mapping, or an existing one."""
    if isinstance(source, Annotations):
        return source
    if isinstance(source, Mapping):
        return Annotations.from_mapping(source)
    return Annotations.open(source)


# -- verification ---------------------------------------------------------------------------------------------


@dataclass
class Tally:
    """Verification counts of one group of questions: total = agree + mismatch + error."""

    total: int = 0
    agree: int = 0
    mismatch: int = 0
    error: int = 0

    def to_json(self) -> dict[str, int]:
        return {"total": self.total, "agree": self.agree, "mismatch": self.mismatch, "error": self.error}


@dataclass(frozen=True)
class Mismatch:
    """A question whose recorded answer differs from the recomputed one."""

    video_index: int
    question_index: int
    template_id: str
    program: str
    question: str
    recorded: Any
    recomputed: Any

    def to_json(self) -> dict[str, Any]:
        return {"video_index": self.video_index, "question_index": self.question_index,
                "template_id": self.template_id, "program": self.program, "question": self.question,
                "recorded": self.recorded, "recomputed": self.recomputed}


@dataclass(frozen=True)
class VerifyError:
    """A question that could not be re-answered. ``kind``: program, simulation or evaluation."""

    video_index: int
    question_index: int
    template_id: str
    kind: str
    message: str

    def to_json(self) -> dict[str, Any]:
        return {"video_index": self.video_index, "question_index": self.question_index,
                "template_id": self.template_id, "kind": self.kind, "message": self.message}


@dataclass
class VerifyReport:
    """Result of :func:`verify_dataset`."""

    videos: int = 0
    totals: Tally = field(default_factory=Tally)
    per_template: dict[str, Tally] = field(default_factory=dict)
    per_category: dict[str, Tally] = field(default_factory=dict)
    mismatches: list[Mismatch] = field(default_factory=list)
    errors: list[VerifyError] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when every question was re-answered and agrees."""
        return self.totals.agree == self.totals.total

    def _add(self, q: Question, outcome: str) -> None:
        for t in (self.totals, self.per_template.setdefault(q.template_id, Tally()),
                  self.per_category.setdefault(q.category, Tally())):
            t.total += 1
            setattr(t, outcome, getattr(t, outcome) + 1)

    def to_json(self, max_items: int | None = None) -> dict[str, Any]:
        mm = self.mismatches if max_items is None else self.mismatches[:max_items]
        ee = self.errors if max_items is None else self.errors[:max_items]
        return {
            "ok": self.ok, "videos": self.videos, **self.totals.to_json(),
            "per_category": {c: self.per_category[c].to_json() for c in CATEGORIES if c in self.per_category},
            "per_template": {t: self.per_template[t].to_json() for t in templates() if t in self.per_template},
            "mismatches": [m.to_json() for m in mm], "mismatches_omitted": len(self.mismatches) - len(mm),
            "errors": [e.to_json() for e in ee], "errors_omitted": len(self.errors) - len(ee),
        }

    def format(self, max_items: int = 20) -> str:
        """A plain-text report."""
        t = self.totals
        lines = [f"verified {t.total} questions over {self.videos} videos: {t.agree} agree, "
                 f"{t.mismatch} mismatch(es), {t.error} error(s)", ""]
        lines.append(f"{'category':<10} {'total':>7} {'agree':>7} {'mismatch':>9} {'error':>7}")
        for c in CATEGORIES:
            if c in self.per_category:
                x = self.per_category[c]
                lines.append(f"{c:<10} {x.total:>7} {x.agree:>7} {x.mismatch:>9} {x.error:>7}")
        bad = [tid for tid in templates() if tid in self.per_template and self.per_template[tid].agree
               != self.per_template[tid].total]
        if bad:
            lines += ["", "templates with disagreements:"]
            for tid in bad:
                x = self.per_template[tid]
                lines.append(f"  {tid:<18} {x.total:>6} questions, {x.mismatch} mismatch(es), {x.error} error(s)")
        if self.mismatches:
            lines += ["", f"mismatches ({min(max_items, len(self.mismatches))} of {len(self.mismatches)}):"]
            for m in self.mismatches[:max_items]:
                lines.append(f"  video {m.video_index} question {m.question_index} ({m.template_id}): recorded "
                             f"{json.dumps(m.recorded)}, recomputed {json.dumps(m.recomputed)}")
                if m.question:
                    lines.append(f"    question: {m.question}")
                lines.append(f"    program:  {m.program.replace(chr(10), '; ')}")
        if self.errors:
            lines += ["", f"errors ({min(max_items, len(self.errors))} of {len(self.errors)}):"]
            for e in self.errors[:max_items]:
                lines.append(f"  video {e.video_index} question {e.question_index} ({e.template_id}): "
                             f"{e.kind}: {e.message}")
        return "\n".join(lines)


def _as_questions(dataset: PathLike | Sequence[Any]) -> list[Question]:
    if isinstance(dataset, (str, os.PathLike)):
        return read_dataset(dataset)
    items = list(dataset)
    if items and all(isinstance(q, Question) for q in items):
        return items
    return parse_dataset(items, "dataset")


def verify_dataset(
    dataset: PathLike | Sequence[Any],
    annotations: PathLike | Mapping[str, Any] | Annotations,
    progress: Callable[[int], None] | None = None,
) -> VerifyReport:
    """Re-answer every question of ``dataset`` over its video's simulation and compare with the recorded answer.

    ``dataset`` is a ``dataset.json`` path, its parsed list, or :class:`Question` records with programs;
    ``annotations`` a path, a mapping ``{id6: simulation dict}`` or an :class:`Annotations`. Questions whose
    program cannot be read, whose simulation is missing or malformed, or whose evaluation fails are reported
    in ``errors``; they never stop the run. ``progress(n)`` is called after each video with its question count.
    """
    questions = _as_questions(dataset)
    store = open_annotations(annotations)
    report = VerifyReport()
    by_video: dict[tuple[int, str], list[Question]] = {}
    for q in questions:
        by_video.setdefault((q.video_index, q.video), []).append(q)
    for (video_index, video), group in by_video.items():
        report.videos += 1
        sim: Simulation | None = None
        sim_error = ""
        key = store.resolve(video, video_index)
        if key is None:
            sim_error = f"no simulation for video {video!r} (video_index {video_index}) in {store.name}"
        else:
            try:
                sim = store.simulation(key)
            except CraftError as err:
                sim_error = str(err)
        for q in group:
            _verify_one(q, sim, sim_error, report)
        if progress is not None:
            progress(len(group))
    return report


def _verify_one(q: Question, sim: Simulation | None, sim_error: str, report: VerifyReport) -> None:
    def error(kind: str, message: str) -> None:
        report.errors.append(VerifyError(q.video_index, q.question_index, q.template_id, kind, message))
        report._add(q, "error")

    if q.program is None:
        error("program", "the record has no program (dataset_minimal.json records cannot be verified)")
        return
    try:
        program = Program.from_nodes(q.program)
    except CraftError as err:
        error("program", f"cannot read the program: {err}")
        return
    if sim is None:
        error("simulation", sim_error)
        return
    try:
        answer = to_json(program.run(sim), original=True)
    except CraftError as err:
        error("evaluation", str(err))
        return
    if answers_agree(answer, q.answer):
        report._add(q, "agree")
    else:
        report.mismatches.append(Mismatch(q.video_index, q.question_index, q.template_id, str(program),
                                          q.question, q.answer, answer))
        report._add(q, "mismatch")


# -- scoring ----------------------------------------------------------------------------------------------------


@dataclass
class Score:
    """Accuracy of one group: ``correct`` of ``total`` (``missing`` of them had no prediction)."""

    total: int = 0
    correct: int = 0
    missing: int = 0

    @property
    def accuracy(self) -> float | None:
        """Percentage correct, or None for an empty group."""
        return 100.0 * self.correct / self.total if self.total else None

    def to_json(self) -> dict[str, Any]:
        return {"total": self.total, "correct": self.correct, "missing": self.missing, "accuracy": self.accuracy}


@dataclass
class ScoreReport:
    """Result of :func:`score`. ``columns`` holds the paper's C, CF, D and All."""

    columns: dict[str, Score] = field(default_factory=lambda: {k: Score() for k in (*FAMILIES, "All")})
    per_category: dict[str, Score] = field(default_factory=dict)
    per_type: dict[str, Score] = field(default_factory=dict)
    per_template: dict[str, Score] = field(default_factory=dict)
    predicted: int = 0
    unknown_predictions: list[tuple[int, int]] = field(default_factory=list)
    outside_split: int = 0
    split_not_in_questions: int = 0
    dropped_templates: int = 0

    @property
    def total(self) -> int:
        return self.columns["All"].total

    @property
    def missing(self) -> int:
        return self.columns["All"].missing

    @property
    def coverage(self) -> float | None:
        """Percentage of the scored questions that have a prediction."""
        return 100.0 * self.predicted / self.total if self.total else None

    def _add(self, q: Question, correct: bool, missing: bool) -> None:
        for s in (self.columns["All"], self.columns[q.family], self.per_category.setdefault(q.category, Score()),
                  self.per_type.setdefault(q.question_type, Score()),
                  self.per_template.setdefault(q.template_id, Score())):
            s.total += 1
            s.correct += correct
            s.missing += missing

    def to_json(self) -> dict[str, Any]:
        return {
            "questions": self.total, "predicted": self.predicted, "missing": self.missing,
            "coverage": self.coverage,
            "unknown_predictions": [f"{v}_{q}" for v, q in self.unknown_predictions],
            "outside_split": self.outside_split, "split_not_in_questions": self.split_not_in_questions,
            "dropped_templates": self.dropped_templates,
            "accuracy": {k: s.accuracy for k, s in self.columns.items()},
            "columns": {k: s.to_json() for k, s in self.columns.items()},
            "per_category": {c: self.per_category[c].to_json() for c in CATEGORIES if c in self.per_category},
            "per_type": {t: self.per_type[t].to_json() for t in QUESTION_TYPES if t in self.per_type},
            "per_template": {t: self.per_template[t].to_json() for t in templates() if t in self.per_template},
        }

    def format(self, per_template: bool = False, compare_paper: str | None = None, label: str = "yours") -> str:
        """A plain-text report; ``compare_paper`` ("easy" or "hard") adds the paper's rows."""
        lines = [f"scored {self.total} questions: {self.predicted} predicted "
                 f"({_pct(self.coverage)} % coverage), {self.missing} without prediction (counted wrong)"]
        if self.unknown_predictions:
            shown = ", ".join(f"{v}_{q}" for v, q in self.unknown_predictions[:5])
            more = " ..." if len(self.unknown_predictions) > 5 else ""
            lines.append(f"{len(self.unknown_predictions)} prediction(s) for unknown questions ignored: {shown}{more}")
        if self.outside_split:
            lines.append(f"{self.outside_split} prediction(s) for questions outside the selected split ignored")
        if self.split_not_in_questions:
            lines.append(f"{self.split_not_in_questions} question(s) of the split are not in the questions file")
        if self.dropped_templates:
            lines.append(f"note: {self.dropped_templates} question(s) come from the 19 templates the paper drops")
        lines += ["", f"{'':<14}" + "".join(f"{k:>8}" for k in (*FAMILIES, "All"))]
        lines.append(f"{'accuracy %':<14}" + "".join(f"{_pct(self.columns[k].accuracy):>8}"
                                                    for k in (*FAMILIES, "All")))
        lines.append(f"{'questions':<14}" + "".join(f"{self.columns[k].total:>8}" for k in (*FAMILIES, "All")))
        lines += ["", f"{'category':<10} {'accuracy %':>10} {'correct':>8} {'total':>7} {'missing':>8}"]
        for c in CATEGORIES:
            if c in self.per_category:
                s = self.per_category[c]
                lines.append(f"{c:<10} {_pct(s.accuracy):>10} {s.correct:>8} {s.total:>7} {s.missing:>8}")
        lines += ["", f"{'type':<15} {'accuracy %':>10} {'correct':>8} {'total':>7}"]
        for t in QUESTION_TYPES:
            if t in self.per_type:
                s = self.per_type[t]
                lines.append(f"{t:<15} {_pct(s.accuracy):>10} {s.correct:>8} {s.total:>7}")
        if per_template:
            lines += ["", f"{'template':<18} {'category':<7} {'accuracy %':>10} {'correct':>8} {'total':>7}"]
            for tid in templates():
                if tid in self.per_template:
                    s = self.per_template[tid]
                    lines.append(f"{tid:<18} {category_of(tid):<7} {_pct(s.accuracy):>10} {s.correct:>8} "
                                 f"{s.total:>7}")
        if compare_paper:
            lines += ["", paper_table(compare_paper, self, label)]
        return "\n".join(lines)


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def paper_table(split: str, report: ScoreReport | None = None, label: str = "yours") -> str:
    """The paper's test accuracies on ``split`` ("easy" or "hard"), with the report's row appended."""
    if split not in ("easy", "hard"):
        raise CraftError(f"--compare-paper takes 'easy' or 'hard', not {split!r}")
    head = f"{'group':<13} {'model':<12}" + "".join(f"{k:>8}" for k in (*FAMILIES, "All"))
    lines = [f"CRAFT paper, {split} split (test accuracy %)", head]
    for row in PAPER_RESULTS:
        values = row.easy if split == "easy" else row.hard
        lines.append(f"{row.group:<13} {row.model:<12}" + "".join(f"{v:>8.2f}" for v in values))
    lines.append(f"{'humans':<13} {'(481 q.)':<12}" + "".join(f"{v:>8.2f}" for v in PAPER_HUMANS))
    if report is not None:
        lines.append(f"{'this run':<13} {label[:12]:<12}" + "".join(
            f"{_pct(report.columns[k].accuracy):>8}" for k in (*FAMILIES, "All")))
    return "\n".join(lines)


def score(
    questions: PathLike | Sequence[Any],
    predictions: PathLike | Mapping[Any, Any] | Sequence[Any],
    split: Iterable[tuple[int, int]] | None = None,
) -> ScoreReport:
    """Score predictions against the recorded answers.

    ``questions``: a ``dataset_minimal.json`` or ``dataset.json`` path, a parsed list, or :class:`Question`
    records. ``predictions``: a path, ``{(video_index, question_index) or "v_q": answer}`` or a list of
    ``{video_index, question_index, answer}``. ``split``: keys to score (e.g. :func:`read_split`); other
    questions are ignored. A question without a prediction counts as wrong (and as ``missing``); a prediction
    for a question not in ``questions`` is listed in ``unknown_predictions`` and ignored.
    """
    if isinstance(questions, (str, os.PathLike)):
        qs = read_questions(questions)
    else:
        items = list(questions)
        qs = items if items and all(isinstance(q, Question) for q in items) else parse_questions(items)
    if isinstance(predictions, (str, os.PathLike)):
        preds = read_predictions(predictions)
    elif isinstance(predictions, Mapping) and predictions and all(isinstance(k, tuple) for k in predictions):
        preds = dict(predictions)
    else:
        preds = parse_predictions(predictions)
    report = ScoreReport()
    known = {q.key for q in qs}
    selected = set(split) if split is not None else None
    if selected is not None:
        report.split_not_in_questions = len(selected - known)
    report.unknown_predictions = sorted(k for k in preds if k not in known)
    for q in qs:
        if selected is not None and q.key not in selected:
            report.outside_split += q.key in preds
            continue
        if q.template_id in DROPPED:
            report.dropped_templates += 1
        if q.key in preds:
            report.predicted += 1
            report._add(q, answers_agree(preds[q.key], q.answer), False)
        else:
            report._add(q, False, True)
    return report


# -- fixture builder ------------------------------------------------------------------------------------------


def build_dataset(
    sims: Sequence[Simulation] | Mapping[int, Simulation], include_dropped: bool = False
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """A small dataset in the published formats, for tests and demos: ``(dataset, annotations)``.

    For every simulation (video index = position, or the mapping's key), one question per template that has
    a valid binding (:func:`craft_dsl.templates.instantiate`), with the saved program
    (``to_nodes(outputs=sim)``, so ``_output`` is present), the raw answer, and the first paraphrase as text.
    ``annotations`` maps the id6 names to :func:`craft_dsl.recorded.simulation_dict` (with variations).

    This is a fixture utility, NOT the CRAFT generation pipeline: no answer balancing, no perturbation
    filter, no random object choice; the 19 dropped templates are left out unless ``include_dropped``.
    """
    from .recorded import simulation_dict
    from .templates import instantiate

    items = sorted(sims.items()) if isinstance(sims, Mapping) else list(enumerate(sims))
    dataset: list[dict[str, Any]] = []
    annotations: dict[str, Any] = {}
    for video_index, sim in items:
        id6 = f"{video_index:06d}"
        found_sid = re.search(r"sid_(\d+)", str(sim.meta.get("video_filename", "")))
        sid = str(sim.meta.get("scene", found_sid.group(1) if found_sid else "0"))
        video_path = f"./videos/sid_{sid}/{id6}.mpg"
        records: list[dict[str, Any]] = []
        for tid, template in templates().items():
            if template.dropped and not include_dropped:
                continue
            found = instantiate(template, sim)
            if found is None:
                continue
            params, answer = found
            records.append({
                "video_filename": video_path, "video_index": video_index, "video": id6,
                "question": question_text(tid, params),
                "program": template.program(params).to_nodes(outputs=sim),
                "answer": to_json(answer, original=True),
                "template_filename": f"{template.family}.json", "question_family_index": template.index,
                "question_index": len(records),
            })
        data = simulation_dict(sim)
        data["original_video_output"]["video_filename"] = video_path
        annotations[id6] = data
        dataset.append({"simulation_id": sid, "video_path": video_path,
                        "questions": {"info": {"video_filename": video_path, "video_index": video_index},
                                      "questions": records}})
    return dataset, annotations


def minimal_records(dataset: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """``dataset_minimal.json`` records (spec §6.11) of a ``dataset.json`` list, as the released data has them:
    answers as strings, colours and shapes capitalised, ``answer_type`` and ``question_type`` filled in."""
    from .vocabulary import COLORS, SHAPES, SIZES

    out: list[dict[str, Any]] = []
    for video in dataset:
        sid = str(video.get("simulation_id", "0"))
        for q in video["questions"]["questions"]:
            answer = str(q["answer"])
            kind = ("Boolean" if answer in ("True", "False") else "Shape" if answer in SHAPES
                    else "Color" if answer in COLORS else "Size" if answer in SIZES else "Count")
            stem = Path(q["template_filename"]).stem
            out.append({
                "question": q.get("question", ""), "answer": answer.capitalize(), "answer_type": kind,
                "template_filename": q["template_filename"], "video_file_path": video.get("video_path", ""),
                "video_index": q["video_index"], "question_index": q["question_index"],
                "question_family_index": q["question_family_index"],
                "template_id": f"{stem}_{q['question_family_index']}", "simulation_id": sid,
                "question_type": stem.capitalize(),
            })
    return out

