"""Questions in words + a perceived scene -> answers (with their probability where a distribution is asked for).

The reader sees a questions file and video files only. Of each question record it reads ``video_index``,
``question_index`` and ``question`` (the text): never a program, template id, answer or simulation. The question's
program comes from its text (:func:`craft_dsl.question_parsing.question_to_program`); the video is found by its
index written in six digits (``<id6>.mpg`` or ``.mp4`` anywhere under the videos folder; folder names, which
hold the scene id in the published layout, are not read).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import CraftError, ReaderError
from ..files import read_json
from ..perception.distribution import answer_distributions
from ..perception.schema import PerceivedScene
from ..perception.world import SceneModel
from ..program import Program, to_json
from ..question_parsing import question_to_program
from ..types import DslType

VIDEO_SUFFIXES = (".mpg", ".mp4")


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
    ``"Red"``), with the probability of that answer when a distribution was computed, or the reason there is none."""

    question: Question
    answer: str | None
    probability: float | None = None
    program: str | None = None
    error: str | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"video_index": self.question.video_index,
                               "question_index": self.question.question_index, "answer": self.answer}
        if self.probability is not None:
            out["probability"] = round(self.probability, 6)
        if self.program is not None:
            out["program"] = self.program
        if self.error is not None:
            out["error"] = self.error
        return out


def _int_field(record: Mapping[str, Any], name: str, where: str) -> int:
    value = record.get(name)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ReaderError(f"{where}: field {name!r} must be an integer, got {value!r}")
    return value


def read_questions(path: str | os.PathLike[str]) -> list[Question]:
    """The questions of a ``dataset_minimal.json``-style file: a list of records with ``video_index``,
    ``question_index`` and ``question`` (other fields are not read)."""
    p = Path(path)
    data = read_json(p, "questions file")  # missing, a directory, not UTF-8, not JSON, too deep: InputFileError
    if not isinstance(data, list):
        raise ReaderError(f"{p}: expected a list of question records (as dataset_minimal.json), got "
                          f"{type(data).__name__}")
    out = []
    seen: set[tuple[int, int]] = set()
    for i, record in enumerate(data):
        where = f"{p}: record {i}"
        if not isinstance(record, Mapping):
            raise ReaderError(f"{where}: expected an object with video_index, question_index and question")
        vi = _int_field(record, "video_index", where)
        qi = _int_field(record, "question_index", where)
        text = record.get("question")
        if not isinstance(text, str) or not text.strip():
            raise ReaderError(f"{where}: field 'question' must be the question text, got {text!r}")
        if (vi, qi) in seen:
            raise ReaderError(f"{where}: question ({vi}, {qi}) is listed twice")
        seen.add((vi, qi))
        out.append(Question(vi, qi, text))
    return out


def find_videos(folder: str | os.PathLike[str], indices: Sequence[int]) -> dict[int, Path]:
    """The video file of each index (``<id6>.mpg`` or ``.mp4`` anywhere under ``folder``)."""
    root = Path(folder)
    if not root.is_dir():
        raise ReaderError(f"--videos {root}: no such folder")
    by_stem: dict[str, list[Path]] = {}
    for f in root.rglob("*"):
        if f.suffix.lower() in VIDEO_SUFFIXES and f.is_file():
            by_stem.setdefault(f.stem, []).append(f)
    out = {}
    for index in indices:
        found = sorted(by_stem.get(f"{index:06d}", []))
        if not found:
            raise ReaderError(f"no video for video_index {index}: expected {index:06d}.mpg (or .mp4) under {root}")
        if len(found) > 1 and len({f.suffix.lower() for f in found}) == len(found):
            found = [f for f in found if f.suffix.lower() == ".mpg"] or found
        if len(found) > 1:
            raise ReaderError(f"video_index {index}: several files under {root}: {', '.join(map(str, found))}")
        out[index] = found[0]
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


def answer_questions(scene: PerceivedScene, questions: Sequence[Question], distribution: bool = False,
                     samples: int = 64, seed: int = 0) -> list[Answer]:
    """Answer each question over ``scene``: on its most likely world, or as the mode of its answer distribution
    (with that answer's probability) when ``distribution`` is set."""
    model = SceneModel(scene)
    sim = model.simulation()
    programs: list[Program | None] = []
    errors: list[str | None] = []
    for q in questions:
        try:
            programs.append(question_to_program(q.text))
            errors.append(None)
        except CraftError as err:
            programs.append(None)
            errors.append(f"question not understood: {err}")
    dists: dict[int, Any] = {}
    if distribution:
        valid = [i for i, p in enumerate(programs) if p is not None]
        computed = answer_distributions(model, [programs[i] for i in valid], samples=samples,  # type: ignore[misc]
                                        seed=seed)
        dists = dict(zip(valid, computed))
    out = []
    for i, (q, program) in enumerate(zip(questions, programs)):
        if program is None:
            out.append(Answer(q, None, error=errors[i]))
            continue
        if i in dists:
            d = dists[i]
            out.append(Answer(q, format_answer(d.mode), d.p(d.mode), str(program)))
            continue
        try:
            value = program.run(sim)
        except CraftError as err:
            out.append(Answer(q, fallback_answer(program), program=str(program), error=f"cannot be answered: {err}"))
            continue
        answer = format_answer(value)
        if answer is None:  # the objects it names are not in the most likely world: weigh every reading
            d = answer_distributions(model, [program], samples=samples, seed=seed)[0]
            answer = format_answer(d.mode)
            if answer is None:
                out.append(Answer(q, fallback_answer(program), None, str(program),
                                  "INVALID in every reading: the objects it names are not in the perceived scene"))
                continue
            out.append(Answer(q, answer, d.p(d.mode), str(program)))
            continue
        out.append(Answer(q, answer, None, str(program)))
    return out


#: The guess for a question that has no answer over the perceived scene, by the program's answer type.
FALLBACK = {DslType.BOOL: "False", DslType.INTEGER: "0", DslType.COLOR: "Gray", DslType.SHAPE: "Cube",
            DslType.SIZE: "Small"}


def fallback_answer(program: Program) -> str:
    """A guess of the program's answer type (predictions files hold an answer for every question)."""
    return FALLBACK.get(program.type, "False")
