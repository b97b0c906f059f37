"""The reader's question and answer records, and answers written as ``dataset_minimal.json`` writes them.

Shared by :mod:`~craft_dsl.reader.answer` (which answers), :mod:`~craft_dsl.reader.votes` (which votes on
counterfactual answers) and :mod:`~craft_dsl.reader.confidence` (which scores them), so that none of those imports
another that imports it back. :mod:`craft_dsl.reader.answer` re-exports every name here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..program import to_json


@dataclass(frozen=True)
class Question:
    """One question to answer: which video, which question of it, and its text."""

    video_index: int
    question_index: int
    text: str

    @property
    def key(self) -> str:
        return f"{self.video_index}_{self.question_index}"


@dataclass(frozen=True)
class Answer:
    """The reader's answer to one question, as ``dataset_minimal.json`` writes answers (``"True"``, ``"2"``,
    ``"Red"``), with the probability of that answer when a distribution was computed, or the reason there is none.
    ``fallback``: the answer is a guess of the program's answer type (:func:`~craft_dsl.reader.answer.
    fallback_answer`), not read from the video; ``error`` says why. ``premise``: the answer comes from a reading that
    reads one object otherwise (one or two of its attributes), the one the question names
    (:mod:`craft_dsl.perception.premise`), and says which. ``votes``: for a counterfactual question, how many of the
    replays (the reader's own and the perturbed ones, :func:`~craft_dsl.reader.votes.vote_counterfactuals`) gave
    each answer. ``warning``: why the video it was read from is not whole (its answers may be wrong).
    ``unchecked``: what could not be checked about the video (each a sentence; the answer stands).
    ``confidence``: the probability that the answer is right (:mod:`craft_dsl.reader.confidence`), from
    ``confidence_inputs``, what the reading showed about it (with what could not be measured, and why)."""

    question: Question
    answer: str | None
    probability: float | None = None
    program: str | None = None
    error: str | None = None
    fallback: bool = False
    premise: str | None = None
    votes: dict[str, int] | None = None
    warning: str | None = None
    confidence: float | None = None
    confidence_inputs: dict[str, Any] | None = None
    unchecked: tuple[str, ...] = ()

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"video_index": self.question.video_index,
                               "question_index": self.question.question_index, "answer": self.answer}
        if self.probability is not None:
            out["probability"] = round(self.probability, 6)
        if self.program is not None:
            out["program"] = self.program
        if self.error is not None:
            out["error"] = self.error
        if self.fallback:
            out["fallback"] = True
        if self.premise is not None:
            out["premise"] = self.premise
        if self.votes is not None:
            out["votes"] = self.votes
        if self.warning is not None:
            out["warning"] = self.warning
        if self.unchecked:
            out["unchecked"] = list(self.unchecked)
        if self.confidence is not None:
            out["confidence"] = round(self.confidence, 6)
        if self.confidence_inputs is not None:
            out["confidence_inputs"] = self.confidence_inputs
        return out


def format_answer(value: Any) -> str | None:
    """An answer as ``dataset_minimal.json`` writes it: ``"True"``, ``"2"``, ``"Red"``; None for INVALID."""
    raw = to_json(value, original=True)
    if isinstance(raw, bool):
        return "True" if raw else "False"
    if isinstance(raw, int):
        return str(raw)
    if isinstance(raw, str):
        return None if raw == "__INVALID__" else raw.capitalize()
    return None


__all__ = ["Answer", "Question", "format_answer"]
