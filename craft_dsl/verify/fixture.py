"""A small dataset in the published formats, for tests and demos (not the generation pipeline)."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..program import to_json
from ..simulation import Simulation
from ..templates import first_instances, question_text


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
    from ..recorded import simulation_dict

    items = sorted(sims.items()) if isinstance(sims, Mapping) else list(enumerate(sims))
    dataset: list[dict[str, Any]] = []
    annotations: dict[str, Any] = {}
    for video_index, sim in items:
        id6 = f"{video_index:06d}"
        found_sid = re.search(r"sid_(\d+)", str(sim.meta.get("video_filename", "")))
        sid = str(sim.meta.get("scene", found_sid.group(1) if found_sid else "0"))
        video_path = f"./videos/sid_{sid}/{id6}.mpg"
        records: list[dict[str, Any]] = []
        for template, params, program, answer in first_instances(sim, include_dropped):
            records.append({
                "video_filename": video_path, "video_index": video_index, "video": id6,
                "question": question_text(template.id, params),
                "program": program.to_nodes(outputs=sim),
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
    """``dataset_minimal.json`` records of a ``dataset.json`` list, as the released data has them:
    answers as strings, colours and shapes capitalised, ``answer_type`` and ``question_type`` filled in."""
    from ..vocabulary import COLORS, SHAPES, SIZES

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
