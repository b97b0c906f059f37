"""Reading a model's predictions: any mix of answers, programs, traces and answer distributions per question.

A predictions file is JSON or JSON Lines:

* ``{"<video_index>_<question_index>": PREDICTION, ...}``;
* ``[{"video_index": 4, "question_index": 2, ...PREDICTION fields}, ...]``;
* ``.jsonl``: one ``{"video_index", "question_index", ...}`` record per line.

Files are read as a stream (:class:`craft_dsl.verify.formats.PredictionEntries`): a ``.json`` object or array
member by member, JSON Lines line by line.

A PREDICTION is a bare answer (``"red"``, ``2``, ``true``), or an object with any of

* ``answer``: the predicted answer;
* ``program``: DSL text (a string), a node list (a list of objects) or tokens (a list of strings);
  ``program_format`` (``text``, ``nodes``, ``prefix``, ``postfix``) says which where the default reading is
  not meant (a string is text unless ``program_format`` is ``prefix`` or ``postfix``; a list of strings is
  tokens in the order given to the reader, prefix by default);
* ``trace``: the model's intermediate outputs, ``{node: value}`` (see :mod:`craft_dsl.oracle.traces`);
* ``answer_distribution``: ``{answer: probability}`` summing to 1.

Every error is a :class:`~craft_dsl.errors.PredictionsFileError` naming the file, the record and the field.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from ..errors import PredictionsFileError
from ..files import describe
from ..verify.answers import answer_problem, normalise_answer
from ..verify.formats import PredictionEntries, repeated_prediction
from .forms import FORMS

#: Fields of a prediction object; any other field is reported, not read.
FIELDS: tuple[str, ...] = ("answer", "program", "program_format", "trace", "answer_distribution")
_RECORD_KEYS = ("video_index", "question_index")
#: How far the probabilities of a distribution may sum from 1.
SUM_TOLERANCE = 1e-6


class _Missing:
    def __repr__(self) -> str:
        return "MISSING"


#: The value of a field a prediction does not give.
MISSING: Any = _Missing()


@dataclass(frozen=True)
class Prediction:
    """What a model predicted for one question (fields it did not give are :data:`MISSING`)."""

    key: tuple[int, int]
    answer: Any = MISSING
    program: Any = MISSING
    program_format: str | None = None
    trace: Any = MISSING
    distribution: dict[str, float] | None = None
    where: str = ""
    unknown_fields: tuple[str, ...] = ()


def _distribution(raw: Any, where: str) -> dict[str, float]:
    if isinstance(raw, Mapping) and isinstance(raw.get("answers"), list):  # AnswerDistribution.to_json()
        entries = raw["answers"]
        if not all(isinstance(e, Mapping) and "answer" in e and "p" in e for e in entries):
            raise PredictionsFileError(f"{where}: every entry of 'answers' needs 'answer' and 'p'")
        raw = [[e["answer"], e["p"]] for e in entries]
    if isinstance(raw, list) and all(isinstance(p, list) and len(p) == 2 for p in raw):
        raw = {str(a): p for a, p in raw}
    if not isinstance(raw, Mapping) or not raw:
        raise PredictionsFileError(f"{where}: expected a non-empty object {{answer: probability}}, found "
                                   f"{describe(raw)}")
    out: dict[str, float] = {}
    for answer, p in raw.items():
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not math.isfinite(p) or not 0 <= p <= 1:
            raise PredictionsFileError(f"{where}: the probability of {describe(answer)} must be a number in [0, 1], "
                                       f"found {describe(p)}")
        key = normalise_answer(answer)
        out[key] = out.get(key, 0.0) + float(p)
    total = sum(out.values())
    if abs(total - 1.0) > SUM_TOLERANCE:
        raise PredictionsFileError(f"{where}: the probabilities sum to {total:.6g}, not 1")
    return out


def make_prediction(key: tuple[int, int], value: Any, where: str) -> Prediction:
    """A :class:`Prediction` from one record's value (a bare answer or an object of :data:`FIELDS`)."""
    if isinstance(value, (str, int, float)) or value is None:
        if value is None:
            raise PredictionsFileError(f"{where}: the prediction is null; give an answer or an object of "
                                       f"{', '.join(FIELDS)}")
        problem = answer_problem(value)
        if problem is not None:
            raise PredictionsFileError(f"{where}: {problem}")
        return Prediction(key, answer=value, where=where)
    if not isinstance(value, Mapping):
        raise PredictionsFileError(f"{where}: expected an answer or an object with {', '.join(FIELDS)}, found "
                                   f"{type(value).__name__}")
    answer = value.get("answer", MISSING)
    if answer is not MISSING and answer_problem(answer) is not None:
        raise PredictionsFileError(f"{where}, field 'answer': {answer_problem(answer)}")
    form = value.get("program_format")
    if form is not None and form not in FORMS:
        raise PredictionsFileError(f"{where}, field 'program_format': {describe(form)} is not one of "
                                   f"{', '.join(FORMS)}")
    program = value.get("program", MISSING)
    if program is not MISSING and not isinstance(program, (str, list)):
        raise PredictionsFileError(f"{where}, field 'program': must be DSL text (a string), a node list or a token "
                                   f"list, found {type(program).__name__}")
    dist = value.get("answer_distribution")
    unknown = tuple(sorted(k for k in value if k not in FIELDS and k not in _RECORD_KEYS and k != "key"))
    return Prediction(
        key, answer=answer, program=program, program_format=form, trace=value.get("trace", MISSING),
        distribution=None if dist is None else _distribution(dist, f"{where}, field 'answer_distribution'"),
        where=where, unknown_fields=unknown,
    )


def iter_predictions(data: Any, name: str = "predictions") -> Iterator[Prediction]:
    """The predictions of a file (read as a stream) or of parsed JSON (an object keyed ``"v_q"`` or a list of
    records)."""
    entries = PredictionEntries(data, name if not isinstance(data, (str, os.PathLike)) else None)
    for key, value, label in entries:
        where = entries.where(label)
        yield make_prediction(key, dict(value) if entries.form != "object" else value, where)


def read_predictions(path: str | os.PathLike[str]) -> Iterator[Prediction]:
    """The predictions of a ``.json`` or ``.jsonl`` file, read as a stream."""
    return iter_predictions(path)


def collect_predictions(source: Any) -> dict[tuple[int, int], Prediction]:
    """Predictions by key from a path, parsed JSON, or :class:`Prediction` values; a key given twice is an
    error naming both records."""
    if isinstance(source, (str, os.PathLike)):
        items: Any = read_predictions(source)
    elif isinstance(source, (Mapping, list)) and not (isinstance(source, list) and source
                                                        and isinstance(source[0], Prediction)):
        items = iter_predictions(source)
    else:
        items = source
    out: dict[tuple[int, int], Prediction] = {}
    for pred in items:
        if pred.key in out:
            raise repeated_prediction(pred.key, out[pred.key].where, pred.where)
        out[pred.key] = pred
    return out
