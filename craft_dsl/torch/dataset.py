"""A PyTorch ``Dataset`` over a CRAFT-format dataset folder, and a collate function for its batches."""

from __future__ import annotations

import os
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
import torch
from torch.utils.data import Dataset

from ..dataset.folder import PARTS, SPLITS, DatasetFolder
from ..errors import CraftError
from .video import Size, decode_image, decode_video

FrameMode = Literal["video", "first", "last", "first_last", "none"]
FRAME_MODES: tuple[str, ...] = ("video", "first", "last", "first_last", "none")
PAD = "<pad>"
UNK = "<unk>"


def _answer_key(answer: str) -> tuple[int, int, str]:
    if answer.isdigit():
        return (0, int(answer), "")
    return (1, 0, answer)


class CraftVideoQA(Dataset[dict[str, Any]]):
    """Questions of one part of a split, each with its video frames, answer and program tokens.

    Args:
        root: the dataset folder (``craft-dsl generate --videos`` output, or the published CRAFT dataset).
        part: ``train``, ``validation``, ``test``, or ``all``.
        split: ``random`` (the paper's easy split) or ``hard``.
        frames: ``video`` (the decoded video), ``first`` / ``last`` (the frame PNGs), ``first_last`` (both) or
            ``none``.
        fps: frame rate of ``video`` frames (at most 60; ``None`` keeps all); ``size``: an int or (height, width)
            to resize frames to (``None`` keeps 256 x 256).
        answers: the answer vocabulary (default: every answer of the whole dataset, counts in numeric order,
            then words alphabetically), so that indices agree across parts.
        token_order: ``prefix`` or ``postfix`` program tokens (:meth:`craft_dsl.Program.to_tokens`).
        cache_videos: decoded videos kept in memory (questions of one video share them).

    An item is a dict: ``frames`` (uint8 tensor [T, 3, H, W]; T = 0 for ``none``), ``question``, ``answer``,
    ``answer_index``, ``answer_type``, ``program_tokens`` (list of str), ``program_ids`` (long tensor, indices
    in :attr:`tokens`), ``template_id``, ``category``, ``question_type``, ``video_index``, ``question_index``.
    """

    def __init__(self, root: str | os.PathLike[str], part: str = "train", split: str = "random",
                 frames: FrameMode = "video", fps: float | None = None, size: Size = None,
                 answers: Sequence[str] | None = None, token_order: Literal["prefix", "postfix"] = "prefix",
                 cache_videos: int = 8) -> None:
        if part not in (*PARTS, "all"):
            raise CraftError(f"unknown part {part!r}; allowed: {', '.join(PARTS)}, all")
        if split not in SPLITS:
            raise CraftError(f"unknown split {split!r}; allowed: {', '.join(SPLITS)}")
        if frames not in FRAME_MODES:
            raise CraftError(f"unknown frames mode {frames!r}; allowed: {', '.join(FRAME_MODES)}")
        if fps is not None and not 0 < fps <= 60:
            raise CraftError(f"fps must be in (0, 60], got {fps}")
        self.folder = DatasetFolder(root)
        self.frames_mode = frames
        self.fps = fps
        self.size = size
        self.token_order = token_order
        part_of = self.folder.part_of(split)
        records = self.folder.records
        self.records = [r for r in records
                        if part == "all" or part_of.get((int(r["video_index"]), int(r["question_index"]))) == part]
        self.answers: tuple[str, ...] = tuple(answers) if answers is not None else tuple(
            sorted({str(r["answer"]) for r in records}, key=_answer_key))
        self._answer_index = {a: i for i, a in enumerate(self.answers)}
        programs = self.folder.programs
        self._tokens = [self._program_tokens(programs.get((int(r["video_index"]), int(r["question_index"])), []))
                        for r in self.records]
        vocabulary = sorted({t for seq in self._program_tokens_all(programs) for t in seq})
        #: Program token vocabulary: index 0 is padding, 1 unknown, then every token of the dataset, sorted.
        self.tokens: tuple[str, ...] = (PAD, UNK, *vocabulary)
        self._token_index = {t: i for i, t in enumerate(self.tokens)}
        self._cache: OrderedDict[str, np.ndarray] = OrderedDict()
        self._cache_size = cache_videos

    # -- programs -------------------------------------------------------------------------------------------

    def _program_tokens(self, nodes: Sequence[Mapping[str, Any]]) -> list[str]:
        if not nodes:
            return []
        from ..program import Program

        return list(Program.from_nodes(nodes).to_tokens(order=self.token_order))

    def _program_tokens_all(self, programs: Mapping[tuple[int, int], Sequence[Mapping[str, Any]]]
                            ) -> list[list[str]]:
        mine = {(int(r["video_index"]), int(r["question_index"])) for r in self.records}
        return self._tokens + [self._program_tokens(nodes) for key, nodes in sorted(programs.items())
                               if key not in mine]

    # -- frames ---------------------------------------------------------------------------------------------

    def _video(self, record: Mapping[str, Any]) -> np.ndarray:
        path = self.folder.video_file(record)
        key = str(path)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        frames = decode_video(path, self.fps, self.size)
        self._cache[key] = frames
        if len(self._cache) > self._cache_size:
            self._cache.popitem(last=False)
        return frames

    def frames(self, record: Mapping[str, Any]) -> np.ndarray:
        """The frames of one record as uint8 [T, H, W, 3]."""
        if self.frames_mode == "video":
            return self._video(record)
        if self.frames_mode == "none":
            return np.zeros((0, 1, 1, 3), np.uint8)
        kinds = ("first", "last") if self.frames_mode == "first_last" else (self.frames_mode,)
        return np.stack([decode_image(self.folder.frame_file(record, k), self.size) for k in kinds])

    # -- Dataset --------------------------------------------------------------------------------------------

    def __len__(self) -> int:
        return len(self.records)

    def __getitem__(self, index: int) -> dict[str, Any]:
        record = self.records[index]
        answer = str(record["answer"])
        tokens = self._tokens[index]
        frames = torch.from_numpy(np.ascontiguousarray(self.frames(record).transpose(0, 3, 1, 2)))
        return {
            "frames": frames,
            "question": str(record.get("question", "")),
            "answer": answer,
            "answer_index": self._answer_index.get(answer, -1),
            "answer_type": str(record.get("answer_type", "")),
            "program_tokens": tokens,
            "program_ids": torch.tensor([self._token_index.get(t, 1) for t in tokens], dtype=torch.long),
            "template_id": record["template_id"],
            "category": record["category"],
            "question_type": record["question_type"],
            "video_index": int(record["video_index"]),
            "question_index": int(record["question_index"]),
        }


def collate(batch: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Batch items of :class:`CraftVideoQA` whose frame counts and program lengths differ.

    ``frames``: uint8 [B, T_max, 3, H, W], zero-padded at the end, with ``frame_mask`` (bool [B, T_max]) and
    ``frame_lengths``; ``program_ids``: long [B, L_max] padded with 0 (``<pad>``), with ``program_lengths``;
    ``answer_index``, ``video_index``, ``question_index``: long [B]; every text field a list of B values.
    """
    if not batch:
        raise CraftError("cannot collate an empty batch")
    shapes = {tuple(item["frames"].shape[1:]) for item in batch if item["frames"].shape[0]}
    if len(shapes) > 1:
        raise CraftError(f"frames of one batch must share their size, found {sorted(shapes)}; give the dataset a size")
    lengths = [int(item["frames"].shape[0]) for item in batch]
    t_max = max(lengths)
    c, h, w = shapes.pop() if shapes else tuple(batch[0]["frames"].shape[1:])
    frames = torch.zeros((len(batch), t_max, c, h, w), dtype=torch.uint8)
    mask = torch.zeros((len(batch), t_max), dtype=torch.bool)
    for i, item in enumerate(batch):
        frames[i, :lengths[i]] = item["frames"]
        mask[i, :lengths[i]] = True
    prog_lengths = [int(item["program_ids"].shape[0]) for item in batch]
    programs = torch.zeros((len(batch), max(prog_lengths)), dtype=torch.long)
    for i, item in enumerate(batch):
        programs[i, :prog_lengths[i]] = item["program_ids"]
    out: dict[str, Any] = {
        "frames": frames, "frame_mask": mask, "frame_lengths": torch.tensor(lengths, dtype=torch.long),
        "program_ids": programs, "program_lengths": torch.tensor(prog_lengths, dtype=torch.long),
    }
    for key in ("answer_index", "video_index", "question_index"):
        out[key] = torch.tensor([int(item[key]) for item in batch], dtype=torch.long)
    for key in ("question", "answer", "answer_type", "program_tokens", "template_id", "category", "question_type"):
        out[key] = [item[key] for item in batch]
    return out




__all__ = ["FRAME_MODES", "PAD", "UNK", "CraftVideoQA", "collate"]
