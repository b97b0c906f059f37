"""Endless fresh CRAFT questions: a PyTorch ``IterableDataset`` and a Hugging Face iterable, generated on the fly.

Stream index ``i`` is video instance ``i`` of ``craft-dsl generate --seed SEED``: the same task
(:func:`craft_dsl.dataset.pipeline.instance_task`) run by the same worker code
(:func:`craft_dsl.dataset.instance.run_instance`), so the same simulation, questions, perturbation filter and
post-process, and the same rows as the dataset's Hugging Face files. What a stream cannot do is the dataset-level
work: there is no answer balancing across videos and no train/validation/test split. Each video yields every
question that survives its own filters (the perturbation filter and the post-process), about 30 per video with the
defaults, with the answer distribution that gives (``craft-dsl generate --no-balance`` has the same).

Indices are dealt out to data-loader workers and ranks without overlap: with ``W`` workers on each of ``R`` ranks,
worker ``w`` of rank ``r`` takes ``i = start + (r * W + w) + k * R * W`` for ``k = 0, 1, ...``. Every sample
depends on nothing but the settings and its index. See ``docs/train.md``.
"""

from __future__ import annotations

import hashlib
import json
import os
import zlib
from collections.abc import Iterator, Sequence
from itertools import count
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch
from torch.utils.data import IterableDataset, get_worker_info

from ..atomic import atomic_path
from ..dataset.instance import InstanceTask, decode_shard, instance_seeds, run_instance
from ..dataset.layout import media_complete, resolve
from ..dataset.pipeline import GenerationConfig, instance_task, work_list
from ..errors import CraftError, MissingExtraError
from ..parallel import usable_cpu_count
from ..vocabulary import COLORS, ORIGINAL_ENGINE, SHAPES
from .dataset import FRAME_MODES, PAD, UNK, _answer_key
from .video import Size

StreamFrameMode = Literal["video", "first", "last", "first_last", "none", "file"]
#: Frame modes of :class:`CraftStream`: those of :class:`~craft_dsl.torch.CraftVideoQA`, and ``file`` (the
#: encoded video written to ``cache_dir``, its path in ``video_path``).
STREAM_FRAME_MODES: tuple[str, ...] = (*FRAME_MODES, "file")
#: Frame modes of :func:`hf_stream` (rows hold no arrays).
HF_FRAME_MODES: tuple[str, ...] = ("none", "file")
#: Settings of :class:`~craft_dsl.dataset.pipeline.GenerationConfig` that mean nothing in a stream.
_NOT_STREAM_SETTINGS = ("size", "workers", "videos", "downsampled", "balance")


def stream_answers() -> tuple[str, ...]:
    """The default answer vocabulary: counts 0-10, then the words (colours, shapes, True, False) alphabetically,
    written as the dataset writes answers (``"3"``, ``"True"``, ``"Red"``)."""
    words = [*(c.capitalize() for c in COLORS), *(s.capitalize() for s in SHAPES), "True", "False"]
    return tuple(sorted([*(str(n) for n in range(11)), *words], key=_answer_key))


def stream_tokens() -> tuple[str, ...]:
    """The default program token vocabulary: ``<pad>``, ``<unk>``, then every token a program can contain
    (:func:`craft_dsl.tokens.program_vocabulary`), so that indices do not depend on the samples seen."""
    from ..tokens import program_vocabulary

    return tuple(dict.fromkeys([PAD, UNK, *program_vocabulary()]))


def _shard_rows(shard: bytes) -> list[dict[str, Any]]:
    """The Hugging Face rows a worker's shard holds (:func:`~craft_dsl.dataset.instance.decode_shard`)."""
    try:
        rows = decode_shard(shard).rows
    except (ValueError, zlib.error) as err:
        raise CraftError(f"internal error: a worker returned a malformed shard ({err})") from None
    return [json.loads(row) for row in rows]


def _distributed(rank: int | None, world_size: int | None) -> tuple[int, int]:
    """``(rank, world_size)``: the given ones, else torch.distributed's where it is initialised, else (0, 1)."""
    if rank is None or world_size is None:
        dist = torch.distributed
        if dist.is_available() and dist.is_initialized():
            rank = dist.get_rank() if rank is None else rank
            world_size = dist.get_world_size() if world_size is None else world_size
    rank = 0 if rank is None else rank
    world_size = 1 if world_size is None else world_size
    if world_size < 1 or not 0 <= rank < world_size:
        raise CraftError(f"rank must be in 0..world_size-1, got rank {rank} of world_size {world_size}")
    return rank, world_size


def _media_thread() -> bool:
    """Render the media in a thread beside the physics only where a core is spare (as ``generate`` does)."""
    info = get_worker_info()
    return usable_cpu_count() > (info.num_workers if info is not None else 1)


class CraftStream(IterableDataset[dict[str, Any]]):
    """Questions of freshly generated videos, without end (or the first ``videos`` of them).

    Args:
        seed: the generation seed: stream index ``i`` is instance ``i`` of ``craft-dsl generate --seed SEED``.
        videos: ``None`` (endless) or a number of videos: then the stream is the videos of ``generate --size
            VIDEOS``, with its scenes (scene blocks); endless, video ``i`` shows ``scenes[i % len(scenes)]``.
        start: the first index (e.g. where an earlier run stopped).
        frames: as :class:`~craft_dsl.torch.CraftVideoQA` (``video``, ``first``, ``last``, ``first_last``,
            ``none``), rendered in memory (no encoding), or ``file``: the encoded video and its first/last frame
            PNGs written to ``cache_dir`` (bytes as ``generate --videos`` writes them), the path in ``video_path``.
        fps: frame rate of ``video`` frames (at most 60; ``None`` keeps all 600); ``size``: frame side in pixels
            (an int or a square (height, width); ``None``: 256), drawn at that size.
        cache_dir: the folder of ``file`` mode (one sub-folder per generation settings).
        answers, tokens: answer and program token vocabularies (defaults: :func:`stream_answers`,
            :func:`stream_tokens`; an answer outside ``answers`` gets ``answer_index`` -1, a token outside
            ``tokens`` the index of ``<unk>``).
        token_order: ``prefix`` or ``postfix`` program tokens.
        rank, world_size: this process's share of the indices (default: torch.distributed's when it is
            initialised at construction, else 0 of 1).
        settings: any other :class:`~craft_dsl.dataset.pipeline.GenerationConfig` setting (``scenes``, ``steps``,
            ``perturbations``, ``amount``, ``engine``, ``templates``, ``video_format``, ...).

    A sample has the keys of :class:`~craft_dsl.torch.CraftVideoQA` (so :func:`~craft_dsl.torch.collate` batches
    it): ``frames`` (uint8 [T, 3, H, W]; T = 0 for ``none`` and ``file``), ``question``, ``answer``,
    ``answer_index``, ``answer_type``, ``program_tokens``, ``program_ids``, ``template_id``, ``category`` (the
    paper's), ``question_type``, ``video_index`` (the stream index), ``question_index``; and ``program`` (DSL
    text), ``family``, ``scene``, ``video_path`` (``file`` mode, else ""). The questions of one video share one
    ``frames`` tensor. No balancing across videos (see the module docstring).
    """

    def __init__(self, seed: int = 0, *, videos: int | None = None, start: int = 0,
                 frames: StreamFrameMode = "video", fps: float | None = None, size: Size = None,
                 cache_dir: str | os.PathLike[str] | None = None, answers: Sequence[str] | None = None,
                 tokens: Sequence[str] | None = None, token_order: Literal["prefix", "postfix"] = "prefix",
                 rank: int | None = None, world_size: int | None = None, **settings: Any) -> None:
        super().__init__()
        bad = sorted(set(settings) & set(_NOT_STREAM_SETTINGS))
        if bad:
            raise CraftError(f"{', '.join(bad)}: not a stream setting (a stream has no size but `videos`, no "
                             "balancing, and renders what `frames` asks)")
        if frames not in STREAM_FRAME_MODES:
            raise CraftError(f"unknown frames mode {frames!r}; allowed: {', '.join(STREAM_FRAME_MODES)}")
        if fps is not None and not 0 < fps <= 60:
            raise CraftError(f"fps must be in (0, 60], got {fps}")
        if videos is not None and videos < 1:
            raise CraftError(f"videos must be at least 1 (or None: endless), got {videos}")
        if start < 0:
            raise CraftError(f"start must be >= 0, got {start}")
        if frames == "file" and cache_dir is None:
            raise CraftError("frames='file' writes the videos to cache_dir: give one")
        if token_order not in ("prefix", "postfix"):
            raise CraftError(f"unknown token order {token_order!r}; allowed: prefix, postfix")
        self.config = GenerationConfig.make(size=videos or 1, seed=seed, **settings)
        if self.config.engine == ORIGINAL_ENGINE and frames not in ("none", "file"):
            raise CraftError("the original simulator draws its own videos: use frames='file' or 'none' with it")
        self.videos = videos
        self.start = start
        self.frames_mode = frames
        self.fps = fps
        self.size = self._side(size)
        self.cache_dir = Path(cache_dir) if cache_dir is not None else None
        self.answers: tuple[str, ...] = tuple(answers) if answers is not None else stream_answers()
        self.tokens: tuple[str, ...] = tuple(tokens) if tokens is not None else stream_tokens()
        self.token_order = token_order
        self.rank, self.world_size = _distributed(rank, world_size)
        self._answer_index = {a: i for i, a in enumerate(self.answers)}
        self._token_index = {t: i for i, t in enumerate(self.tokens)}
        self._scenes = dict(work_list(self.config)) if videos is not None else None

    @staticmethod
    def _side(size: Size) -> int:
        if size is None:
            return 256
        h, w = (size, size) if isinstance(size, int) else size
        if h != w or h < 8:
            raise CraftError(f"frames are drawn square, at least 8 pixels: size {size!r} is not")
        return int(h)

    # -- indices ------------------------------------------------------------------------------------------------

    @property
    def stop(self) -> int | None:
        """One past the last index (``None``: endless)."""
        return self.videos

    def scene_of(self, index: int) -> int:
        """The scene id of video ``index``."""
        if self._scenes is not None:
            return self._scenes[index]
        ids = self.config.scene_ids
        return ids[index % len(ids)]

    def indices(self, parts: Sequence[int], total: int) -> Iterator[int]:
        """The video indices of ``parts`` (each in 0..total-1) when the stream is dealt into ``total`` parts:
        ``start + p + k * total``, in increasing order."""
        owned = sorted(set(parts))
        if any(not 0 <= p < total for p in owned):
            raise CraftError(f"parts must be in 0..{total - 1}, got {owned}")
        for k in count():
            for p in owned:
                i = self.start + p + k * total
                if self.stop is not None and i >= self.stop:
                    return
                yield i

    def shard(self) -> tuple[int, int]:
        """This iterator's part and the number of parts: rank and data-loader worker together."""
        info = get_worker_info()
        worker, workers = (info.id, info.num_workers) if info is not None else (0, 1)
        return self.rank * workers + worker, self.world_size * workers

    # -- one video ------------------------------------------------------------------------------------------------

    def task(self, index: int, media: bool = False) -> InstanceTask:
        """The worker task of video ``index``, as ``generate`` makes it."""
        return instance_task(self.config, index, self.scene_of(index), questions=True, media=media,
                             media_thread=_media_thread())

    def media_root(self) -> Path:
        """The cache sub-folder of these settings (``file`` mode): named by a hash of what decides the media."""
        if self.cache_dir is None:
            raise CraftError("no cache_dir")
        recorded = {k: v for k, v in self.config.recorded().items() if k not in ("size", "videos", "downsampled")}
        key = hashlib.sha256(json.dumps(recorded, sort_keys=True).encode()).hexdigest()[:16]
        return self.cache_dir / f"craft-stream-{key}"

    def rows(self, index: int) -> list[dict[str, Any]]:
        """The questions of video ``index`` as the dataset's Hugging Face rows (paths relative to a dataset folder),
        plus ``scene`` and, in ``file`` mode, ``video`` (the video's path in the cache)."""
        scene = self.scene_of(index)
        media = False
        root = None
        if self.frames_mode == "file":
            root = self.media_root()
            media = not media_complete(root, scene, index, self.config.video_format, ())
        result = run_instance(self.task(index, media))
        if result.shard is None:  # pragma: no cover - a task with questions always has a shard
            raise CraftError(f"internal error: video {index} gave no shard")
        for rel, data in result.media:
            assert root is not None
            with atomic_path(resolve(root, rel)) as tmp:
                tmp.write_bytes(data)
        rows = _shard_rows(result.shard)
        for row in rows:
            row["scene"] = scene
            row["video"] = str(resolve(root, row["video_file_path"])) if root is not None else ""
        return rows

    def simulation(self, index: int) -> Any:
        """The factual simulation of video ``index`` (live physics again: a few milliseconds)."""
        from ..dataset.instance import start_world
        from ..physics import simulate
        from ..physics.live import get_engine

        task = self.task(index)
        sim_seed = instance_seeds(task.seed, index)[0]
        return simulate(start_world(task, sim_seed), seed=sim_seed, steps=task.steps, engine=get_engine(task.engine))

    def render(self, index: int) -> np.ndarray:
        """The frames of video ``index`` as :attr:`frames_mode` asks, uint8 [T, H, W, 3]."""
        if self.frames_mode in ("none", "file"):
            return np.zeros((0, 1, 1, 3), np.uint8)
        from ..render import frame, frame_steps, frames

        sim = self.simulation(index)
        if self.frames_mode == "video":
            return frames(sim, self.fps or 60, self.size)
        steps = frame_steps(sim.steps)  # the states of the first and last frame PNGs
        kinds = ("first", "last") if self.frames_mode == "first_last" else (self.frames_mode,)
        return np.stack([frame(sim, int(steps[0] if k == "first" else steps[-1]), self.size) for k in kinds])

    def video_samples(self, index: int) -> list[dict[str, Any]]:
        """The samples of video ``index`` (possibly none: a video whose questions all fail the filters)."""
        from ..program import Program

        rows = self.rows(index)
        if not rows:
            return []
        pixels = torch.from_numpy(self.render(index)).permute(0, 3, 1, 2)  # [T, 3, H, W], a view: no copy
        out = []
        for row in rows:
            tokens = list(Program.from_nodes(row["program_nodes"]).to_tokens(order=self.token_order))
            out.append({
                "frames": pixels,
                "question": row["question"],
                "answer": row["answer"],
                "answer_index": self._answer_index.get(row["answer"], -1),
                "answer_type": row["answer_type"],
                "program_tokens": tokens,
                "program_ids": torch.tensor([self._token_index.get(t, 1) for t in tokens], dtype=torch.long),
                "template_id": row["template_id"],
                "category": row["category"],
                "question_type": row["question_type"],
                "video_index": int(row["video_index"]),
                "question_index": int(row["question_index"]),
                "program": row["program"],
                "family": row["family"],
                "scene": int(row["scene"]),
                "video_path": row["video"],
            })
        return out

    # -- IterableDataset ------------------------------------------------------------------------------------------

    def __iter__(self) -> Iterator[dict[str, Any]]:
        part, total = self.shard()
        for index in self.indices([part], total):
            yield from self.video_samples(index)


# -- Hugging Face -------------------------------------------------------------------------------------------------


def _datasets() -> Any:
    try:
        import datasets
    except ImportError as err:
        if err.name and err.name.split(".")[0] != "datasets":
            raise
        raise MissingExtraError("craft_dsl.torch.hf_stream", "integration", "datasets") from None
    return datasets


def hf_features() -> Any:
    """The ``datasets.Features`` of :func:`hf_stream`'s rows: the dataset's Hugging Face columns, ``scene`` and
    ``video``."""
    datasets = _datasets()
    from ..dataset.hf import FEATURES

    value = datasets.Value
    fields: dict[str, Any] = {}
    for name, dtype in FEATURES:
        fields[name] = [{"type": value("string"), "inputs": [value("int64")], "value_inputs": [value("string")]}] \
            if dtype == "nodes" else value(dtype)
    fields["scene"] = value("int64")
    fields["video"] = value("string")
    return datasets.Features(fields)


def _hf_rows(shards: list[int], stream: CraftStream, n_shards: int) -> Iterator[dict[str, Any]]:
    """The generator of :func:`hf_stream`: the indices of this rank's ``shards`` (a data-loader worker gets some
    of them from ``datasets``), each video's rows in turn."""
    total = stream.world_size * n_shards
    for index in stream.indices([stream.rank * n_shards + s for s in shards], total):
        yield from stream.rows(index)


def hf_stream(seed: int = 0, *, videos: int | None = None, start: int = 0, frames: str = "none",
              cache_dir: str | os.PathLike[str] | None = None, shards: int = 64, rank: int | None = None,
              world_size: int | None = None, **settings: Any) -> Any:
    """The stream as a ``datasets.IterableDataset`` (the ``integration`` extra) of rows: the columns of the
    dataset's Hugging Face files, ``scene``, and ``video`` (``frames="file"``: the video's path in
    ``cache_dir``; ``"none"``: empty). Rows hold no pixels: read them from ``video``, or use :class:`CraftStream`.

    ``shards`` parts per rank, dealt to data-loader workers by ``datasets`` (give at least as many as workers);
    ``rank``/``world_size`` as :class:`CraftStream` (use them rather than ``split_dataset_by_node``). Same
    indices, rows and order of questions as :class:`CraftStream` with the same arguments.
    """
    datasets = _datasets()
    if frames not in HF_FRAME_MODES:
        raise CraftError(f"frames mode {frames!r} is not for Hugging Face rows; allowed: {', '.join(HF_FRAME_MODES)}"
                         " (pixels: CraftStream)")
    if shards < 1:
        raise CraftError(f"shards must be at least 1, got {shards}")
    stream = CraftStream(seed, videos=videos, start=start, frames=frames, cache_dir=cache_dir,  # type: ignore[arg-type]
                         rank=rank, world_size=world_size, **settings)
    return datasets.IterableDataset.from_generator(
        _hf_rows, features=hf_features(),
        gen_kwargs={"shards": list(range(shards)), "stream": stream, "n_shards": shards})


__all__ = ["HF_FRAME_MODES", "STREAM_FRAME_MODES", "CraftStream", "hf_features", "hf_stream",
           "stream_answers", "stream_tokens"]
