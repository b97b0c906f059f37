"""The dataset-level stages of generation, as pure functions over plain records (each testable alone).

:func:`post_process`, :func:`balance` (seeded; groups are (scene, template), so a scene's
questions are balanced alone), :func:`hard_split` / :func:`random_split` and :func:`dataset_videos`
(``dataset.json``). :mod:`craft_dsl.dataset.instance` applies the post-process per video in the workers;
:mod:`craft_dsl.dataset.merge` balances one scene at a time and splits at the end.
"""

from __future__ import annotations

from collections import Counter, defaultdict
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..templates import DROPPED, templates
from ..verify.records import template_id_of, video_record
from .layout import DEFAULT_VIDEO_FORMAT, video_relpath

#: Fixed "hard" split of the 20 scene ids (computed by the original with seed 10435).
HARD_SPLIT: dict[str, frozenset[int]] = {
    "train": frozenset({1, 2, 3, 4, 5, 6, 7, 9, 10, 15, 19, 20}),
    "validation": frozenset({8, 12, 14, 16}),
    "test": frozenset({11, 13, 17, 18}),
}
SPLIT_PARTS: tuple[str, ...] = ("train", "validation", "test")

# tags mixed into the seed sequences so that each purpose gets its own stream
_BALANCE_TAG = 0xBA1A
_SPLIT_TAG = 0x5B17


def video_path(scene: int, instance_id: int, video_format: str = DEFAULT_VIDEO_FORMAT) -> str:
    """The dataset-relative video path recorded in every file (``./videos/sid_<s>/<id6>.mpg``)."""
    return video_relpath(scene, instance_id, video_format)


def hard_part(scene: int) -> str:
    """The part of the hard split a scene's questions go to; a custom layout's scene (not in :data:`HARD_SPLIT`)
    is held out: ``test``."""
    return next((part for part in SPLIT_PARTS if scene in HARD_SPLIT[part]), "test")


def random_parts(videos: Iterable[int], seed: int) -> dict[int, str]:
    """The random split's part of every video with questions: the sorted indices shuffled once (seeded),
    test = validation = int(0.2 N), train = the rest, taken in that order."""
    ordered = sorted(set(videos))
    order = np.random.default_rng(np.random.SeedSequence([seed, _SPLIT_TAG])).permutation(len(ordered))
    shuffled = [ordered[i] for i in order]
    n_test = n_val = int(0.2 * len(ordered))
    n_train = len(ordered) - n_test - n_val
    part_of = {v: "train" for v in shuffled[:n_train]}
    part_of.update({v: "validation" for v in shuffled[n_train:n_train + n_val]})
    part_of.update({v: "test" for v in shuffled[n_train + n_val:]})
    return part_of


# -- post-process ------------------------------------------------------------------------------------

_PREVENT_FIXES = ("is prevented by", "is kept by", "is held by", "is blocked by")


def _is_shape_answer(answer: Any) -> bool:
    from ..vocabulary import SHAPES

    return isinstance(answer, str) and answer.lower() in SHAPES


def post_process(
    records: Iterable[Mapping[str, Any]], dynamic_shape_counts: Mapping[int, int]
) -> tuple[list[dict[str, Any]], Counter[str]]:
    """The pre-balancing post-process over question records (raw answers).

    Drops Shape questions of videos whose dynamic objects have <= 1 distinct shape (``dynamic_shape_counts``:
    video index -> number of distinct dynamic shapes), questions mentioning "hexagon", and the 19 basket
    templates (:data:`craft_dsl.templates.DROPPED`); applies the text fixes (the ``counterfactual_2`` one is
    unreachable, as in the original, because that template is dropped). Returns the kept records (copies) and
    the number dropped per rule.
    """
    kept: list[dict[str, Any]] = []
    dropped: Counter[str] = Counter()
    for rec in records:
        tid = template_id_of(rec)
        text = str(rec.get("question", ""))
        if _is_shape_answer(rec["answer"]) and dynamic_shape_counts.get(int(rec["video_index"]), 0) <= 1:
            dropped["shape_single_shape"] += 1
            continue
        if "hexagon" in text:
            dropped["hexagon"] += 1
            continue
        if tid in DROPPED:
            dropped["basket_template"] += 1
            continue
        new = dict(rec)
        if tid in ("prevent_0", "prevent_1", "prevent_2") and text.startswith("Is"):
            for phrase in _PREVENT_FIXES:
                text = text.replace(phrase, phrase[len("is "):])
            new["question"] = text
        kept.append(new)
    return kept, dropped


# -- balancing ---------------------------------------------------------------------------------------


def answer_label(answer: Any) -> str:
    """The string a balancing group counts (``str`` of the raw answer, capitalised as the original does first)."""
    return str(answer).capitalize()


def _is_outlier(label: str) -> bool:
    return label.isdigit() and 3 <= int(label) <= 10


def _template_number(tid: str) -> int:
    return list(templates()).index(tid) if tid in templates() else -1


def balance(
    records: Sequence[Mapping[str, Any]], scene_of: Mapping[int, int], seed: int
) -> tuple[list[dict[str, Any]], Counter[str]]:
    """Answer balancing within each (scene, template) group over the merged dataset, seeded.

    Per group: <= 1 distinct answer -> the group is dropped ("purged"); answers 3..10 are set aside and kept;
    if the rest has >= 2 distinct answers every answer is undersampled, without replacement, to the count of
    the rarest one. The draw of each group comes from ``SeedSequence([seed, tag, scene, template number])``, so
    it depends only on the group's own questions. Kept records keep their input order. Returns the kept records
    and counts ``purged_single_answer`` / ``undersampled``.
    """
    groups: dict[tuple[int, int], list[int]] = defaultdict(list)
    for i, rec in enumerate(records):
        groups[(int(scene_of[int(rec["video_index"])]), _template_number(template_id_of(rec)))].append(i)
    keep: set[int] = set()
    counts: Counter[str] = Counter()
    for (scene, tnum), members in sorted(groups.items()):
        labels = {i: answer_label(records[i]["answer"]) for i in members}
        if len(set(labels.values())) <= 1:
            counts["purged_single_answer"] += len(members)
            continue
        rest = [i for i in members if not _is_outlier(labels[i])]
        keep.update(i for i in members if _is_outlier(labels[i]))
        by_label: dict[str, list[int]] = defaultdict(list)
        for i in rest:
            by_label[labels[i]].append(i)
        if len(by_label) <= 1:
            keep.update(rest)
            continue
        smallest = min(len(v) for v in by_label.values())
        rng = np.random.default_rng(np.random.SeedSequence([seed, _BALANCE_TAG, scene, tnum + 1]))
        for label in sorted(by_label):
            items = by_label[label]
            chosen = sorted(rng.choice(len(items), size=smallest, replace=False).tolist())
            keep.update(items[j] for j in chosen)
            counts["undersampled"] += len(items) - smallest
    return [dict(records[i]) for i in range(len(records)) if i in keep], counts


# -- splits ------------------------------------------------------------------------------------------


def _keys(records: Iterable[Mapping[str, Any]]) -> list[dict[str, int]]:
    return [{"video_index": int(r["video_index"]), "question_index": int(r["question_index"])} for r in records]


def hard_split(records: Sequence[Mapping[str, Any]], scene_of: Mapping[int, int]) -> dict[str, list[dict[str, int]]]:
    """The fixed held-out-scene split: every question goes to the part of its scene (:func:`hard_part`)."""
    return {part: _keys(r for r in records if hard_part(scene_of[int(r["video_index"])]) == part)
            for part in SPLIT_PARTS}


def random_split(records: Sequence[Mapping[str, Any]], seed: int) -> dict[str, list[dict[str, int]]]:
    """The "easy" split: the sorted video indices are shuffled once (seeded), test = validation = int(0.2 N),
    train = the rest, taken in that order; whole videos go to one part."""
    part_of = random_parts((int(r["video_index"]) for r in records), seed)
    return {part: _keys(r for r in records if part_of[int(r["video_index"])] == part) for part in SPLIT_PARTS}


# -- dataset.json ------------------------------------------------------------------------------------------------


def dataset_videos(
    records: Sequence[Mapping[str, Any]], scene_of: Mapping[int, int], video_format: str = DEFAULT_VIDEO_FORMAT
) -> list[dict[str, Any]]:
    """The ``dataset.json`` list: one element per video with questions, ascending, raw answers."""
    by_video: dict[int, list[dict[str, Any]]] = defaultdict(list)
    for rec in records:
        by_video[int(rec["video_index"])].append(dict(rec))
    out = []
    for vi in sorted(by_video):
        path = video_path(scene_of[vi], vi, video_format)
        qs = sorted(by_video[vi], key=lambda r: int(r["question_index"]))
        out.append(video_record(scene_of[vi], path, vi, qs))
    return out


__all__ = ["HARD_SPLIT", "SPLIT_PARTS", "answer_label", "balance", "dataset_videos", "hard_part", "hard_split",
           "post_process", "random_parts", "random_split", "template_id_of", "video_path"]
