"""Reading a model's predictions: any mix of answers, programs, traces and answer distributions per question.

A predictions file is JSON or JSON Lines:

* ``{"<video_index>_<question_index>": PREDICTION, ...}``;
* ``[{"video_index": 4, "question_index": 2, ...PREDICTION fields}, ...]``;
* ``.jsonl``: one ``{"video_index", "question_index", ...}`` record per line (read as a stream).

A PREDICTION is a bare answer (``"red"``, ``2``, ``true``), or an object with any of

* ``answer``: the predicted answer;
* ``program``: DSL text (a string), a node list (a list of objects) or tokens (a list of strings);
  ``program_format`` (``text``, ``nodes``, ``prefix``, ``postfix``) says which where the default reading is
  not meant (a string is text unless ``program_format`` is ``prefix`` or ``postfix``; a list of strings is
  tokens in the order given to the reader, prefix by default);
* ``trace``: the model's intermediate outputs, ``{node: value}`` (see :mod:`craft_dsl.oracle.traces`);
* ``answer_distribution``: ``{answer: probability}`` summing to 1.

Every error names the file, the record and the field.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from ..errors import CraftError
from ..verify.answers import normalise_answer
from .forms import FORMS

#: Fields of a prediction object; any other field is reported, not read.
FIELDS: tuple[str, ...] = ("answer", "program", "program_format", "trace", "answer_distribution")
_KEY = re.compile(r"\s*(\d{1,12})_(\d{1,12})\s*")
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


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise CraftError(f"the key {key!r} appears twice in one object")
        out[key] = value
    return out


def _load(text: str, where: str) -> Any:
    try:
        return json.loads(text, object_pairs_hook=_no_duplicates)
    except json.JSONDecodeError as err:
        raise CraftError(f"{where}: not valid JSON (line {err.lineno}, column {err.colno}: {err.msg})") from None
    except CraftError as err:
        raise CraftError(f"{where}: {err}") from None
    except RecursionError:
        raise CraftError(f"{where}: JSON nested too deeply") from None


def _distribution(raw: Any, where: str) -> dict[str, float]:
    if isinstance(raw, Mapping) and isinstance(raw.get("answers"), list):  # AnswerDistribution.to_json()
        entries = raw["answers"]
        if not all(isinstance(e, Mapping) and "answer" in e and "p" in e for e in entries):
            raise CraftError(f"{where}: every entry of 'answers' needs 'answer' and 'p'")
        raw = [[e["answer"], e["p"]] for e in entries]
    if isinstance(raw, list) and all(isinstance(p, list) and len(p) == 2 for p in raw):
        raw = {str(a): p for a, p in raw}
    if not isinstance(raw, Mapping) or not raw:
        raise CraftError(f"{where}: expected a non-empty object {{answer: probability}}, found {json.dumps(raw)}")
    out: dict[str, float] = {}
    for answer, p in raw.items():
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not math.isfinite(p) or not 0 <= p <= 1:
            raise CraftError(f"{where}: the probability of {answer!r} must be a number in [0, 1], found {p!r}")
        key = normalise_answer(answer)
        out[key] = out.get(key, 0.0) + float(p)
    total = sum(out.values())
    if abs(total - 1.0) > SUM_TOLERANCE:
        raise CraftError(f"{where}: the probabilities sum to {total:.6g}, not 1")
    return out


def make_prediction(key: tuple[int, int], value: Any, where: str) -> Prediction:
    """A :class:`Prediction` from one record's value (a bare answer or an object of :data:`FIELDS`)."""
    if isinstance(value, (str, int, float)) or value is None:
        if value is None:
            raise CraftError(f"{where}: the prediction is null; give an answer or an object of {', '.join(FIELDS)}")
        return Prediction(key, answer=value, where=where)
    if not isinstance(value, Mapping):
        raise CraftError(f"{where}: expected an answer or an object with {', '.join(FIELDS)}, found "
                         f"{type(value).__name__}")
    answer = value.get("answer", MISSING)
    if answer is not MISSING and not isinstance(answer, (str, int, float)):
        raise CraftError(f"{where}, field 'answer': must be a string, a number or a boolean, found "
                         f"{json.dumps(answer)}")
    form = value.get("program_format")
    if form is not None and form not in FORMS:
        raise CraftError(f"{where}, field 'program_format': {form!r} is not one of {', '.join(FORMS)}")
    program = value.get("program", MISSING)
    if program is not MISSING and not isinstance(program, (str, list)):
        raise CraftError(f"{where}, field 'program': must be DSL text (a string), a node list or a token list, "
                         f"found {type(program).__name__}")
    dist = value.get("answer_distribution")
    unknown = tuple(sorted(k for k in value if k not in FIELDS and k not in _RECORD_KEYS and k != "key"))
    return Prediction(
        key, answer=answer, program=program, program_format=form, trace=value.get("trace", MISSING),
        distribution=None if dist is None else _distribution(dist, f"{where}, field 'answer_distribution'"),
        where=where, unknown_fields=unknown,
    )


def _record_key(record: Any, where: str) -> tuple[int, int]:
    if not isinstance(record, Mapping):
        raise CraftError(f"{where}: expected an object with video_index and question_index, found "
                         f"{type(record).__name__}")
    if "key" in record and not all(k in record for k in _RECORD_KEYS):
        return _parse_key(record["key"], f"{where}, field 'key'")
    out = []
    for name in _RECORD_KEYS:
        v = record.get(name)
        if not isinstance(v, int) or isinstance(v, bool) or not 0 <= v < 10**12:
            raise CraftError(f"{where}, field '{name}': expected a non-negative integer, found {json.dumps(v)}")
        out.append(v)
    return (out[0], out[1])


def _parse_key(key: Any, where: str) -> tuple[int, int]:
    m = _KEY.fullmatch(str(key))
    if not m:
        raise CraftError(f"{where}: {key!r} is not '<video_index>_<question_index>' (e.g. '42_3')")
    return (int(m.group(1)), int(m.group(2)))


def iter_predictions(data: Any, name: str = "predictions") -> Iterator[Prediction]:
    """The predictions of parsed JSON (an object keyed ``"v_q"`` or a list of records)."""
    if isinstance(data, Mapping):
        for key, value in data.items():
            where = f"{name}: record {key!r}"
            yield make_prediction(_parse_key(key, where), value, where)
    elif isinstance(data, list):
        for i, record in enumerate(data):
            where = f"{name}: record {i}"
            key = _record_key(record, where)
            yield make_prediction(key, dict(record), where)
    else:
        raise CraftError(f"{name}: expected an object {{'<video>_<question>': prediction}} or a list of records, "
                         f"found {type(data).__name__}")


def _open_text(p: Path) -> TextIO:
    try:
        return open(p, encoding="utf-8")
    except FileNotFoundError:
        raise CraftError(f"{p}: no such file (predictions)") from None
    except OSError as err:
        raise CraftError(f"{p}: cannot read ({err.strerror})") from None


def read_predictions(path: str | os.PathLike[str]) -> Iterator[Prediction]:
    """The predictions of a ``.json`` or ``.jsonl`` file (JSON Lines are read one line at a time)."""
    p = Path(path)
    if p.is_dir():
        raise CraftError(f"{p}: is a directory, expected a predictions file (.json or .jsonl)")
    with _open_text(p) as fh:
        try:
            if p.suffix == ".jsonl":
                for n, line in enumerate(fh, start=1):
                    if line.strip():
                        where = f"{p}: line {n}"
                        record = _load(line, where)
                        yield make_prediction(_record_key(record, where), record, where)
                return
            text = fh.read()
        except UnicodeDecodeError as err:
            raise CraftError(f"{p}: not UTF-8 text ({err.reason} at byte {err.start})") from None
    yield from iter_predictions(_load(text, str(p)), str(p))


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
            raise CraftError(f"{pred.where}: question {pred.key[0]}_{pred.key[1]} is already predicted by "
                             f"{out[pred.key].where}")
        out[pred.key] = pred
    return out
