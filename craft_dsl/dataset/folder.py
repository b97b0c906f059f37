"""A CRAFT-format dataset folder as its users read it: questions, splits, simulations, media and provenance.

Works on a folder written by ``craft-dsl generate`` and on the published CRAFT dataset alike (both hold
``dataset_minimal.json``, ``dataset.json``, ``split_info_{random,hard}.json`` and ``annotations.json``).
Files are read when first asked for; every error is a :class:`CraftError` naming the file.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from functools import cached_property
from pathlib import Path
from typing import Any

from ..errors import CraftError
from ..files import read_json
from ..verify.annotations import Annotations
from ..verify.categories import category_of, family_of
from ..verify.formats import Question, _read_json, parse_dataset, parse_minimal, parse_split
from ..vocabulary import LEGACY_DEFAULT_ENGINE
from .layout import DEFAULT_VIDEO_FORMAT, frame_relpath, id6, resolve, video_relpath
from .samplers import LEGACY_SAMPLER

#: The settings a ``generation_config.json`` may leave out, with what a file without them was made with: pymunk,
#: the default engine before Box2D, and revision 1 of the layout files.
LEGACY_SETTINGS: dict[str, str] = {"engine": LEGACY_DEFAULT_ENGINE, "sampler": LEGACY_SAMPLER}


def with_legacy_defaults(recorded: dict[str, Any]) -> dict[str, Any]:
    """A recorded ``generation_config.json`` with the settings of its time filled in (:data:`LEGACY_SETTINGS`;
    the file itself is left as it is)."""
    return {**{k: v for k, v in LEGACY_SETTINGS.items() if k not in recorded}, **recorded}


def as_recorded(settings: dict[str, Any]) -> dict[str, Any]:
    """``settings`` as ``generation_config.json`` and the report write them: a sampler at its legacy value is left
    out, so the files of a dataset made before the setting existed keep their bytes."""
    return {k: v for k, v in settings.items() if not (k == "sampler" and v == LEGACY_SAMPLER)}

#: The two splits of the published dataset: "random" (the paper's easy split) and "hard" (held-out scenes).
SPLITS: tuple[str, ...] = ("random", "hard")
PARTS: tuple[str, ...] = ("train", "validation", "test")
Key = tuple[int, int]


class DatasetFolder:
    """Read-only view of one dataset folder (``DatasetFolder(path)``; nothing is read until asked for)."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root)
        if not self.root.is_dir():
            raise CraftError(f"{self.root}: no such dataset folder")
        if not (self.root / "dataset_minimal.json").is_file():
            raise CraftError(f"{self.root}: not a CRAFT dataset folder (no dataset_minimal.json; make one with "
                             "craft-dsl generate)")

    # -- questions --------------------------------------------------------------------------------------------

    @cached_property
    def records(self) -> list[dict[str, Any]]:
        """The ``dataset_minimal.json`` records (validated), in file order, with ``category`` and ``family``."""
        path = self.root / "dataset_minimal.json"
        data = _read_json(path, "dataset_minimal.json")
        questions = parse_minimal(data, str(path))
        out = []
        for raw, q in zip(data, questions, strict=True):
            rec = dict(raw)
            rec["template_id"] = q.template_id
            rec["simulation_id"] = str(raw.get("simulation_id", ""))
            rec["category"] = category_of(q.template_id)
            rec["family"] = family_of(q.template_id)
            rec.setdefault("question_type", q.question_type)
            out.append(rec)
        return out

    @cached_property
    def _dataset_questions(self) -> list[Question]:
        path = self.root / "dataset.json"
        if not path.is_file():
            return []
        return parse_dataset(_read_json(path, "dataset.json"), str(path))

    @cached_property
    def programs(self) -> dict[Key, list[dict[str, Any]]]:
        """Node list of every question, from ``dataset.json`` (``{}`` if the folder has none)."""
        return {q.key: [dict(n) for n in (q.program or ())] for q in self._dataset_questions}

    @cached_property
    def raw_answers(self) -> dict[Key, Any]:
        """Raw answers of ``dataset.json`` (booleans, integers, lowercase strings)."""
        return {q.key: q.answer for q in self._dataset_questions}

    def by_video(self) -> dict[int, list[dict[str, Any]]]:
        """Records grouped by video index (ascending), each group in question-index order."""
        out: dict[int, list[dict[str, Any]]] = {}
        for rec in sorted(self.records, key=lambda r: (r["video_index"], r["question_index"])):
            out.setdefault(int(rec["video_index"]), []).append(rec)
        return out

    # -- splits -----------------------------------------------------------------------------------------------

    def split(self, name: str) -> dict[str, set[Key]]:
        """``{"train": keys, "validation": keys, "test": keys}`` of ``split_info_<name>.json``."""
        if name not in SPLITS:
            raise CraftError(f"unknown split {name!r}; allowed: {', '.join(SPLITS)}")
        return self._splits[name]

    @cached_property
    def _splits(self) -> dict[str, dict[str, set[Key]]]:
        out = {}
        for name in SPLITS:
            path = self.root / f"split_info_{name}.json"
            data = _read_json(path, f"split_info_{name}.json")
            out[name] = {part: parse_split(data, part, str(path)) for part in PARTS}
        return out

    def part_of(self, name: str) -> dict[Key, str]:
        """The part (train, validation, test) of every question key in split ``name``."""
        return {key: part for part, keys in self.split(name).items() for key in keys}

    # -- provenance -------------------------------------------------------------------------------------------

    def _optional_json(self, name: str) -> Any:
        path = self.root / name
        return _read_json(path, name) if path.is_file() else None

    @cached_property
    def config(self) -> dict[str, Any] | None:
        """``generation_config.json`` with the settings of its time filled in (:func:`with_legacy_defaults`;
        ``None`` for a dataset not made by ``craft-dsl generate``)."""
        data = self._optional_json("generation_config.json")
        return with_legacy_defaults(data) if isinstance(data, dict) else None

    @cached_property
    def report(self) -> dict[str, Any] | None:
        """``generation_report.json`` (``None`` if absent)."""
        data = self._optional_json("generation_report.json")
        return data if isinstance(data, dict) else None

    def instance_stats(self, video_index: int) -> dict[str, Any] | None:
        """The generator's per-video record (scene, simulation seed, ...) from ``questions/qa_<id6>.json``."""
        path = self.root / "questions" / f"qa_{id6(video_index)}.json"
        if not path.is_file():
            return None
        try:
            data = read_json(path, "per-video record")
        except CraftError:  # unreadable, deeply nested, not JSON: the viewer shows the video without it
            return None
        stats = data.get("stats") if isinstance(data, Mapping) else None
        return dict(stats) if isinstance(stats, Mapping) else None

    # -- simulations and media --------------------------------------------------------------------------------

    @cached_property
    def annotations(self) -> Annotations:
        """Recorded simulations with their counterfactual variations (``annotations.json``, else
        ``intermediates/``)."""
        if (self.root / "annotations.json").is_file():
            return Annotations.open(self.root / "annotations.json")
        if (self.root / "intermediates").is_dir():
            return Annotations.open(self.root / "intermediates")
        raise CraftError(f"{self.root}: no annotations.json (nor intermediates/) with the simulations")

    @property
    def video_format(self) -> str:
        """The video extension the records name (``mpg`` unless the dataset was made with ``mp4``)."""
        if self.config and self.config.get("video_format"):
            return str(self.config["video_format"])
        for rec in self.records[:1]:
            return str(rec.get("video_file_path", "")).rpartition(".")[2] or DEFAULT_VIDEO_FORMAT
        return DEFAULT_VIDEO_FORMAT

    def video_relpath(self, record: Mapping[str, Any]) -> str:
        """The record's ``video_file_path`` (or the published layout's path for its scene and index)."""
        path = record.get("video_file_path")
        if isinstance(path, str) and path:
            return path
        return video_relpath(int(record.get("simulation_id") or 0), int(record["video_index"]), self.video_format)

    def video_file(self, record: Mapping[str, Any]) -> Path:
        return resolve(self.root, self.video_relpath(record))

    def frame_file(self, record: Mapping[str, Any], which: str = "first") -> Path:
        return resolve(self.root, frame_relpath(self.video_relpath(record), which))


__all__ = ["PARTS", "SPLITS", "DatasetFolder", "Key"]
