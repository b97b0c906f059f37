"""Dataset generation: configuration and the orchestrator.

:func:`generate_dataset` chains the stages:

1. :func:`work_list` — instance ids in scene blocks;
2. per video, in a worker (:func:`craft_dsl.dataset.instance.run_instance`, on an executor of
   :mod:`craft_dsl.dataset.executors`): simulate, clean counterfactual variations, questions (part A,
   :mod:`craft_dsl.dataset.questions`), perturbation filter, post-process, everything serialised into a shard;
   the main process writes the shard (and the media files) as results arrive;
3. per scene block, in a merge thread of the main process while the workers go on
   (:class:`craft_dsl.dataset.merge.Merger`): balancing (:func:`~craft_dsl.dataset.stages.balance`) and the
   block's part of every file, committed to a journal;
4. at the end: the splits, the report, the Hugging Face files and the dataset card.

Every random draw comes from ``numpy.random.SeedSequence`` children of the configuration seed, keyed by what they
decide (instance id; balancing group; split), never by processing order: the same configuration gives
byte-identical files whatever the executor and the number of workers. A run can be killed at any moment and
resumed by the same command. See ``docs/dataset.md``.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Literal, Protocol

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..atomic import atomic_path
from ..errors import CraftError
from ..scenes import list_scenes
from ..templates import templates
from ..vocabulary import DEFAULT_ENGINE
from .custom_scenes import CustomScene, builtin_id_clash, recorded_scenes_text, scene_entry
from .executors import Executor, LocalExecutor
from .folder import as_recorded, with_legacy_defaults
from .instance import InstanceResult, InstanceTask, instance_seeds, run_instance, shard_is_complete
from .layout import DEFAULT_VIDEO_FORMAT, VideoFormat, id6, media_complete, resolve
from .merge import WORK_FOLDER, Merger, load_state, new_state, shard_path
from .samplers import DEFAULT_SAMPLER, Sampler, check_sampler_scenes
from .stages import (
    HARD_SPLIT,
    SPLIT_PARTS,
    answer_label,
    balance,
    dataset_videos,
    hard_split,
    post_process,
    random_split,
    template_id_of,
    video_path,
)

#: Version of the generated folder's format: bumped whenever the output for a given seed and configuration
#: changes (docs/dataset.md, "Changelog of the output"); a folder of another version is refused.
FORMAT_VERSION = 3

#: Settings that decide the content of the files (``workers`` and the executor do not). ``videos`` and
#: ``downsampled`` decide only which media files exist; ``video_format`` is content, since every JSON file names
#: the videos.
CONTENT_FIELDS: tuple[str, ...] = ("size", "seed", "scenes", "steps", "perturbations", "amount", "engine",
                                   "sampler", "templates", "video_format", "balance")
MEDIA_FIELDS: tuple[str, ...] = ("videos", "downsampled")
#: What ``generation_config.json`` records.
RECORDED_FIELDS: tuple[str, ...] = ("format_version", *CONTENT_FIELDS, *MEDIA_FIELDS)
#: The run's log, in the output folder (the one file that holds times; never compared).
LOG_FILE = "generation.log"

class GenerationConfig(BaseModel):
    """What to generate. ``size`` videos spread over ``scenes`` in blocks (see :func:`work_list`).

    ``scenes`` holds built-in scene ids and custom layouts: a layout file (str or Path) or a
    :class:`~craft_dsl.scenes.SceneLayout` given here is read once and held as a :class:`CustomScene` (its
    canonical JSON; see :mod:`craft_dsl.dataset.custom_scenes`).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    size: int = Field(ge=1, description="number of videos (simulations) to generate")
    seed: int = Field(0, ge=0, description="the one seed every random draw derives from")
    scenes: tuple[int | CustomScene, ...] = Field(
        tuple(range(1, 21)), description="built-in scene ids (1-20) and custom layouts (files, held as CustomScene)")
    steps: int = Field(600, ge=1, description="simulation steps per video (60 per second)")
    perturbations: int = Field(3, ge=0, description="perturbed re-simulations per video (0: no filter)")
    amount: float = Field(0.02, ge=0.0, le=0.5, description="perturbation noise amount")
    workers: int = Field(1, ge=1, description="local worker processes (the output does not depend on it)")
    videos: bool = Field(False, description="render each video with its first and last frames")
    video_format: VideoFormat = Field(DEFAULT_VIDEO_FORMAT, description="mpg (MPEG-1, as published) or mp4 (H.264)")
    downsampled: tuple[int, ...] = Field((), description="also write H.264 videos at these frame rates (with videos)")
    engine: Literal["pymunk", "box2d", "box2d128", "original"] = Field(
        DEFAULT_ENGINE, description="physics engine (box2d, the default; pymunk, the default of datasets made "
                                    "before; box2d128: Box2D with the original's 128-gon circles, built by "
                                    "tools/box2d128/build.sh; original: the original CRAFT simulator, which also "
                                    "draws the videos)")
    sampler: Sampler = Field(DEFAULT_SAMPLER, description="who draws the start states: layouts-2 (the layout "
                                                          "files, default), layouts-1 (their revision before, "
                                                          "the default of datasets made before), original (the "
                                                          "original simulator's own sampler)")
    templates: tuple[str, ...] = Field(tuple(templates()), description="template ids to instantiate")
    balance: bool = Field(True, description="answer balancing (off: keep every question that passed the filters)")

    @field_validator("scenes", mode="before")
    @classmethod
    def _read_layouts(cls, v: Any) -> Any:
        if isinstance(v, (str, Path)):
            v = (v,)
        return tuple(scene_entry(item) for item in v) if isinstance(v, (list, tuple)) else v

    @field_validator("scenes")
    @classmethod
    def _check_scenes(cls, v: tuple[int | CustomScene, ...]) -> tuple[int | CustomScene, ...]:
        if not v:
            raise ValueError("give at least one scene id or layout file")
        builtin = set(list_scenes())
        bad = [s for s in v if isinstance(s, int) and s not in builtin]
        if bad:
            raise ValueError(f"built-in scene ids are {min(builtin)}-{max(builtin)}, not {bad} (a custom layout is "
                             "given as its file)")
        for s in v:
            clash = builtin_id_clash(s) if isinstance(s, CustomScene) else None
            if clash:
                raise ValueError(clash)
        seen: dict[int, int | CustomScene] = {}
        for s in v:
            sid = s if isinstance(s, int) else s.scene
            if sid in seen:
                both = [x.describe() if isinstance(x, CustomScene) else f"built-in scene {x}" for x in (seen[sid], s)]
                raise ValueError(f"scene id {sid} appears twice ({both[0]}; {both[1]}): each scene of a dataset "
                                 "needs an id of its own (a layout's is its \"scene\" field)")
            seen[sid] = s
        return v

    @model_validator(mode="after")
    def _sampler_makes_scenes(self) -> GenerationConfig:
        problem = check_sampler_scenes(self.sampler, self.scenes)
        if problem:
            raise ValueError(problem)
        return self

    @field_validator("templates")
    @classmethod
    def _check_templates(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        known = templates()
        bad = [t for t in v if t not in known]
        if bad:
            raise ValueError(f"unknown template ids {bad} (known: descriptive_0-39, counterfactual_0-8, "
                             "cause/enable/prevent_0-5)")
        if not v:
            raise ValueError("give at least one template id")
        return tuple(t for t in known if t in set(v))  # canonical order

    @field_validator("downsampled")
    @classmethod
    def _check_downsampled(cls, v: tuple[int, ...]) -> tuple[int, ...]:
        bad = [f for f in v if not 1 <= f <= 60]
        if bad:
            raise ValueError(f"downsampled frame rates are 1-60 frames per second, not {bad}")
        return tuple(sorted(set(v)))

    @classmethod
    def make(cls, **kwargs: Any) -> GenerationConfig:
        """Validate, turning a pydantic error into a :class:`CraftError` naming the field."""
        try:
            return cls(**kwargs)
        except ValidationError as err:
            msgs = [f"{'.'.join(str(p) for p in e['loc']) or 'config'}: {e['msg'].removeprefix('Value error, ')}"
                    for e in err.errors()]
            raise CraftError("bad generation config: " + "; ".join(msgs)) from None

    @property
    def scene_ids(self) -> tuple[int, ...]:
        """The scene id of every entry of ``scenes`` (a custom layout's own ``scene`` field)."""
        return tuple(s if isinstance(s, int) else s.scene for s in self.scenes)

    @property
    def custom_scenes(self) -> dict[int, CustomScene]:
        """The custom layouts by scene id."""
        return {s.scene: s for s in self.scenes if isinstance(s, CustomScene)}

    def content(self) -> dict[str, Any]:
        """The fields that decide the generated content (the report's ``config``), as recorded
        (:func:`as_recorded`)."""
        data = self.model_dump(mode="json")
        return as_recorded({k: data[k] for k in CONTENT_FIELDS})

    @classmethod
    def from_recorded(cls, data: Any, source: str = "generation_config.json", **overrides: Any) -> GenerationConfig:
        """The configuration a ``generation_config.json`` records (:meth:`recorded`), to resume or regenerate that
        dataset; ``overrides`` sets what the file does not decide (``workers``). A file that names no engine was
        made before Box2D became the default: pymunk (:data:`LEGACY_DEFAULT_ENGINE`)."""
        if not isinstance(data, dict):
            raise CraftError(f"{source}: not a generation config (a JSON object of settings expected)")
        data = with_legacy_defaults(data)
        version = data.get("format_version")
        if version != FORMAT_VERSION:
            raise CraftError(f"{source}: format_version {version!r}, and this version of craft_dsl writes "
                             f"{FORMAT_VERSION} (docs/dataset.md, changelog of the output): generate it anew")
        fields = {k: data[k] for k in (*CONTENT_FIELDS, *MEDIA_FIELDS) if k in data}
        missing = [k for k in (*CONTENT_FIELDS, *MEDIA_FIELDS) if k not in data]
        if missing:
            raise CraftError(f"{source}: lacks {', '.join(missing)}")
        unknown = sorted(set(data) - set(RECORDED_FIELDS))
        if unknown:
            raise CraftError(f"{source}: unknown settings {', '.join(unknown)}; known: {', '.join(RECORDED_FIELDS)}")
        return cls.make(**fields, **overrides)

    def recorded(self) -> dict[str, Any]:
        """What ``generation_config.json`` records: the format version and every setting that changes the
        output (:data:`RECORDED_FIELDS`)."""
        data = self.model_dump(mode="json")
        return as_recorded({"format_version": FORMAT_VERSION,
                            **{k: data[k] for k in (*CONTENT_FIELDS, *MEDIA_FIELDS)}})


# -- work list -----------------------------------------------------------------------------------------------


def work_list(config: GenerationConfig) -> list[tuple[int, int]]:
    """``(instance_id, scene_id)`` pairs in scene blocks, ids 0 .. size-1.

    Each scene gets ``size // len(scenes)`` consecutive ids, as in the original; the remainder
    ``size % len(scenes)`` is not dropped (the original dropped it) but gives one more video to each of the
    first scenes, so exactly ``size`` videos are made. When ``size`` is a multiple of the number of scenes the
    ids match the original's (``scene = scenes[id // (size // len(scenes))]``).
    """
    scenes = config.scene_ids
    per, extra = divmod(config.size, len(scenes))
    out: list[tuple[int, int]] = []
    for k, scene in enumerate(scenes):
        out.extend((len(out), scene) for _ in range(per + (1 if k < extra else 0)))
    return out


# -- the output folder ----------------------------------------------------------------------------------------

#: Everything :func:`generate_dataset` writes (``--force`` with other content settings removes it first).
GENERATED = (WORK_FOLDER, "questions", "intermediates", "hf", "README.md", "dataset.json", "dataset_minimal.json",
             "balanced_dataset.json", "imbalanced_dataset.json", "split_info_hard.json", "split_info_random.json",
             "annotations.json", "videos_with_no_questions.json", "generation_report.json", "videos",
             "first_frames", "last_frames", "downsampled", "videos_with_no_questions")


def _load_json(path: Path) -> Any:
    try:
        with path.open(encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def _write_small(data: Any, path: Path) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n", encoding="utf-8")


def recorded_setting(folder: str | Path, name: str) -> str | None:
    """The setting ``name`` (``engine``, ``sampler``) the dataset in ``folder`` was generated with (the default of
    its time where its configuration names none), or ``None`` where the folder holds no readable
    ``generation_config.json``."""
    data = _load_json(Path(folder) / "generation_config.json")
    return str(with_legacy_defaults(data)[name]) if isinstance(data, dict) else None


def recorded_engine(folder: str | Path) -> str | None:
    """The engine the dataset in ``folder`` was generated with (pymunk where its configuration names none), or
    ``None`` where the folder holds no readable ``generation_config.json``."""
    return recorded_setting(folder, "engine")


def differing_settings(old: Any, new: dict[str, Any]) -> list[str]:
    """The recorded settings that differ, as ``name OLD here, NEW now`` (``templates`` by name only, custom scene
    layouts by id and hash)."""
    if not isinstance(old, dict):
        return ["generation_config.json unreadable"]
    out = []
    for k in RECORDED_FIELDS:
        if old.get(k) == new[k]:
            continue
        if k == "templates":
            out.append("templates")
        elif k == "scenes":
            out.append(f"scenes {recorded_scenes_text(old.get(k))} here, {recorded_scenes_text(new[k])} now")
        else:
            out.append(f"{k} {old.get(k)!r} here, {new[k]!r} now")
    return out


def _prepare_folder(root: Path, config: GenerationConfig, force: bool, log: RunLog) -> None:
    """Refuse a folder made with other settings (unless ``force``), else record this configuration."""
    path = root / "generation_config.json"
    new = config.recorded()
    if path.exists():
        # compared as made: a setting a file leaves out has the default of its time, on both sides
        old = _load_json(path)
        if isinstance(old, dict):
            old = with_legacy_defaults(old)
        filled = with_legacy_defaults(new)
        if old != filled:
            diff = differing_settings(old, filled)
            if not force:
                raise CraftError(f"{root} holds a dataset generated with other settings ({'; '.join(diff)}; see "
                                 f"{path}): use a new output folder, the same settings to resume, or --force to "
                                 "start over with these settings")
            if not isinstance(old, dict) or any(old.get(k) != filled[k] for k in RECORDED_FIELDS
                                                if k not in MEDIA_FIELDS):
                log.write(f"--force: settings changed ({'; '.join(diff)}): removing the generated files")
                for name in GENERATED:
                    target = root / name
                    if target.is_dir():
                        shutil.rmtree(target)
                    else:
                        target.unlink(missing_ok=True)
            else:
                log.write(f"--force: media settings changed ({'; '.join(diff)}): keeping the generated files")
            _write_small(new, path)
    else:
        _write_small(new, path)


def sweep_temporary_files(root: Path) -> int:
    """Remove the temporary files a killed run left (atomic writes' ``.<name>.<random>.tmp<ext>``)."""
    n = 0
    for path in root.rglob(".*.tmp*"):
        if path.is_file():
            path.unlink(missing_ok=True)
            n += 1
    return n


@contextmanager
def _folder_lock(root: Path) -> Iterator[None]:
    """Hold an exclusive lock on the folder: a second generate in the same folder is refused."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock
        yield
        return
    fd = os.open(root, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise CraftError(f"{root}: another craft-dsl generate is writing this folder") from None
        yield
    finally:
        os.close(fd)


class RunLog:
    """The run's log file (``generation.log`` in the output folder, appended to) and an optional echo."""

    def __init__(self, root: Path, echo: Any = None) -> None:
        self.path = root / LOG_FILE
        self.echo = echo

    def write(self, message: str) -> None:
        stamp = time.strftime("%Y-%m-%d %H:%M:%S")
        with self.path.open("a", encoding="utf-8") as fh:
            fh.write(f"{stamp} {message}\n")
        if self.echo is not None:
            self.echo(message)


# -- progress -------------------------------------------------------------------------------------------------


class Progress(Protocol):
    """Progress of the stages (``videos``, ``merge``, ``finish``): a display per stage."""

    def start(self, stage: str, total: int, unit: str) -> None: ...

    def advance(self, stage: str, n: int = 1) -> None: ...

    def close(self) -> None: ...


class _NoProgress:
    def start(self, stage: str, total: int, unit: str) -> None:
        pass

    def advance(self, stage: str, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def _peak_memory() -> str:
    """Peak resident memory of this process and of its largest finished child (the local workers)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not POSIX
        return "peak memory not measured"
    scale = 1 if sys.platform == "darwin" else 1024  # ru_maxrss: bytes on macOS, KiB elsewhere
    main = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale / 2**20
    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * scale / 2**20
    return f"peak memory: main process {main:.0f} MiB, largest worker {child:.0f} MiB"


# -- orchestrator -----------------------------------------------------------------------------------------------


def instance_task(config: GenerationConfig, instance_id: int, scene: int, questions: bool = True,
                  media: bool = False, media_thread: bool = True) -> InstanceTask:
    """The task of one video: its questions (the shard) and/or its media files; a custom scene's task carries its
    layout's canonical JSON."""
    custom = config.custom_scenes.get(scene)
    return InstanceTask(instance_id, scene, config.seed, config.steps, config.perturbations, config.amount,
                        config.engine, config.templates, config.video_format, questions, media, config.downsampled,
                        custom.layout if custom is not None else "", sampler=config.sampler,
                        media_thread=media_thread)


class _MergeThread:
    """Merges each scene block as soon as its last shard is written (see :mod:`craft_dsl.dataset.merge`)."""

    def __init__(self, merger: Merger, done: set[int], progress: Progress) -> None:
        self.merger = merger
        self.done = done
        self.progress = progress
        self.wake = threading.Event()
        self.finished = False
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._loop, daemon=True, name="craft-dsl merge")
        self.thread.start()

    def _ready(self) -> bool:
        m = self.merger
        return m.merged < len(m.blocks) and all(i in self.done for i in m.block_ids(m.merged))

    def _loop(self) -> None:
        try:
            while True:
                self.wake.wait()
                self.wake.clear()
                while self._ready() and not self.merger.stop.is_set():
                    if not self.merger.merge_block(self.merger.merged):
                        return
                    self.progress.advance("merge")
                if self.finished or self.merger.stop.is_set():
                    return
        except BaseException as err:  # noqa: BLE001 - re-raised by the main thread
            self.error = err

    def close(self, wait: float | None = None) -> None:
        self.finished = True
        self.wake.set()
        self.thread.join(wait)
        if self.error is not None:
            raise self.error


def generate_dataset(
    config: GenerationConfig, out: str | os.PathLike[str], *, executor: Executor | None = None,
    progress: Progress | None = None, force: bool = False, echo: Any = None,
) -> dict[str, Any]:
    """Generate the dataset into folder ``out`` and return the generation report (also written).

    ``executor``: where the videos are computed (default: ``config.workers`` local processes). Work already done
    in ``out`` (same settings) is not redone. A folder made with other settings is refused unless ``force`` (which
    starts over, or only adds media when just ``videos``/``downsampled`` differ). If videos fail, the others still
    run and a :class:`CraftError` lists the failures (re-running the same command resumes). ``echo(message)``
    also receives the log lines.
    """
    root = Path(out)
    root.mkdir(parents=True, exist_ok=True)
    progress = progress or _NoProgress()
    with _folder_lock(root):
        log = RunLog(root, echo)
        _prepare_folder(root, config, force, log)
        swept = sweep_temporary_files(root)
        executor = executor or LocalExecutor(config.workers)
        work = work_list(config)
        state = load_state(root)
        complete = state is None and not (root / WORK_FOLDER).exists() and (root / "generation_report.json").is_file()
        if state is None and not complete:
            state = new_state()  # shards written before the first committed block are kept
        merger = Merger(root, config, work, state, log.write) if state is not None else None
        merged_ids = {i for i, _ in work} if merger is None else \
            {i for b in range(merger.merged) for i in merger.block_ids(b)}
        done = set(merged_ids) | {i for i, _ in work if i not in merged_ids and shard_is_complete(shard_path(root, i))}
        tasks = []
        media_thread = getattr(executor, "spare_cores", False)
        for i, scene in work:
            media = config.videos and not media_complete(root, scene, i, config.video_format, config.downsampled)
            if i not in done or media:
                tasks.append(instance_task(config, i, scene, questions=i not in done, media=media,
                                           media_thread=media_thread))
        resumed = len(done)
        log.write(f"start: {len(work)} videos, {resumed} already done, {len(tasks)} tasks on {executor.description}"
                  + (f"; removed {swept} temporary files of an interrupted run" if swept else ""))
        for custom in config.custom_scenes.values():
            log.write(f"custom scene {custom.describe()}")
        if resumed:
            (echo or (lambda _m: None))(f"resuming: {resumed} of {len(work)} videos already done")
        start = time.perf_counter()
        progress.start("videos", len(tasks), "video")
        merge_thread = None
        if merger is not None:
            progress.start("merge", len(merger.blocks), "scene")
            progress.advance("merge", merger.merged)
            merge_thread = _MergeThread(merger, done, progress)
            merge_thread.wake.set()

        def on_result(result: InstanceResult) -> None:
            for rel, data in result.media:
                with atomic_path(resolve(root, rel)) as tmp:
                    tmp.write_bytes(data)
            if result.shard is not None:
                with atomic_path(shard_path(root, result.instance_id)) as tmp:
                    tmp.write_bytes(result.shard)
                done.add(result.instance_id)
                if merge_thread is not None:
                    merge_thread.wake.set()
            progress.advance("videos")

        try:
            failures = executor.run(tasks, on_result)
            if merge_thread is not None:
                merge_thread.close()
        except BaseException as err:
            log.write("interrupted: re-run the same command to resume" if isinstance(err, KeyboardInterrupt)
                      else f"stopped by an error: {type(err).__name__}: {err}")
            if merger is not None:
                merger.stop.set()
            if merge_thread is not None:
                merge_thread.finished = True
                merge_thread.wake.set()
                merge_thread.thread.join(1.0)
            raise
        finally:
            progress.close()
        elapsed = time.perf_counter() - start
        if failures:
            shown = "; ".join(f"{id6(i)}: {e}" for i, e in failures[:5])
            log.write(f"{len(failures)} videos failed: {shown}")
            raise CraftError(f"{len(failures)} of {len(work)} instances failed ({shown}); the completed ones are "
                             f"saved in {root}: re-run the same command to resume")
        if merger is not None:
            report = merger.finish(work)
        else:
            report = dict(_load_json(root / "generation_report.json") or {})
            from .layout import park_videos_without_questions

            with_questions = set(range(len(work))) - set(_load_json(root / "videos_with_no_questions.json") or [])
            park_videos_without_questions(root, dict(work), with_questions, config.video_format)
        computed = sum(t.questions for t in tasks)
        log.write(f"done: {computed} videos computed in {elapsed:.1f} s"
                  + (f" ({60 * computed / elapsed:.1f} videos/min)" if computed and elapsed > 0 else "")
                  + f"; {_peak_memory()}")
        return dict(report, resumed=resumed)


__all__ = [
    "CONTENT_FIELDS", "FORMAT_VERSION", "GenerationConfig", "HARD_SPLIT", "InstanceTask", "Progress",
    "RECORDED_FIELDS", "SPLIT_PARTS", "answer_label", "balance", "dataset_videos", "differing_settings",
    "generate_dataset", "hard_split", "id6", "instance_seeds", "instance_task", "post_process", "random_split",
    "recorded_engine", "recorded_setting", "run_instance", "sweep_temporary_files", "template_id_of", "video_path",
    "with_legacy_defaults", "work_list",
]
