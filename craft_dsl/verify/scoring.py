"""Prediction scoring: accuracy per paper column, sub-category, question type and template."""

from __future__ import annotations

import os
from array import array
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import CraftError, PredictionsFileError
from ..templates import DROPPED, templates
from .answers import answer_problem, answers_agree
from .categories import CATEGORIES, FAMILIES, QUESTION_TYPES, category_of
from .formats import (
    PathLike,
    PredictionEntries,
    Question,
    parse_questions,
    read_questions,
    repeated_prediction,
)
from .paper import PAPER_HUMANS, PAPER_RESULTS

#: At most this many predictions for unknown questions are listed (the smallest keys); all are counted.
UNKNOWN_LISTED = 1000


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
    #: The smallest (at most UNKNOWN_LISTED) keys predicted that are not questions; ``unknown_count`` counts all.
    unknown_predictions: list[tuple[int, int]] = field(default_factory=list)
    unknown_count: int = 0
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
            "unknown_count": self.unknown_count,
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
        if self.unknown_count:
            shown = ", ".join(f"{v}_{q}" for v, q in self.unknown_predictions[:5])
            more = " ..." if self.unknown_count > 5 else ""
            lines.append(f"{self.unknown_count} prediction(s) for unknown questions ignored: {shown}{more}")
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
        # label columns as wide as their longest label (never cut)
        w = label_width("category", CATEGORIES, 10)
        lines += ["", f"{'category':<{w}} {'accuracy %':>10} {'correct':>8} {'total':>7} {'missing':>8}"]
        for c in CATEGORIES:
            if c in self.per_category:
                s = self.per_category[c]
                lines.append(f"{c:<{w}} {_pct(s.accuracy):>10} {s.correct:>8} {s.total:>7} {s.missing:>8}")
        w = label_width("type", QUESTION_TYPES, 15)
        lines += ["", f"{'type':<{w}} {'accuracy %':>10} {'correct':>8} {'total':>7}"]
        for t in QUESTION_TYPES:
            if t in self.per_type:
                s = self.per_type[t]
                lines.append(f"{t:<{w}} {_pct(s.accuracy):>10} {s.correct:>8} {s.total:>7}")
        if per_template:
            tids = [tid for tid in templates() if tid in self.per_template]
            w, wc = label_width("template", tids, 18), label_width("category", [category_of(t) for t in tids], 7)
            lines += ["", f"{'template':<{w}} {'category':<{wc}} {'accuracy %':>10} {'correct':>8} {'total':>7}"]
            for tid in tids:
                s = self.per_template[tid]
                lines.append(f"{tid:<{w}} {category_of(tid):<{wc}} {_pct(s.accuracy):>10} {s.correct:>8} "
                             f"{s.total:>7}")
        if compare_paper:
            lines += ["", paper_table(compare_paper, self, label)]
        return "\n".join(lines)


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def label_width(header: str, labels: Iterable[str], least: int = 0) -> int:
    """The width of a label column: its longest label or header (at least ``least``), so that none is cut."""
    return max([least, len(header), *(len(x) for x in labels)])


def paper_table(split: str, report: ScoreReport | None = None, label: str = "yours") -> str:
    """The paper's test accuracies on ``split`` ("easy" or "hard"), with the report's row appended."""
    if split not in ("easy", "hard"):
        raise CraftError(f"--compare-paper takes 'easy' or 'hard', not {split!r}")
    # the label columns are as wide as their longest entry: the run's label (a file name) is never cut
    wg = label_width("group", [*(r.group for r in PAPER_RESULTS), "humans", "this run"], 13)
    wm = label_width("model", [*(r.model for r in PAPER_RESULTS), "(481 q.)", *([label] if report is not None else [])],
                12)
    head = f"{'group':<{wg}} {'model':<{wm}}" + "".join(f"{k:>8}" for k in (*FAMILIES, "All"))
    lines = [f"CRAFT paper, {split} split (test accuracy %)", head]
    for row in PAPER_RESULTS:
        values = row.easy if split == "easy" else row.hard
        lines.append(f"{row.group:<{wg}} {row.model:<{wm}}" + "".join(f"{v:>8.2f}" for v in values))
    lines.append(f"{'humans':<{wg}} {'(481 q.)':<{wm}}" + "".join(f"{v:>8.2f}" for v in PAPER_HUMANS))
    if report is not None:
        lines.append(f"{'this run':<{wg}} {label:<{wm}}" + "".join(
            f"{_pct(report.columns[k].accuracy):>8}" for k in (*FAMILIES, "All")))
    return "\n".join(lines)


class _UnknownKeys:
    """Keys predicted for questions the questions file does not have, 8 bytes each (a 200 MB predictions file
    can hold ten million of them): packed ``video_index << 32 | question_index`` where both fit, else in a set."""

    def __init__(self) -> None:
        self.packed = array("q")
        self.wide: set[tuple[int, int]] = set()

    def add(self, key: tuple[int, int]) -> None:
        v, q = key
        if v < (1 << 31) and q < (1 << 32):
            self.packed.append(v << 32 | q)
        elif key in self.wide:
            raise _Repeated(key)
        else:
            self.wide.add(key)

    def finish(self) -> tuple[int, list[tuple[int, int]]]:
        """(how many, the smallest UNKNOWN_LISTED); raises _Repeated for a key given twice."""
        keys = np.frombuffer(self.packed, dtype=np.int64) if self.packed else np.zeros(0, dtype=np.int64)
        keys.sort()
        same = np.flatnonzero(keys[1:] == keys[:-1])
        if len(same):
            k = int(keys[same[0]])
            raise _Repeated((k >> 32, k & 0xFFFFFFFF))
        listed = [(int(k) >> 32, int(k) & 0xFFFFFFFF) for k in keys[:UNKNOWN_LISTED]]
        listed = sorted(listed + sorted(self.wide)[:UNKNOWN_LISTED])[:UNKNOWN_LISTED]
        return len(keys) + len(self.wide), listed


class _Repeated(Exception):
    def __init__(self, key: tuple[int, int]) -> None:
        self.key = key


def _predictions(predictions: Any) -> tuple[Iterator[tuple[tuple[int, int], Any, Any]], Any]:
    """(key, answer, label) of every prediction, from a path (streamed), parsed JSON, or {(v, q): answer}; and
    the function that turns a label into the prediction's place for messages."""
    if isinstance(predictions, Mapping) and predictions and all(isinstance(k, tuple) for k in predictions):
        return _tuple_keyed(predictions), lambda label: f"predictions: key {label!r}"
    entries = PredictionEntries(predictions)
    return entries.answers(), entries.where


def _tuple_keyed(predictions: Mapping[tuple[int, int], Any]) -> Iterator[tuple[tuple[int, int], Any, Any]]:
    for key, answer in predictions.items():
        problem = answer_problem(answer)
        if problem is not None:
            raise PredictionsFileError(f"predictions: key {key!r}: {problem}")
        yield key, answer, key


def _repeated_error(predictions: Any, key: tuple[int, int]) -> PredictionsFileError:
    """The error for a question predicted twice, naming both entries (a second pass over the predictions)."""
    items, where = _predictions(predictions)
    places = [where(label) for k, _, label in items if k == key][:2]
    return repeated_prediction(key, places[0], places[-1])


def score(
    questions: PathLike | Sequence[Any],
    predictions: PathLike | Mapping[Any, Any] | Sequence[Any],
    split: Iterable[tuple[int, int]] | None = None,
) -> ScoreReport:
    """Score predictions against the recorded answers.

    ``questions``: a ``dataset_minimal.json`` or ``dataset.json`` path, a parsed list, or :class:`Question`
    records. ``predictions``: a path (``.json`` or ``.jsonl``, read as a stream: memory grows with the questions
    and 8 bytes per prediction for an unknown question, not with the file), ``{(video_index, question_index) or
    "v_q": answer}`` or a list of ``{video_index, question_index, answer}``. ``split``: keys to score (e.g.
    :func:`read_split`); other questions are ignored. A question without a prediction counts as wrong (and as
    ``missing``); a prediction for a question not in ``questions`` is counted in ``unknown_count`` (the first
    keys listed in ``unknown_predictions``) and ignored. A question predicted twice is an error naming both.
    """
    if isinstance(questions, (str, os.PathLike)):
        qs = read_questions(questions)
    else:
        items = list(questions)
        qs = items if items and all(isinstance(q, Question) for q in items) else parse_questions(items)
    position = {q.key: i for i, q in enumerate(qs)}
    answered = bytearray(len(qs))
    correct = bytearray(len(qs))
    unknown = _UnknownKeys()
    get, packed = position.get, unknown.packed.append
    try:
        for key, answer, _label in _predictions(predictions)[0]:
            i = get(key)
            if i is None:
                video, question = key
                if video < 0x80000000 and question < 0x100000000:  # _UnknownKeys.add inlined: it runs ten million
                    packed(video << 32 | question)  # times for a 200 MB file
                else:
                    unknown.add(key)
            elif answered[i]:
                raise _Repeated(key)
            else:
                answered[i] = 1
                correct[i] = answers_agree(answer, qs[i].answer)
        report = ScoreReport()
        report.unknown_count, report.unknown_predictions = unknown.finish()
    except _Repeated as rep:
        raise _repeated_error(predictions, rep.key) from None
    selected = set(split) if split is not None else None
    if selected is not None:
        report.split_not_in_questions = len(selected - position.keys())
    for i, q in enumerate(qs):
        if selected is not None and q.key not in selected:
            report.outside_split += answered[i]
            continue
        if q.template_id in DROPPED:
            report.dropped_templates += 1
        if answered[i]:
            report.predicted += 1
            report._add(q, bool(correct[i]), False)
        else:
            report._add(q, False, True)
    return report
