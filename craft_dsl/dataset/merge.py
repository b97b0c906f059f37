"""The dataset-level merge, streamed one scene at a time while the workers go on.

Balancing groups are (scene, template) and the work list gives each scene one block of consecutive video ids, so
once the last video of a scene's block is done, everything about that block is known but the random split:
:meth:`Merger.merge_block` balances the block's questions (from the shard headers alone), then appends its part
of every large file (``dataset.json``, ``dataset_minimal.json``, ``balanced_dataset.json``,
``imbalanced_dataset.json``, ``annotations.json``, the hard split's Hugging Face files) to a growing file in the
work folder ``.generate/``, writes the block's small per-video files, and commits a journal
(``.generate/state.json``, written atomically): the byte length of every growing file and the running counts.
The block's shards are deleted after the commit. Only the last block and :meth:`Merger.finish` (the splits, the
random split's Hugging Face files, renaming the grown files into place, the report and the dataset card) run
after the last video.

Interruption: a run killed at any moment leaves the journal of the last committed block; the next run truncates
every growing file to its committed length and goes on with the next block, so no merged block is merged again
and the result has the bytes of an uninterrupted run. :meth:`Merger.finish` is re-entrant.
"""

from __future__ import annotations

import json
import os
import shutil
import threading
from collections import Counter, defaultdict
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from ..atomic import atomic_path
from ..errors import CraftError
from ..templates import templates
from ..verify.records import video_record
from .instance import read_shard
from .layout import id6, park_videos_without_questions
from .stages import SPLIT_PARTS, balance, hard_part, random_parts, video_path

#: The work folder inside the output folder (shards, growing files, journal); removed when the run finishes.
WORK_FOLDER = ".generate"
#: Version of the journal and shard layout; a work folder of another version is discarded.
STATE_FORMAT = 2

# growing file -> (opening bytes, closing bytes, separator between items, target path relative to the root)
_ARRAY = ("[", "]\n", ", ")
_STREAMS: dict[str, tuple[str, str, str, str | None]] = {
    "dataset": (*_ARRAY, "dataset.json"),
    "minimal": (*_ARRAY, "dataset_minimal.json"),
    "balanced": (*_ARRAY, "balanced_dataset.json"),
    "imbalanced": (*_ARRAY, "imbalanced_dataset.json"),
    "annotations": ("{", "\n}\n", ",", "annotations.json"),
    **{f"hard_{part}": ("", "", "", f"hf/hard/{part}.jsonl") for part in SPLIT_PARTS},
    "rows": ("", "", "", None),  # every final row, split into hf/random/ by finish()
}
_REPORT_KEYS = ("generated", "dropped_by_perturbation", "after_post_process", "final")


def shard_path(root: Path, instance_id: int) -> Path:
    return root / WORK_FOLDER / "shards" / f"{id6(instance_id)}.shard"


def qa_path(root: Path, instance_id: int) -> Path:
    return root / "questions" / f"qa_{id6(instance_id)}.json"


def intermediate_path(root: Path, scene: int, instance_id: int) -> Path:
    return root / "intermediates" / f"sid_{scene}" / f"{id6(instance_id)}.json"


def _write_text(path: Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _write_json(data: Any, path: Path, indent: int | None = None, sort_keys: bool = False) -> None:
    _write_text(path, json.dumps(data, indent=indent, sort_keys=sort_keys) + "\n")


def blocks_of(work: Sequence[tuple[int, int]]) -> list[tuple[int, list[int]]]:
    """The work list's scene blocks: (scene, its consecutive instance ids), in order."""
    out: list[tuple[int, list[int]]] = []
    for i, scene in work:
        if not out or out[-1][0] != scene:
            out.append((scene, []))
        out[-1][1].append(i)
    return out


def new_state() -> dict[str, Any]:
    return {"format": STATE_FORMAT, "blocks_merged": 0, "closed": False,
            "lengths": {name: 0 for name in _STREAMS}, "items": {name: 0 for name in _STREAMS},
            "totals": {}, "post_process": {}, "balancing": {}, "per_template": {}, "final_keys": [],
            "videos_with_questions": 0}


def load_state(root: Path) -> dict[str, Any] | None:
    """The journal of the work folder, or None when there is none (or one of another version)."""
    path = root / WORK_FOLDER / "state.json"
    try:
        state = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return state if isinstance(state, dict) and state.get("format") == STATE_FORMAT else None


class Merger:
    """Merges the blocks of one run in order (see the module docstring). ``stop`` is checked between videos:
    when it is set, :meth:`merge_block` returns without committing (the next run redoes that block)."""

    def __init__(self, root: Path, config: Any, work: Sequence[tuple[int, int]], state: dict[str, Any],
                 log: Callable[[str], None] = lambda _msg: None) -> None:
        self.root = root
        self.config = config
        self.scene_of = dict(work)
        self.blocks = blocks_of(work)
        self.state = state
        self.log = log
        self.stop = threading.Event()
        self.work = root / WORK_FOLDER
        self.work.mkdir(parents=True, exist_ok=True)
        for name, (opening, _closing, _sep, _target) in _STREAMS.items():
            path = self._partial(name)
            length = int(state["lengths"][name])
            if length == 0:
                path.write_text(opening, encoding="utf-8")
                state["lengths"][name] = len(opening.encode("utf-8"))
            elif not state["closed"]:
                with path.open("r+b") as fh:  # drop what an interrupted block appended after the last commit
                    fh.truncate(length)

    def _partial(self, name: str) -> Path:
        return self.work / f"{name}.partial"

    @property
    def merged(self) -> int:
        return int(self.state["blocks_merged"])

    def block_ids(self, block: int) -> list[int]:
        return self.blocks[block][1]

    def _save(self) -> None:
        _write_json(self.state, self.work / "state.json")

    # -- one block ---------------------------------------------------------------------------------------------

    def merge_block(self, block: int) -> bool:
        """Merge block ``block`` (the next one); True when committed."""
        if block != self.merged:
            raise CraftError(f"internal error: block {block} merged out of order (next is {self.merged})")
        scene, ids = self.blocks[block]
        headers = {i: read_shard(shard_path(self.root, i), body=False).header for i in ids}
        questions = [{"video_index": i, "question_index": qi, "template_id": tid, "answer": label}
                     for i in ids for qi, tid, label in headers[i]["questions"]]
        if self.config.balance:
            kept, counts = balance(questions, self.scene_of, self.config.seed)
        else:
            kept, counts = [dict(q) for q in questions], Counter()
        final: dict[int, set[int]] = defaultdict(set)
        for q in kept:
            final[q["video_index"]].add(q["question_index"])

        state = self.state
        out: dict[str, list[str]] = {name: [] for name in _STREAMS}  # texts appended by this block, per stream
        totals: Counter[str] = Counter(state["totals"])
        per_template: dict[str, Counter[str]] = defaultdict(Counter)
        for tid, c in state["per_template"].items():
            per_template[tid].update(c)
        post: dict[str, int] = dict(state["post_process"])
        with_questions = 0
        final_keys: list[list[int]] = []
        for i in ids:
            if self.stop.is_set():
                return False
            header = headers[i]
            stats = header["stats"]
            for tid in stats["generated"]:
                per_template[tid]["generated"] += 1
            for tid in stats["dropped_by_perturbation"]:
                per_template[tid]["dropped_by_perturbation"] += 1
            totals["generated"] += len(stats["generated"])
            totals["dropped_by_perturbation"] += len(stats["dropped_by_perturbation"])
            totals["after_perturbation"] += int(header["after_perturbation"])
            totals["after_post_process"] += len(header["questions"])
            for rule, n in header["dropped_by_post_process"].items():
                post[rule] = post.get(rule, 0) + int(n)
            shard = read_shard(shard_path(self.root, i))
            keep = final.get(i, set())
            vpath = video_path(scene, i, self.config.video_format)
            out["imbalanced"].extend(shard.minimal)
            chosen = [k for k, (qi, _tid, _label) in enumerate(header["questions"]) if qi in keep]
            for qi, tid, _label in header["questions"]:
                per_template[tid]["after_post_process"] += 1
                if qi in keep:
                    per_template[tid]["final"] += 1
            if chosen:
                with_questions += 1
                element = json.dumps(video_record(scene, vpath, i, []))
                assert element.endswith("[]}}")
                out["dataset"].append(element[:-4] + "[" + ", ".join(shard.records[k] for k in chosen) + "]}}")
                out["minimal"].extend(shard.minimal[k] for k in chosen)
                out["balanced"].extend(shard.minimal[k] for k in chosen)
                out["annotations"].append("\n" + json.dumps(id6(i)) + ": " + shard.annotation)
                out[f"hard_{hard_part(scene)}"].extend(shard.rows[k] + "\n" for k in chosen)
                out["rows"].extend(shard.rows[k] + "\n" for k in chosen)
                final_keys.extend([i, header["questions"][k][0]] for k in chosen)
                intermediate_path(self.root, scene, i).unlink(missing_ok=True)
            else:
                _write_text(intermediate_path(self.root, scene, i), shard.annotation + "\n")
            _write_json({"info": {"video_filename": vpath, "video_index": i}, "stats": stats},
                        qa_path(self.root, i))
        if self.stop.is_set():
            return False
        for name, texts in out.items():
            if texts:
                self._append(name, texts)
        totals["final"] += len(kept)
        balancing = dict(state["balancing"])
        for key, n in counts.items():
            balancing[key] = balancing.get(key, 0) + int(n)
        state.update(blocks_merged=block + 1, totals=dict(totals), post_process=post, balancing=balancing,
                     per_template={t: dict(c) for t, c in per_template.items()},
                     final_keys=state["final_keys"] + final_keys,
                     videos_with_questions=int(state["videos_with_questions"]) + with_questions)
        self._save()
        for i in ids:
            shard_path(self.root, i).unlink(missing_ok=True)
        self.log(f"merged scene {scene} (videos {ids[0]}-{ids[-1]}): {len(questions)} questions after the "
                 f"post-process, {len(kept)} kept")
        return True

    def _append(self, name: str, texts: list[str]) -> None:
        sep = _STREAMS[name][2]
        n = int(self.state["items"][name])
        data = "".join((sep if n + k else "") + t for k, t in enumerate(texts)).encode("utf-8")
        path = self._partial(name)
        with path.open("ab") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        self.state["lengths"][name] = int(self.state["lengths"][name]) + len(data)
        self.state["items"][name] = n + len(texts)

    # -- the end -------------------------------------------------------------------------------------------------

    def finish(self, work: Sequence[tuple[int, int]]) -> dict[str, Any]:
        """Splits, random-split Hugging Face files, files renamed into place, report, card; removes the work
        folder. Re-entrant: a run killed here finishes on the next run."""
        from .hf import finish_streamed

        state, root, config = self.state, self.root, self.config
        if self.merged != len(self.blocks):
            raise CraftError(f"internal error: {self.merged} of {len(self.blocks)} scene blocks merged")
        if not state["closed"]:
            for name, (_opening, closing, _sep, _target) in _STREAMS.items():
                if closing:
                    with self._partial(name).open("ab") as fh:
                        fh.write(closing.encode("utf-8"))
                        fh.flush()
                        os.fsync(fh.fileno())
            state["closed"] = True
            self._save()
        keys = [(int(v), int(q)) for v, q in state["final_keys"]]
        with_questions = sorted({v for v, _ in keys})
        part_random = random_parts(with_questions, config.seed)
        hard: dict[str, list[dict[str, int]]] = {p: [] for p in SPLIT_PARTS}
        rand: dict[str, list[dict[str, int]]] = {p: [] for p in SPLIT_PARTS}
        for v, q in keys:
            key = {"video_index": v, "question_index": q}
            hard[hard_part(self.scene_of[v])].append(key)
            rand[part_random[v]].append(key)
        self._write_random_rows(part_random)
        for name, (_o, _c, _s, target) in _STREAMS.items():
            if target is not None and self._partial(name).exists():
                (root / target).parent.mkdir(parents=True, exist_ok=True)
                os.replace(self._partial(name), root / target)
        _write_json(hard, root / "split_info_hard.json")
        _write_json(rand, root / "split_info_random.json")
        no_questions = sorted(set(self.scene_of) - set(with_questions))
        _write_json(no_questions, root / "videos_with_no_questions.json", indent=2)
        park_videos_without_questions(root, self.scene_of, with_questions, config.video_format)
        totals = state["totals"]
        per_template = state["per_template"]
        report: dict[str, Any] = {
            "config": config.content(),
            "videos": {"total": len(work), "with_questions": len(with_questions),
                       "without_questions": len(no_questions), "annotations": int(state["videos_with_questions"])},
            "questions": {
                "generated": int(totals.get("generated", 0)),
                "dropped_by_perturbation": int(totals.get("dropped_by_perturbation", 0)),
                "after_perturbation": int(totals.get("after_perturbation", 0)),
                "dropped_by_post_process": dict(sorted(state["post_process"].items())),
                "after_post_process": int(totals.get("after_post_process", 0)),
                "dropped_by_balancing": dict(sorted(state["balancing"].items())),
                "final": int(totals.get("final", 0)),
            },
            "splits": {"hard": {p: len(hard[p]) for p in SPLIT_PARTS},
                       "random": {p: len(rand[p]) for p in SPLIT_PARTS}},
            "per_template": {t: {k: int(per_template[t].get(k, 0)) for k in _REPORT_KEYS}
                             for t in templates() if t in per_template},
        }
        _write_json(report, root / "generation_report.json", indent=2, sort_keys=True)
        counts = {"random": {p: len(rand[p]) for p in SPLIT_PARTS}, "hard": {p: len(hard[p]) for p in SPLIT_PARTS}}
        hf = finish_streamed(root, counts)
        shutil.rmtree(self.work, ignore_errors=True)
        return dict(report, hf_parquet=hf.parquet)

    def _write_random_rows(self, part_of: dict[int, str]) -> None:
        """Distribute the final rows (in order) to ``hf/random/<part>.jsonl``."""
        folder = self.root / "hf" / "random"
        folder.mkdir(parents=True, exist_ok=True)
        with ExitStack() as stack:
            handles = {part: stack.enter_context(stack.enter_context(atomic_path(folder / f"{part}.jsonl"))
                                                 .open("w", encoding="utf-8")) for part in SPLIT_PARTS}
            with self._partial("rows").open(encoding="utf-8") as fh:
                for line in fh:
                    video = json.loads(line[:line.index(",")] + "}")["video_index"]
                    handles[part_of[video]].write(line)


__all__ = ["STATE_FORMAT", "WORK_FOLDER", "Merger", "blocks_of", "intermediate_path", "load_state", "new_state",
           "qa_path", "shard_path"]
