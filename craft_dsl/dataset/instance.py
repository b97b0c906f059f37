"""One video of the generation pipeline, computed wherever a worker runs it.

:func:`run_instance` simulates the video, computes its clean counterfactual variations, generates its questions,
runs the perturbation filter and the per-video post-process, and serialises everything the dataset files will
need into one *shard* (bytes). It writes nothing: the result (the shard and, with ``media``, the video and frame
files as bytes) goes back to the main process, which writes it. So any executor works (local processes, a Dask
cluster without a shared file system), a killed worker leaves nothing behind, and a video is done exactly when
its shard is on disk.

A shard holds, for the dataset-level merge (:mod:`craft_dsl.dataset.merge`), no JSON to parse again:

* a small JSON *header*: instance, scene, the statistics of the generation report, and per post-processed
  question its index, template and answer label (all balancing needs);
* a zlib-compressed *body*: the simulation with variations as ``annotations.json`` holds it, and per
  post-processed question its ``dataset.json`` record, its ``dataset_minimal.json`` record and its Hugging Face
  row, each already serialised exactly as the files hold them.

The video is rendered and encoded (PyAV, in this process) as soon as the factual run exists: in a background
thread that overlaps the counterfactual and perturbed simulations where the machine has a core to spare, at once
where every core has a worker (:attr:`InstanceTask.media_thread`).
"""

from __future__ import annotations

import json
import struct
import tempfile
import threading
import time
import zlib
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CraftError
from ..vocabulary import ORIGINAL_ENGINE
from ..world import WorldSpec
from .layout import DEFAULT_VIDEO_FORMAT
from .samplers import DEFAULT_SAMPLER, ORIGINAL_SAMPLER, start_state
from .stages import answer_label, post_process, template_id_of, video_path

#: First bytes of a shard file; the number is the shard format (bumped with the dataset format).
SHARD_MAGIC = b"CRAFTSHARD2\n"
_LENGTHS = struct.Struct("<QQ")


# -- seeds --------------------------------------------------------------------------------------------------


def instance_seeds(seed: int, instance_id: int) -> tuple[int, np.random.SeedSequence, np.random.SeedSequence]:
    """(simulation seed, question seed sequence, perturbation seed sequence) of one instance.

    Children of ``SeedSequence([seed, instance_id])``: they depend on nothing but the configuration seed and the
    instance id, so results do not depend on processing order, the executor or the number of workers.
    """
    sim_ss, question_ss, perturb_ss = np.random.SeedSequence([seed, instance_id]).spawn(3)
    return int(sim_ss.generate_state(1, dtype=np.uint32)[0]), question_ss, perturb_ss


# -- tasks and results --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class InstanceTask:
    """Everything a worker needs for one video (picklable, no paths: workers write nothing nor read the user's
    files). ``layout``: the canonical JSON of a custom scene layout (empty for a built-in scene)."""

    instance_id: int
    scene: int
    seed: int
    steps: int
    perturbations: int
    amount: float
    engine: str
    templates: tuple[str, ...]
    video_format: str = DEFAULT_VIDEO_FORMAT
    questions: bool = True
    media: bool = False
    downsampled: tuple[int, ...] = ()
    layout: str = ""
    #: Who draws the start state (:mod:`craft_dsl.dataset.samplers`).
    sampler: str = DEFAULT_SAMPLER
    #: Render and encode the media in a thread beside the questions' physics (rendering and encoding release
    #: the GIL for much of their time): faster where a core is spare, slower where every core has a worker
    #: (measured: 1 worker on 2 cores 38.0 s against 45.7 s inline; 2 workers 50.6 s against 47.4 s). The
    #: bytes are the same either way.
    media_thread: bool = True


@dataclass(frozen=True)
class InstanceResult:
    """What a worker sends back: the shard (``None`` for a media-only task) and media files as
    (path relative to the output folder, bytes)."""

    instance_id: int
    shard: bytes | None
    media: tuple[tuple[str, bytes], ...] = ()


# -- timing (for benchmarks/generate_speed.py) ----------------------------------------------------------------


@dataclass
class StageClock:
    """Seconds per stage of :func:`run_instance`; physics runs inside a stage are also counted apart, as
    ``"<stage>: runs"`` (a whole scene) and ``"<stage>: variations"`` (a counterfactual re-run)."""

    seconds: dict[str, float] = field(default_factory=lambda: defaultdict(float))
    #: Number of physics runs per ``"<stage>: runs"`` / ``"<stage>: variations"`` key.
    runs: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    #: Frames simulated (a counterfactual re-run starts at its first activated frame).
    frames: int = 0
    current: str = ""

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        previous, self.current = self.current, name
        start = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] += time.perf_counter() - start
            self.current = previous


class _TimedEngine:
    """A physics engine that reports the time of each run to a :class:`StageClock`."""

    def __init__(self, engine: Any, clock: StageClock) -> None:
        self._engine = engine
        self._clock = clock
        self.name = engine.name

    def run(self, world: Any, steps: int, replay: Any = None) -> Any:
        start = time.perf_counter()
        try:
            return self._engine.run(world, steps, replay)
        finally:
            key = f"{self._clock.current}: {'variations' if replay is not None else 'runs'}"
            self._clock.seconds[key] += time.perf_counter() - start
            self._clock.runs[key] += 1
            self._clock.frames += steps - (replay.first_frame if replay is not None else 0)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._engine, name)


@contextmanager
def _no_stage(name: str) -> Iterator[None]:
    yield


# -- media ----------------------------------------------------------------------------------------------------


class _MediaJob:
    """Render and encode one video's media files, in a background thread or at once
    (:attr:`InstanceTask.media_thread`); :meth:`result` waits for them."""

    def __init__(self, sim: Any, task: InstanceTask) -> None:
        self._files: tuple[tuple[str, bytes], ...] = ()
        self._error: BaseException | None = None
        self._thread: threading.Thread | None = None
        if task.media_thread:
            self._thread = threading.Thread(target=self._run, args=(sim, task), daemon=True)
            self._thread.start()
        else:
            self._run(sim, task)

    def _run(self, sim: Any, task: InstanceTask) -> None:
        try:
            self._files = render_media(sim, task)
        except BaseException as err:  # noqa: BLE001 - re-raised in the worker's thread by result()
            self._error = err

    def result(self) -> tuple[tuple[str, bytes], ...]:
        if self._thread is not None:
            self._thread.join()
        if self._error is not None:
            raise self._error
        return self._files


def render_media(sim: Any, task: InstanceTask) -> tuple[tuple[str, bytes], ...]:
    """The video's media files of the published layout as (relative path, bytes), encoded in a private
    temporary folder (:func:`craft_dsl.dataset.layout.write_media`)."""
    from .layout import write_media

    with tempfile.TemporaryDirectory(prefix="craft-media-") as tmp:
        root = Path(tmp)
        paths = write_media(sim, root, task.scene, task.instance_id, task.video_format, task.downsampled)
        return tuple((p.relative_to(root).as_posix(), p.read_bytes()) for p in paths)


# -- the instance -----------------------------------------------------------------------------------------------


def run_instance(task: InstanceTask, clock: StageClock | None = None) -> InstanceResult:
    """Compute one video (see the module docstring). Deterministic: the same task gives the same bytes."""
    from ..physics import simulate
    from ..physics.live import get_engine
    from . import questions as part_a

    stage = clock.stage if clock is not None else _no_stage
    engine: Any = task.engine if task.engine == ORIGINAL_ENGINE else get_engine(task.engine)
    if clock is not None and engine != ORIGINAL_ENGINE:
        engine = _TimedEngine(engine, clock)
    vpath = video_path(task.scene, task.instance_id, task.video_format)
    sim_seed, question_ss, perturb_ss = instance_seeds(task.seed, task.instance_id)
    with stage("factual simulation"):
        if task.sampler == ORIGINAL_SAMPLER and task.engine == ORIGINAL_ENGINE:  # as the original pipeline
            from ..physics.original_sampler import simulate_fresh

            sim = simulate_fresh(task.scene, sim_seed, task.steps, meta={"scene": task.scene, "seed": sim_seed})
        else:
            sim = simulate(start_world(task, sim_seed), seed=sim_seed, steps=task.steps, engine=engine)
        sim.meta["video_filename"] = vpath
    media = _MediaJob(sim, task) if task.media else None
    shard = None
    if task.questions:
        with stage("counterfactual variations"):
            for obj in sim.objects:
                if obj.dynamic:
                    sim.counterfactual(obj.id)
        with stage("question search"):
            generated = part_a.generate_questions(
                sim, np.random.default_rng(question_ss), video_index=task.instance_id, video_filename=vpath,
                template_ids=list(task.templates), instances_per_template=1,
            )
        with stage("perturbation filter"):
            if task.perturbations > 0:
                kept, pstats = part_a.perturbation_filter(sim, generated, np.random.default_rng(perturb_ss),
                                                          perturbations=task.perturbations, amount=task.amount)
            else:
                kept, pstats = list(generated), {}
        with stage("serialisation"):
            shard = _shard(task, sim, sim_seed, vpath, generated, kept, pstats)
    with stage("media (waiting for the encoder)"):
        files = media.result() if media is not None else ()
    return InstanceResult(task.instance_id, shard, files)


def start_world(task: InstanceTask, sim_seed: int) -> WorldSpec:
    """The start state to simulate: drawn by the task's sampler from its scene (a custom scene's layout where the
    task carries one)."""
    from ..scenes import layout_from_data

    layout = None
    if task.layout:
        layout = layout_from_data(json.loads(task.layout), f"custom scene {task.scene}")
        if layout.scene != task.scene:
            raise CraftError(f"internal error: task of scene {task.scene} carries the layout of scene "
                             f"{layout.scene}")
    return start_state(task.scene, sim_seed, task.sampler, layout)


def _shard(task: InstanceTask, sim: Any, sim_seed: int, vpath: str, generated: list[dict[str, Any]],
           kept: list[dict[str, Any]], pstats: dict[str, int]) -> bytes:
    from ..recorded import simulation_dict
    from ..verify.categories import category_of, family_of
    from ..verify.records import minimal_records, video_record
    from .hf import row, row_text

    kept_keys = {q["question_index"] for q in kept}
    dynamic_shapes = sorted({o.shape for o in sim.objects if o.dynamic})
    processed, pp_dropped = post_process(kept, {task.instance_id: len(dynamic_shapes)})
    video = video_record(task.scene, vpath, task.instance_id, processed)
    minimal = minimal_records([video])
    records, minimals, rows = [], [], []
    for rec, mini in zip(processed, minimal, strict=True):
        records.append(json.dumps(rec))
        minimals.append(json.dumps(mini))
        folder_rec = dict(mini, category=category_of(mini["template_id"]), family=family_of(mini["template_id"]))
        rows.append(row_text(row(folder_rec, rec["program"], vpath)))
    stats = {
        "scene": task.scene,
        "simulation_seed": sim_seed,
        "dynamic_shapes": dynamic_shapes,
        "generated": [template_id_of(q) for q in generated],
        "dropped_by_perturbation": [template_id_of(q) for q in generated if q["question_index"] not in kept_keys],
        "perturbation": {str(k): int(v) for k, v in pstats.items()},
    }
    header = {
        "instance": task.instance_id, "scene": task.scene, "stats": stats,
        "after_perturbation": len(kept), "dropped_by_post_process": dict(sorted(pp_dropped.items())),
        "questions": [[int(r["question_index"]), template_id_of(r), answer_label(r["answer"])] for r in processed],
    }
    texts = [json.dumps(simulation_dict(sim)), *records, *minimals, *rows]
    blobs = [t.encode("utf-8") for t in texts]
    header["sizes"] = [len(b) for b in blobs]
    return encode_shard(header, b"".join(blobs))


# -- shard files --------------------------------------------------------------------------------------------------


def encode_shard(header: dict[str, Any], body: bytes) -> bytes:
    """Magic, the two lengths, the JSON header, the zlib-compressed body."""
    head = json.dumps(header, separators=(",", ":")).encode("utf-8")
    packed = zlib.compress(body, 1)
    return SHARD_MAGIC + _LENGTHS.pack(len(head), len(packed)) + head + packed


def shard_is_complete(path: Path) -> bool:
    """True if ``path`` is a whole shard of this format (its lengths match its size)."""
    try:
        with path.open("rb") as fh:
            start = fh.read(len(SHARD_MAGIC) + _LENGTHS.size)
        size = path.stat().st_size
    except OSError:
        return False
    if len(start) < len(SHARD_MAGIC) + _LENGTHS.size or not start.startswith(SHARD_MAGIC):
        return False
    head, body = _LENGTHS.unpack_from(start, len(SHARD_MAGIC))
    return size == len(SHARD_MAGIC) + _LENGTHS.size + head + body


@dataclass(frozen=True)
class Shard:
    """A decoded shard: the header and, when read with the body, the serialised texts."""

    header: dict[str, Any]
    annotation: str = ""
    records: tuple[str, ...] = ()
    minimal: tuple[str, ...] = ()
    rows: tuple[str, ...] = ()


def _texts(header: dict[str, Any], data: bytes) -> Shard:
    """The shard of ``header`` and its decompressed body ``data``."""
    texts, at = [], 0
    for size in header["sizes"]:
        texts.append(data[at:at + size].decode("utf-8"))
        at += size
    n = len(header["questions"])
    return Shard(header, texts[0], tuple(texts[1:1 + n]), tuple(texts[1 + n:1 + 2 * n]), tuple(texts[1 + 2 * n:]))


def decode_shard(shard: bytes) -> Shard:
    """A shard as a worker returns it (:attr:`InstanceResult.shard`), decoded; a malformed one raises ValueError
    or ``zlib.error``."""
    if not shard.startswith(SHARD_MAGIC) or len(shard) < len(SHARD_MAGIC) + _LENGTHS.size:
        raise ValueError("not a shard of this format")
    head_len, body_len = _LENGTHS.unpack_from(shard, len(SHARD_MAGIC))
    at = len(SHARD_MAGIC) + _LENGTHS.size
    header = json.loads(shard[at:at + head_len])
    return _texts(header, zlib.decompress(shard[at + head_len:at + head_len + body_len]))


def read_shard(path: Path, body: bool = True) -> Shard:
    """Read a shard file (the body too unless ``body=False``); a damaged file is a :class:`CraftError`."""
    try:
        with path.open("rb") as fh:
            start = fh.read(len(SHARD_MAGIC) + _LENGTHS.size)
            if not start.startswith(SHARD_MAGIC) or len(start) < len(SHARD_MAGIC) + _LENGTHS.size:
                raise ValueError("not a shard of this format")
            head_len, body_len = _LENGTHS.unpack_from(start, len(SHARD_MAGIC))
            header = json.loads(fh.read(head_len))
            if not body:
                return Shard(header)
            data = zlib.decompress(fh.read(body_len))
    except (OSError, ValueError, zlib.error) as err:
        raise CraftError(f"{path}: damaged work file ({err}); delete it and re-run to recompute the video") from None
    return _texts(header, data)


__all__ = ["InstanceResult", "InstanceTask", "Shard", "StageClock", "decode_shard", "encode_shard", "instance_seeds",
           "read_shard", "render_media", "run_instance", "shard_is_complete"]
