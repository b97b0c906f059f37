"""A small dataset in the published formats, for tests and demos (not the generation pipeline)."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

from ..program import to_json
from ..simulation import Simulation
from ..templates import first_instances, question_text
from .records import question_record, video_record


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
            records.append(question_record(
                video_filename=video_path, video_index=video_index, question=question_text(template.id, params),
                program=program.to_nodes(outputs=sim), answer=to_json(answer, original=True),
                family=template.family, family_index=template.index, question_index=len(records)))
        data = simulation_dict(sim)
        data["original_video_output"]["video_filename"] = video_path
        annotations[id6] = data
        dataset.append(video_record(sid, video_path, video_index, records))
    return dataset, annotations
