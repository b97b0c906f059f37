"""Statistics of a CRAFT-format dataset and the paper's heuristic baselines computed on it (pure Python).

The tables are those the original generator wrote (answer distribution per template, per category; question
types per scene), with the simulation-side ones it did not (events per video, objects per scene), and the
paper's four heuristic baselines per split (``Random``, ``AT-Random``, ``MFA``, ``AT-MFA``) beside the paper's
figures: a baseline's accuracy measures the answer bias a model could exploit without looking at the video.

Baselines are *expected* accuracies on the test part, computed exactly rather than by sampling:

* Random: an answer drawn uniformly from every distinct answer of the training part (1/K if the true answer
  is one of them);
* AT-Random: drawn uniformly from the training answers of the question's answer type (Boolean, Count, Color,
  Shape, Size);
* MFA: the most frequent training answer; AT-MFA: the most frequent training answer of the question's type
  (ties go to the answer first in sorted order).

Charts (matplotlib) are in :mod:`craft_dsl.dataset.charts`; the ``craft-dsl stats`` command writes both.
"""

from __future__ import annotations

import csv
import io
from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..templates import templates
from ..verify.answers import normalise_answer
from ..verify.categories import CATEGORIES, QUESTION_TYPES
from ..verify.paper import PAPER_RESULTS
from .folder import SPLITS, DatasetFolder, Key

#: The paper's heuristic baselines, in table order.
BASELINES: tuple[str, ...] = ("Random", "AT-Random", "MFA", "AT-MFA")
#: The paper's columns.
COLUMNS: tuple[str, ...] = ("C", "CF", "D", "All")
#: Event types counted per video (Start and End are not events of the video).
EVENT_TYPES: tuple[str, ...] = ("Collision", "TouchStart", "TouchEnd", "EnterBasket")
#: The paper's name of each split.
PAPER_SPLIT = {"random": "easy", "hard": "hard"}


@dataclass(frozen=True)
class Table:
    """One statistics table: written as ``<name>.csv`` and drawn as ``<name>.png`` / ``.svg``."""

    name: str
    title: str
    columns: tuple[str, ...]
    rows: list[tuple[Any, ...]] = field(default_factory=list)

    def to_csv(self) -> str:
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(self.columns)
        writer.writerows(["" if v is None else v for v in row] for row in self.rows)
        return buf.getvalue()

    def to_json(self) -> list[dict[str, Any]]:
        return [dict(zip(self.columns, row, strict=True)) for row in self.rows]


def template_order(tid: str) -> int:
    order = list(templates())
    return order.index(tid) if tid in order else len(order)


def answer_order(answer: str) -> tuple[int, int, str]:
    """Counts numerically first, then booleans, then words alphabetically."""
    if answer.isdigit():
        return (0, int(answer), "")
    if answer in ("False", "True"):
        return (1, 0, answer)
    return (2, 0, answer)


# -- question tables ------------------------------------------------------------------------------------------


def answers_per_template(records: Iterable[Mapping[str, Any]]) -> Table:
    counts: Counter[tuple[str, str, str, str]] = Counter(
        (r["template_id"], r["category"], str(r.get("answer_type", "")), str(r["answer"])) for r in records)
    rows = [(t, c, k, a, n) for (t, c, k, a), n in counts.items()]
    rows.sort(key=lambda row: (template_order(row[0]), answer_order(row[3])))
    return Table("answers_per_template", "Answer distribution per template",
                 ("template_id", "category", "answer_type", "answer", "count"), rows)


def answers_per_category(records: Iterable[Mapping[str, Any]]) -> Table:
    counts: Counter[tuple[str, str, str]] = Counter(
        (r["category"], str(r.get("answer_type", "")), str(r["answer"])) for r in records)
    rows = [(c, k, a, n) for (c, k, a), n in counts.items()]
    rows.sort(key=lambda row: (CATEGORIES.index(row[0]), answer_order(row[2])))
    return Table("answers_per_category", "Answer distribution per paper category",
                 ("category", "answer_type", "answer", "count"), rows)


def question_types_per_scene(records: Iterable[Mapping[str, Any]]) -> Table:
    counts: Counter[tuple[int, str]] = Counter((int(r["simulation_id"] or 0), str(r["question_type"]))
                                               for r in records)
    rows = [(s, t, n) for (s, t), n in counts.items()]
    rows.sort(key=lambda row: (row[0], QUESTION_TYPES.index(row[1]) if row[1] in QUESTION_TYPES else 99))
    return Table("question_types_per_scene", "Question types per scene", ("scene", "question_type", "count"), rows)


# -- simulation tables ----------------------------------------------------------------------------------------


def events_per_video(folder: DatasetFolder) -> Table:
    """Events of each video with questions (from its recorded simulation), by type."""
    scenes = {int(r["video_index"]): int(r["simulation_id"] or 0) for r in folder.records}
    annotations = folder.annotations
    rows = []
    for vi in sorted(scenes):
        key = annotations.resolve(f"{vi:06d}", vi)
        if key is None:
            continue
        sim = annotations.simulation(key)
        counts = Counter(e.type for e in sim.events)
        per_type = [counts.get(t, 0) for t in EVENT_TYPES]
        rows.append((vi, scenes[vi], *per_type, sum(per_type)))
    return Table("events_per_video", "Events per video", ("video_index", "scene", *EVENT_TYPES, "total"), rows)


def objects_per_scene(folder: DatasetFolder) -> Table:
    """Per scene: videos, dynamic objects (min, mean, max) and static objects, from the recorded simulations."""
    scenes = {int(r["video_index"]): int(r["simulation_id"] or 0) for r in folder.records}
    annotations = folder.annotations
    dynamic: dict[int, list[int]] = defaultdict(list)
    static: dict[int, list[int]] = defaultdict(list)
    for vi in sorted(scenes):
        key = annotations.resolve(f"{vi:06d}", vi)
        if key is None:
            continue
        sim = annotations.simulation(key)
        dynamic[scenes[vi]].append(sum(1 for o in sim.objects if o.dynamic))
        static[scenes[vi]].append(sum(1 for o in sim.objects if not o.dynamic))
    rows = [(s, len(d), min(d), round(sum(d) / len(d), 3), max(d), round(sum(static[s]) / len(static[s]), 3))
            for s, d in sorted(dynamic.items())]
    return Table("objects_per_scene", "Objects per scene",
                 ("scene", "videos", "dynamic_min", "dynamic_mean", "dynamic_max", "static_mean"), rows)


# -- heuristic baselines --------------------------------------------------------------------------------------


def _most_frequent(counts: Counter[str]) -> str | None:
    if not counts:
        return None
    best = max(counts.values())
    return min(a for a, n in counts.items() if n == best)


def heuristic_baselines(records: Sequence[Mapping[str, Any]], part_of: Mapping[Key, str]
                        ) -> dict[str, dict[str, tuple[float | None, int]]]:
    """Expected test accuracy (%) and question count per baseline and column: ``{baseline: {column: (acc, n)}}``.

    Trained on the questions whose ``part_of`` is ``train``, evaluated on those in ``test``; ``acc`` is None
    when a column has no test question.
    """
    train = [r for r in records if part_of.get((int(r["video_index"]), int(r["question_index"]))) == "train"]
    test = [r for r in records if part_of.get((int(r["video_index"]), int(r["question_index"]))) == "test"]
    answers: Counter[str] = Counter(normalise_answer(r["answer"]) for r in train)
    by_type: dict[str, Counter[str]] = defaultdict(Counter)
    for r in train:
        by_type[str(r.get("answer_type"))][normalise_answer(r["answer"])] += 1
    mfa = _most_frequent(answers)
    at_mfa = {t: _most_frequent(c) for t, c in by_type.items()}

    def expected(name: str, r: Mapping[str, Any]) -> float:
        truth = normalise_answer(r["answer"])
        kind = str(r.get("answer_type"))
        space = by_type.get(kind, Counter())
        if name == "Random":
            return 1.0 / len(answers) if truth in answers else 0.0
        if name == "AT-Random":
            return 1.0 / len(space) if truth in space else 0.0
        if name == "MFA":
            return 1.0 if truth == mfa else 0.0
        return 1.0 if truth == at_mfa.get(kind) else 0.0

    out: dict[str, dict[str, tuple[float | None, int]]] = {}
    for name in BASELINES:
        sums: dict[str, float] = defaultdict(float)
        counts: Counter[str] = Counter()
        for r in test:
            value = expected(name, r)
            for column in (str(r["family"]), "All"):
                sums[column] += value
                counts[column] += 1
        out[name] = {c: ((100.0 * sums[c] / counts[c]) if counts[c] else None, counts[c]) for c in COLUMNS}
    return out


def paper_baselines(split: str) -> dict[str, tuple[float, float, float, float]]:
    """The paper's figures (C, CF, D, All) of the heuristic baselines on ``split`` ("random" = easy, "hard")."""
    side = PAPER_SPLIT[split]
    return {row.model: getattr(row, side) for row in PAPER_RESULTS if row.model in BASELINES}


def baselines_table(folder: DatasetFolder) -> Table:
    """Every baseline on both splits, this dataset's accuracy beside the paper's."""
    rows = []
    for split in SPLITS:
        ours = heuristic_baselines(folder.records, folder.part_of(split))
        paper = paper_baselines(split)
        for name in BASELINES:
            acc = [None if ours[name][c][0] is None else round(float(ours[name][c][0] or 0.0), 2) for c in COLUMNS]
            rows.append((split, name, *acc, ours[name]["All"][1], *paper[name]))
    return Table("baselines", "Heuristic baselines: expected test accuracy (%), this dataset beside the paper",
                 ("split", "baseline", *COLUMNS, "test_questions", *(f"paper_{c}" for c in COLUMNS)), rows)


def question_tables(folder: DatasetFolder) -> list[Table]:
    """The tables computed from the questions alone (no simulation needed)."""
    return [answers_per_template(folder.records), answers_per_category(folder.records),
            question_types_per_scene(folder.records), baselines_table(folder)]


def all_tables(folder: DatasetFolder) -> list[Table]:
    """Every statistics table (the simulation ones read ``annotations.json``)."""
    tables = question_tables(folder)
    return tables[:3] + [events_per_video(folder), objects_per_scene(folder)] + tables[3:]


def format_baselines(table: Table) -> str:
    """The baseline table as aligned text (``ours / paper`` per column)."""
    # the label columns are as wide as their longest label (never cut)
    ws = max([7, *(len(str(row[0])) for row in table.rows)])
    wb = max([10, *(len(str(row[1])) for row in table.rows)])
    lines = [f"{'split':<{ws}} {'baseline':<{wb}} " + " ".join(f"{c:>13}" for c in COLUMNS) + "  test questions",
             f"{'':<{ws}} {'':<{wb}} " + " ".join(f"{'ours / paper':>13}" for _ in COLUMNS)]
    for row in table.rows:
        split, name, *rest = row
        ours, n, paper = rest[:4], rest[4], rest[5:]
        cells = " ".join(f"{'-' if o is None else f'{o:.1f}':>6} / {p:>4.1f}" for o, p in zip(ours, paper,
                                                                                                 strict=True))
        lines.append(f"{split:<{ws}} {name:<{wb}} {cells}  {n}")
    return "\n".join(lines)


__all__ = [
    "BASELINES", "COLUMNS", "EVENT_TYPES", "Table", "all_tables", "answer_order", "answers_per_category",
    "answers_per_template", "baselines_table", "events_per_video", "format_baselines", "heuristic_baselines",
    "objects_per_scene", "paper_baselines", "question_tables", "question_types_per_scene", "template_order",
]
