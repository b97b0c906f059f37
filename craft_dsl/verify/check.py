"""Dataset verification: re-answer every question by running its saved program."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from ..errors import CraftError
from ..program import Program, to_json
from ..simulation import Simulation
from ..templates import templates
from .annotations import Annotations, open_annotations
from .answers import answers_agree
from .categories import CATEGORIES
from .formats import PathLike, Question, parse_dataset, read_dataset


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
        return asdict(self)


@dataclass(frozen=True)
class VerifyError:
    """A question that could not be re-answered. ``kind``: program, simulation or evaluation."""

    video_index: int
    question_index: int
    template_id: str
    kind: str
    message: str

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


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
        w = max(10, *(len(c) for c in CATEGORIES))  # label columns as wide as their longest label (never cut)
        lines.append(f"{'category':<{w}} {'total':>7} {'agree':>7} {'mismatch':>9} {'error':>7}")
        for c in CATEGORIES:
            if c in self.per_category:
                x = self.per_category[c]
                lines.append(f"{c:<{w}} {x.total:>7} {x.agree:>7} {x.mismatch:>9} {x.error:>7}")
        bad = [tid for tid in templates() if tid in self.per_template and self.per_template[tid].agree
               != self.per_template[tid].total]
        if bad:
            lines += ["", "templates with disagreements:"]
            w = max(18, *(len(tid) for tid in bad))
            for tid in bad:
                x = self.per_template[tid]
                lines.append(f"  {tid:<{w}} {x.total:>6} questions, {x.mismatch} mismatch(es), {x.error} error(s)")
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
