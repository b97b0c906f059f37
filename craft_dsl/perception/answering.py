"""Answering a set of questions over a perceived scene: most likely world, answer distributions, accuracy."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import CraftError, PerceptionError
from ..files import read_json
from ..program import Program, to_json
from ..templates import first_instances
from ..verify.answers import answers_agree
from ..verify.categories import family_of
from .distribution import DEFAULT_BOUND, DEFAULT_SAMPLES, AnswerDistribution, answer_distributions
from .world import SceneModel


@dataclass(frozen=True)
class QuestionItem:
    """A question to answer: its program, and what is known about it (template, text, true answer)."""

    program: Program
    template_id: str | None = None
    question: str = ""
    truth: Any = None
    index: int = 0


@dataclass(frozen=True)
class AnsweredQuestion:
    item: QuestionItem
    answer: Any
    distribution: AnswerDistribution | None

    @property
    def correct(self) -> bool | None:
        if self.item.truth is None:
            return None
        return answers_agree(self.answer, self.item.truth)

    @property
    def mode_correct(self) -> bool | None:
        if self.item.truth is None or self.distribution is None:
            return None
        return answers_agree(self.distribution.mode, self.item.truth)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"index": self.item.index, "template_id": self.item.template_id,
                               "question": self.item.question, "program": str(self.item.program),
                               "answer": self.answer}
        if self.item.truth is not None:
            out["truth"] = self.item.truth
            out["correct"] = self.correct
        if self.distribution is not None:
            out["distribution"] = self.distribution.to_json()
            if self.item.truth is not None:
                out["mode_correct"] = self.mode_correct
                out["log_likelihood"] = self.distribution.log_likelihood(self.item.truth)
                out["brier"] = self.distribution.brier(self.item.truth)
        return out


def answer_all(model: SceneModel, items: Sequence[QuestionItem], distribution: bool = False,
               bound: int = DEFAULT_BOUND, samples: int = DEFAULT_SAMPLES, seed: int = 0) -> list[AnsweredQuestion]:
    """Each question's answer on the most likely world (and its answer distribution when asked)."""
    sim = model.simulation()
    answers = [to_json(item.program.run(sim), original=True) for item in items]
    dists: list[AnswerDistribution | None] = [None] * len(items)
    if distribution and items:
        dists = list(answer_distributions(model, [i.program for i in items], bound=bound, samples=samples,
                                          seed=seed))
    return [AnsweredQuestion(item, a, d) for item, a, d in zip(items, answers, dists)]


def template_questions(model: SceneModel) -> list[QuestionItem]:
    """The first valid instance of each of the paper's 48 templates on the most likely world (no truth)."""
    sim = model.simulation()
    return [QuestionItem(program, template.id, index=i)
            for i, (template, _params, program, _answer) in enumerate(first_instances(sim))]


def _records(data: Any, where: str, video_index: int | None) -> list[Mapping[str, Any]]:
    if isinstance(data, Mapping) and isinstance(data.get("questions"), list):
        data = data["questions"]
    if not isinstance(data, list):
        raise PerceptionError(f"{where}: expected a list of question records or a CRAFT dataset.json")
    if data and isinstance(data[0], Mapping) and isinstance(data[0].get("questions"), Mapping):  # dataset.json
        videos = [(i, v) for i, v in enumerate(data)
                  if video_index is None or v["questions"].get("info", {}).get("video_index") == video_index
                  or any(q.get("video_index") == video_index for q in v["questions"].get("questions", []))]
        if len(videos) != 1:
            raise PerceptionError(f"{where}: holds {len(data)} videos; pick one with --video-index "
                                  f"({len(videos)} match)")
        return list(videos[0][1]["questions"]["questions"])
    if video_index is not None:
        data = [r for r in data if isinstance(r, Mapping) and r.get("video_index") == video_index]
    return list(data)


def read_question_file(path: str | Path, video_index: int | None = None) -> list[QuestionItem]:
    """Questions with programs: a list of question records (as ``generate_questions`` writes them), or a CRAFT
    ``dataset.json`` (one video, chosen by ``video_index`` when it holds several)."""
    p = Path(path)
    data = read_json(p, "questions file")  # missing, a directory, not UTF-8, not JSON, too deep: InputFileError
    items = []
    for i, record in enumerate(_records(data, str(p), video_index)):
        where = f"{p}: question record {i}"
        if not isinstance(record, Mapping) or not isinstance(record.get("program"), list):
            raise PerceptionError(f"{where}: needs a 'program' node list")
        try:
            program = Program.from_nodes(record["program"])
        except CraftError as err:
            raise PerceptionError(f"{where}: field 'program': {err}") from None
        tid = record.get("template_id")
        if tid is None and "template_filename" in record and "question_family_index" in record:
            tid = f"{Path(str(record['template_filename'])).stem}_{record['question_family_index']}"
        items.append(QuestionItem(program, tid, str(record.get("question", "")), record.get("answer"),
                                  int(record.get("question_index", i))))
    return items


def accuracy_by_family(answered: Sequence[AnsweredQuestion]) -> dict[str, dict[str, float]]:
    """Per paper column (C, CF, D) and overall: questions, accuracy of the most likely world and of the mode."""
    groups: dict[str, list[AnsweredQuestion]] = {}
    for a in answered:
        if a.correct is None or a.item.template_id is None:
            continue
        groups.setdefault(family_of(a.item.template_id), []).append(a)
        groups.setdefault("All", []).append(a)
    out = {}
    for name in ("C", "CF", "D", "All"):
        group = groups.get(name, [])
        if not group:
            continue
        row = {"questions": float(len(group)), "most_likely": sum(bool(a.correct) for a in group) / len(group)}
        if group[0].distribution is not None:
            row["mode"] = sum(bool(a.mode_correct) for a in group) / len(group)
        out[name] = row
    return out
