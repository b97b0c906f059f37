"""The dataset level of the generation pipeline (spec ``original-question-engine.md`` §6, README §6).

Stages are pure functions over plain records, so each can be tested alone; :func:`generate_dataset` chains them:

1. :func:`work_list` — instance ids in scene blocks;
2. :func:`run_instance` (per video, top-level so a process pool can pickle it) — simulate, generate questions
   (part A, :mod:`craft_dsl.dataset.questions`), perturbation filter, write the annotation
   ``intermediates/sid_<s>/<id6>.json``, the optional media of the published layout (``videos/sid_<s>/<id6>.mpg``,
   ``first_frames/``, ``last_frames/``, :mod:`craft_dsl.dataset.layout`) and, last, the question file
   ``questions/qa_<id6>.json`` (its presence marks the instance complete: resume skips it);
3. :func:`post_process` (§6.5), :func:`balance` (§6.6, seeded and global), :func:`hard_split` /
   :func:`random_split` (§6.7);
4. writers: ``dataset.json`` (§6.8), ``dataset_minimal.json`` (§6.11), split files, ``annotations.json`` (§6.9,
   streamed), ``videos_with_no_questions.json``, ``imbalanced_dataset.json``, ``balanced_dataset.json``,
   ``generation_report.json`` and the Hugging Face files (:mod:`craft_dsl.dataset.hf`).

Every random draw comes from ``numpy.random.SeedSequence`` children of the configuration seed, keyed by what they
decide (instance id; balancing group; split), never by processing order: the same configuration gives
byte-identical files whatever the number of workers. See ``docs/dataset.md``.
"""

from __future__ import annotations

import json
import multiprocessing
import os
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from ..atomic import atomic_path, write_json_atomic
from ..errors import CraftError
from ..templates import DROPPED, templates
from .layout import DEFAULT_VIDEO_FORMAT, VideoFormat, id6, media_complete, park_videos_without_questions, video_relpath

# -- configuration ------------------------------------------------------------------------------------------

#: Fixed "hard" split of the 20 scene ids (spec §6.7, computed by the original with seed 10435).
HARD_SPLIT: dict[str, frozenset[int]] = {
    "train": frozenset({1, 2, 3, 4, 5, 6, 7, 9, 10, 15, 19, 20}),
    "validation": frozenset({8, 12, 14, 16}),
    "test": frozenset({11, 13, 17, 18}),
}
SPLIT_PARTS: tuple[str, ...] = ("train", "validation", "test")

# tags mixed into the seed sequences so that each purpose gets its own stream
_BALANCE_TAG = 0xBA1A
_SPLIT_TAG = 0x5B17

#: Configuration fields that decide the content of the per-instance files (``workers``, ``videos`` and
#: ``downsampled`` do not; ``video_format`` does, since every JSON file names the videos).
CONTENT_FIELDS: tuple[str, ...] = ("size", "seed", "scenes", "steps", "perturbations", "amount", "engine",
                                   "templates", "video_format")


class GenerationConfig(BaseModel):
    """What to generate. ``size`` videos spread over ``scenes`` in blocks (see :func:`work_list`)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    size: int = Field(ge=1, description="number of videos (simulations) to generate")
    seed: int = Field(0, ge=0, description="the one seed every random draw derives from")
    scenes: tuple[int, ...] = Field(tuple(range(1, 21)), description="scene layout ids (1-20)")
    steps: int = Field(600, ge=1, description="simulation steps per video (60 per second)")
    perturbations: int = Field(3, ge=0, description="perturbed re-simulations per video (0: no filter)")
    amount: float = Field(0.02, ge=0.0, le=0.5, description="perturbation noise amount")
    workers: int = Field(1, ge=1, description="worker processes")
    videos: bool = Field(False, description="render each video with its first and last frames")
    video_format: VideoFormat = Field(DEFAULT_VIDEO_FORMAT, description="mpg (MPEG-1, as published) or mp4 (H.264)")
    downsampled: tuple[int, ...] = Field((), description="also write H.264 videos at these frame rates (with videos)")
    engine: Literal["pymunk", "box2d"] = "pymunk"
    templates: tuple[str, ...] = Field(tuple(templates()), description="template ids to instantiate")
    balance: bool = Field(True, description="answer balancing (off: keep every question that passed the filters)")

    @field_validator("scenes")
    @classmethod
    def _check_scenes(cls, v: tuple[int, ...]) -> tuple[int, ...]:
        if not v:
            raise ValueError("give at least one scene id")
        bad = [s for s in v if not 1 <= s <= 20]
        if bad:
            raise ValueError(f"scene ids are 1-20, not {bad}")
        if len(set(v)) != len(v):
            raise ValueError(f"scene ids repeat: {list(v)}")
        return v

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
            msgs = [f"{'.'.join(str(p) for p in e['loc']) or 'config'}: {e['msg']}" for e in err.errors()]
            raise CraftError("bad generation config: " + "; ".join(msgs)) from None

    def content(self) -> dict[str, Any]:
        """The fields that decide the generated content (stored in ``generation_config.json``)."""
        data = self.model_dump(mode="json")
        return {k: data[k] for k in CONTENT_FIELDS}


# -- work list and seeds ------------------------------------------------------------------------------------


def work_list(config: GenerationConfig) -> list[tuple[int, int]]:
    """``(instance_id, scene_id)`` pairs in scene blocks, ids 0 .. size-1.

    Each scene gets ``size // len(scenes)`` consecutive ids, as in the original (§6.3); the remainder
    ``size % len(scenes)`` is not dropped (the original dropped it) but gives one more video to each of the
    first scenes, so exactly ``size`` videos are made. When ``size`` is a multiple of the number of scenes the
    ids match the original's (``scene = scenes[id // (size // len(scenes))]``).
    """
    n = len(config.scenes)
    per, extra = divmod(config.size, n)
    out: list[tuple[int, int]] = []
    for k, scene in enumerate(config.scenes):
        out.extend((len(out), scene) for _ in range(per + (1 if k < extra else 0)))
    return out


def instance_seeds(seed: int, instance_id: int) -> tuple[int, np.random.SeedSequence, np.random.SeedSequence]:
    """(simulation seed, question seed sequence, perturbation seed sequence) of one instance.

    Children of ``SeedSequence([seed, instance_id])``: they depend on nothing but the configuration seed and the
    instance id, so results do not depend on processing order or the number of workers.
    """
    sim_ss, question_ss, perturb_ss = np.random.SeedSequence([seed, instance_id]).spawn(3)
    return int(sim_ss.generate_state(1, dtype=np.uint32)[0]), question_ss, perturb_ss


def video_path(scene: int, instance_id: int, video_format: str = DEFAULT_VIDEO_FORMAT) -> str:
    """The dataset-relative video path recorded in every file (``./videos/sid_<s>/<id6>.mpg``)."""
    return video_relpath(scene, instance_id, video_format)


def annotation_file(out: Path, scene: int, instance_id: int) -> Path:
    return out / "intermediates" / f"sid_{scene}" / f"{id6(instance_id)}.json"


def questions_file(out: Path, instance_id: int) -> Path:
    return out / "questions" / f"qa_{id6(instance_id)}.json"


# -- per instance -------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class InstanceTask:
    """Everything one worker needs (picklable)."""

    out: str
    instance_id: int
    scene: int
    seed: int
    steps: int
    perturbations: int
    amount: float
    engine: str
    templates: tuple[str, ...]
    videos: bool
    video_format: str = DEFAULT_VIDEO_FORMAT
    downsampled: tuple[int, ...] = ()


def _part_a() -> ModuleType:
    """The per-video generator (part A), imported lazily."""
    from . import questions

    return questions


def _load_json(path: Path) -> Any:
    try:
        with path.open(encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def instance_complete(out: Path, scene: int, instance_id: int, videos: bool,
                      video_format: str = DEFAULT_VIDEO_FORMAT, downsampled: tuple[int, ...] = ()) -> bool:
    """True if the instance's files exist and parse (its question file is written last), with its media if
    ``videos``."""
    qa = _load_json(questions_file(out, instance_id))
    if not isinstance(qa, dict) or not isinstance(qa.get("questions"), list) or "stats" not in qa:
        return False
    ann = _load_json(annotation_file(out, scene, instance_id))
    if not isinstance(ann, dict) or "original_video_output" not in ann:
        return False
    return not videos or media_complete(out, scene, instance_id, video_format, downsampled)


def run_instance(task: InstanceTask) -> int:
    """Simulate one video, generate and filter its questions, write its files; returns the instance id.

    Writes (each atomically) the annotation, the media if asked for (video, first and last frames, downsampled
    videos: :func:`craft_dsl.dataset.layout.write_media`), then ``questions/qa_<id6>.json`` =
    ``{"info", "questions", "stats"}`` (``info``/``questions`` as the original's qa file, §4.9; ``stats`` for the
    generation report). An interrupted instance leaves no question file and is redone on the next run.
    """
    from ..physics import simulate
    from ..recorded import simulation_dict

    part_a = _part_a()
    out = Path(task.out)
    vpath = video_path(task.scene, task.instance_id, task.video_format)
    sim_seed, question_ss, perturb_ss = instance_seeds(task.seed, task.instance_id)
    sim = simulate(task.scene, seed=sim_seed, steps=task.steps, engine=task.engine)
    sim.meta["video_filename"] = vpath
    generated: list[dict[str, Any]] = part_a.generate_questions(
        sim, np.random.default_rng(question_ss), video_index=task.instance_id, video_filename=vpath,
        template_ids=list(task.templates), instances_per_template=1,
    )
    if task.perturbations > 0:
        kept, pstats = part_a.perturbation_filter(
            sim, generated, np.random.default_rng(perturb_ss), perturbations=task.perturbations, amount=task.amount
        )
    else:
        kept, pstats = list(generated), {}
    kept_keys = {q["question_index"] for q in kept}
    dynamic_shapes = sorted({o.shape for o in sim.objects if o.dynamic})
    stats = {
        "scene": task.scene,
        "simulation_seed": sim_seed,
        "dynamic_shapes": dynamic_shapes,
        "generated": [template_id_of(q) for q in generated],
        "dropped_by_perturbation": [template_id_of(q) for q in generated if q["question_index"] not in kept_keys],
        "perturbation": _jsonable(pstats),
    }
    write_json_atomic(simulation_dict(sim), annotation_file(out, task.scene, task.instance_id), indent=None)
    if task.videos:
        from .layout import write_media

        write_media(sim, out, task.scene, task.instance_id, task.video_format, task.downsampled)
    info = {"video_filename": vpath, "video_index": task.instance_id}
    write_json_atomic({"info": info, "questions": kept, "stats": stats}, questions_file(out, task.instance_id),
                      indent=None)
    return task.instance_id


def _jsonable(value: Any) -> Any:
    """``value`` made JSON-safe (numpy scalars, tuples, sets) so the stats file always writes."""
    return json.loads(json.dumps(value, default=lambda o: o.tolist() if hasattr(o, "tolist") else sorted(o)
                                 if isinstance(o, (set, frozenset)) else str(o)))


# -- post-process (§6.5) ------------------------------------------------------------------------------------

_PREVENT_FIXES = ("is prevented by", "is kept by", "is held by", "is blocked by")


def template_id_of(record: Mapping[str, Any]) -> str:
    tid = record.get("template_id")
    if tid:
        return str(tid)
    return f"{Path(str(record['template_filename'])).stem}_{record['question_family_index']}"


def _is_shape_answer(answer: Any) -> bool:
    from ..vocabulary import SHAPES

    return isinstance(answer, str) and answer.lower() in SHAPES


def post_process(
    records: Iterable[Mapping[str, Any]], dynamic_shape_counts: Mapping[int, int]
) -> tuple[list[dict[str, Any]], Counter[str]]:
    """The pre-balancing post-process (§6.5) over records of §4.9 (raw answers).

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


# -- balancing (§6.6) ---------------------------------------------------------------------------------------


def answer_label(answer: Any) -> str:
    """The string a balancing group counts (``str`` of the raw answer, capitalised as after §6.6 step 1)."""
    return str(answer).capitalize()


def _is_outlier(label: str) -> bool:
    return label.isdigit() and 3 <= int(label) <= 10


def _template_number(tid: str) -> int:
    return list(templates()).index(tid) if tid in templates() else -1


def balance(
    records: Sequence[Mapping[str, Any]], scene_of: Mapping[int, int], seed: int
) -> tuple[list[dict[str, Any]], Counter[str]]:
    """Answer balancing within each (scene, template) group over the merged dataset (§6.6), seeded.

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


# -- splits (§6.7) ------------------------------------------------------------------------------------------


def _keys(records: Iterable[Mapping[str, Any]]) -> list[dict[str, int]]:
    return [{"video_index": int(r["video_index"]), "question_index": int(r["question_index"])} for r in records]


def hard_split(records: Sequence[Mapping[str, Any]], scene_of: Mapping[int, int]) -> dict[str, list[dict[str, int]]]:
    """The fixed held-out-scene split: every question goes to the part of its scene (:data:`HARD_SPLIT`)."""
    return {part: _keys(r for r in records if scene_of[int(r["video_index"])] in HARD_SPLIT[part])
            for part in SPLIT_PARTS}


def random_split(records: Sequence[Mapping[str, Any]], seed: int) -> dict[str, list[dict[str, int]]]:
    """The "easy" split: the sorted video indices are shuffled once (seeded), test = validation = int(0.2 N),
    train = the rest, taken in that order; whole videos go to one part."""
    videos = sorted({int(r["video_index"]) for r in records})
    order = np.random.default_rng(np.random.SeedSequence([seed, _SPLIT_TAG])).permutation(len(videos))
    shuffled = [videos[i] for i in order]
    n_test = n_val = int(0.2 * len(videos))
    n_train = len(videos) - n_test - n_val
    part_of = {v: "train" for v in shuffled[:n_train]}
    part_of.update({v: "validation" for v in shuffled[n_train:n_train + n_val]})
    part_of.update({v: "test" for v in shuffled[n_train + n_val:]})
    return {part: _keys(r for r in records if part_of[int(r["video_index"])] == part) for part in SPLIT_PARTS}


# -- writers ------------------------------------------------------------------------------------------------


def dataset_videos(
    records: Sequence[Mapping[str, Any]], scene_of: Mapping[int, int], video_format: str = DEFAULT_VIDEO_FORMAT
) -> list[dict[str, Any]]:
    """The ``dataset.json`` list (§6.8): one element per video with questions, ascending, raw answers."""
    by_video: dict[int, list[dict[str, Any]]] = defaultdict(list)
    for rec in records:
        by_video[int(rec["video_index"])].append(dict(rec))
    out = []
    for vi in sorted(by_video):
        path = video_path(scene_of[vi], vi, video_format)
        qs = sorted(by_video[vi], key=lambda r: int(r["question_index"]))
        out.append({"simulation_id": str(scene_of[vi]), "video_path": path,
                    "questions": {"info": {"video_filename": path, "video_index": vi}, "questions": qs}})
    return out


def write_annotations(path: Path, sources: Iterable[tuple[str, Path]]) -> int:
    """Stream ``{"<id6>": <simulation with variations>, ...}`` into ``path`` atomically, one entry at a time
    (each source file is parsed and re-serialised, so the result is valid JSON). Returns the entry count."""
    n = 0
    with atomic_path(path) as tmp, tmp.open("w", encoding="utf-8") as fh:
        fh.write("{")
        for key, source in sources:
            with source.open(encoding="utf-8") as src:
                data = json.load(src)
            fh.write(("," if n else "") + "\n" + json.dumps(key) + ": ")
            json.dump(data, fh)
            n += 1
        fh.write("\n}\n")
    return n


def _write(data: Any, path: Path, indent: int | None = None, sort_keys: bool = False) -> None:
    with atomic_path(path) as tmp, tmp.open("w", encoding="utf-8") as fh:
        json.dump(data, fh, indent=indent, sort_keys=sort_keys)
        fh.write("\n")


# -- orchestrator -------------------------------------------------------------------------------------------

Progress = Callable[[int], None]


def _check_folder(out: Path, config: GenerationConfig) -> None:
    path = out / "generation_config.json"
    if path.exists():
        old = _load_json(path)
        new = config.content()
        if old != new:
            if isinstance(old, dict):
                diff = ", ".join(f"{k} {old.get(k)!r} here, {new[k]!r} now" if k != "templates" else "templates"
                                 for k in CONTENT_FIELDS if old.get(k) != new[k])
            else:
                diff = "unreadable"
            raise CraftError(f"{out} holds a dataset generated with another configuration ({diff}; see {path}): "
                             "use a new output folder, or the same configuration to resume")
    else:
        _write(config.content(), path, indent=2, sort_keys=True)


def _run_pending(tasks: Sequence[InstanceTask], workers: int, progress: Progress | None) -> list[tuple[int, str]]:
    """Run the tasks (in a process pool when workers > 1); returns the failures ``(instance id, error)``."""
    failures: list[tuple[int, str]] = []
    if workers <= 1 or len(tasks) <= 1:
        for task in tasks:
            try:
                run_instance(task)
            except Exception as err:  # noqa: BLE001 - reported after the other instances ran
                failures.append((task.instance_id, f"{type(err).__name__}: {err}"))
            if progress:
                progress(1)
        return failures
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(workers, len(tasks)), mp_context=ctx) as pool:
        futures: dict[Future[int], int] = {pool.submit(run_instance, t): t.instance_id for t in tasks}
        for fut in as_completed(futures):
            exc = fut.exception()
            if exc is not None:
                failures.append((futures[fut], f"{type(exc).__name__}: {exc}"))
            if progress:
                progress(1)
    return sorted(failures)


def generate_dataset(
    config: GenerationConfig, out: str | os.PathLike[str], progress: Progress | None = None,
    on_total: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Generate the dataset into folder ``out`` and return the generation report (also written).

    Instances already complete in ``out`` (same configuration) are not recomputed. ``on_total(pending, total)``
    is called once before the instances run, ``progress(1)`` after each. If instances fail, the others still
    run and a :class:`CraftError` lists the failures (re-running the same command resumes).
    """
    root = Path(out)
    root.mkdir(parents=True, exist_ok=True)
    _check_folder(root, config)
    work = work_list(config)
    tasks = [
        InstanceTask(str(root), i, s, config.seed, config.steps, config.perturbations, config.amount, config.engine,
                     config.templates, config.videos, config.video_format, config.downsampled)
        for i, s in work if not instance_complete(root, s, i, config.videos, config.video_format, config.downsampled)
    ]
    if on_total:
        on_total(len(tasks), len(work))
    failures = _run_pending(tasks, config.workers, progress)
    if failures:
        shown = "; ".join(f"{id6(i)}: {e}" for i, e in failures[:5])
        raise CraftError(f"{len(failures)} of {len(work)} instances failed ({shown}); the completed ones are "
                         f"saved in {root}: re-run the same command to resume")
    return assemble(config, root, work, resumed=len(work) - len(tasks))


def assemble(config: GenerationConfig, root: Path, work: Sequence[tuple[int, int]], resumed: int = 0) -> dict[str, Any]:
    """Merge the per-instance files (in instance order) and write every dataset-level file."""
    scene_of = dict(work)
    generated: list[dict[str, Any]] = []
    shape_counts: dict[int, int] = {}
    per_template: dict[str, Counter[str]] = defaultdict(Counter)
    perturbation_total: Counter[str] = Counter()
    for i, _scene in work:
        qa = _load_json(questions_file(root, i))
        if not isinstance(qa, dict):
            raise CraftError(f"{questions_file(root, i)}: missing or unreadable; re-run to regenerate it")
        stats = qa["stats"]
        shape_counts[i] = len(stats["dynamic_shapes"])
        for tid in stats["generated"]:
            per_template[tid]["generated"] += 1
        for tid in stats["dropped_by_perturbation"]:
            per_template[tid]["dropped_by_perturbation"] += 1
        perturbation_total["generated"] += len(stats["generated"])
        perturbation_total["dropped_by_perturbation"] += len(stats["dropped_by_perturbation"])
        generated.extend(qa["questions"])

    processed, pp_dropped = post_process(generated, shape_counts)
    if config.balance:
        balanced, bal_counts = balance(processed, scene_of, config.seed)
    else:
        balanced, bal_counts = [dict(r) for r in processed], Counter()
    for rec in processed:
        per_template[template_id_of(rec)]["after_post_process"] += 1
    for rec in balanced:
        per_template[template_id_of(rec)]["final"] += 1

    # writers
    dataset = dataset_videos(balanced, scene_of, config.video_format)
    from ..verify import minimal_records

    minimal = minimal_records(dataset)
    _write(dataset, root / "dataset.json")
    _write(minimal, root / "dataset_minimal.json")
    _write(minimal, root / "balanced_dataset.json")
    _write(minimal_records(dataset_videos(processed, scene_of, config.video_format)), root / "imbalanced_dataset.json")
    hard = hard_split(balanced, scene_of)
    rand = random_split(balanced, config.seed)
    _write(hard, root / "split_info_hard.json")
    _write(rand, root / "split_info_random.json")
    with_questions = [v["questions"]["info"]["video_index"] for v in dataset]
    n_ann = write_annotations(root / "annotations.json",
                              ((id6(v), annotation_file(root, scene_of[v], v)) for v in with_questions))
    no_questions = sorted(set(scene_of) - set(with_questions))
    _write(no_questions, root / "videos_with_no_questions.json", indent=2)
    park_videos_without_questions(root, scene_of, with_questions, config.video_format)

    report: dict[str, Any] = {
        "config": config.content(),
        "videos": {"total": len(work), "with_questions": len(with_questions), "without_questions": len(no_questions),
                   "annotations": n_ann},
        "questions": {
            "generated": perturbation_total["generated"],
            "dropped_by_perturbation": perturbation_total["dropped_by_perturbation"],
            "after_perturbation": len(generated),
            "dropped_by_post_process": dict(sorted(pp_dropped.items())),
            "after_post_process": len(processed),
            "dropped_by_balancing": dict(sorted(bal_counts.items())),
            "final": len(balanced),
        },
        "splits": {"hard": {p: len(hard[p]) for p in SPLIT_PARTS}, "random": {p: len(rand[p]) for p in SPLIT_PARTS}},
        "per_template": {t: {k: per_template[t][k] for k in ("generated", "dropped_by_perturbation",
                                                                "after_post_process", "final")}
                         for t in templates() if t in per_template},
    }
    _write(report, root / "generation_report.json", indent=2, sort_keys=True)
    from .hf import write_hf

    hf = write_hf(root)
    return dict(report, resumed=resumed, hf_parquet=hf.parquet)


__all__ = [
    "GenerationConfig", "HARD_SPLIT", "InstanceTask", "assemble", "balance", "dataset_videos", "generate_dataset",
    "hard_split", "id6", "instance_complete", "instance_seeds", "post_process", "random_split", "run_instance",
    "work_list", "write_annotations",
]
