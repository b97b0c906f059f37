"""The published record formats, written in one place: question records and video elements of
``dataset.json``, and ``dataset_minimal.json`` records. Key order is part of the format (files are compared
byte for byte), so every writer builds its records here."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..vocabulary import COLORS, SHAPES, SIZES


def question_record(*, video_filename: str, video_index: int, question: str, program: list[dict[str, Any]],
                    answer: Any, family: str, family_index: int, question_index: int,
                    template_id: str | None = None) -> dict[str, Any]:
    """One question of ``dataset.json`` (``answer`` raw: bool, int or lowercase str; ``template_id`` is ours and
    is written only when given)."""
    record: dict[str, Any] = {
        "video_filename": video_filename, "video_index": video_index, "video": f"{video_index:06d}",
        "question": question, "program": program, "answer": answer, "template_filename": f"{family}.json",
        "question_family_index": family_index, "question_index": question_index,
    }
    if template_id is not None:
        record["template_id"] = template_id
    return record


def video_record(simulation_id: int | str, video_path: str, video_index: int,
                 questions: list[dict[str, Any]]) -> dict[str, Any]:
    """One element of ``dataset.json``: a video and its questions."""
    return {"simulation_id": str(simulation_id), "video_path": video_path,
            "questions": {"info": {"video_filename": video_path, "video_index": video_index},
                          "questions": questions}}


def template_id_of(record: Mapping[str, Any]) -> str:
    """``"cause_3"``: the record's ``template_id``, or its template file and family index."""
    tid = record.get("template_id")
    if tid:
        return str(tid)
    return f"{Path(str(record['template_filename'])).stem}_{record['question_family_index']}"


def answer_type(answer: str) -> str:
    """``Boolean``, ``Shape``, ``Color``, ``Size`` or ``Count``, of an answer written as ``str(raw answer)``."""
    return ("Boolean" if answer in ("True", "False") else "Shape" if answer in SHAPES
            else "Color" if answer in COLORS else "Size" if answer in SIZES else "Count")


def minimal_records(dataset: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """``dataset_minimal.json`` records of a ``dataset.json`` list, as the released data has them:
    answers as strings, colours and shapes capitalised, ``answer_type`` and ``question_type`` filled in."""
    out: list[dict[str, Any]] = []
    for video in dataset:
        sid = str(video.get("simulation_id", "0"))
        for q in video["questions"]["questions"]:
            answer = str(q["answer"])
            stem = Path(q["template_filename"]).stem
            out.append({
                "question": q.get("question", ""), "answer": answer.capitalize(), "answer_type": answer_type(answer),
                "template_filename": q["template_filename"], "video_file_path": video.get("video_path", ""),
                "video_index": q["video_index"], "question_index": q["question_index"],
                "question_family_index": q["question_family_index"],
                "template_id": f"{stem}_{q['question_family_index']}", "simulation_id": sid,
                "question_type": stem.capitalize(),
            })
    return out
