"""An lmms-eval task folder for a CRAFT dataset, and the functions its tasks call.

``craft-dsl export lmms-eval DATASET --out DIR`` (:func:`export_lmms_eval`) writes a folder that lmms-eval
(``pip install lmms-eval``, 0.7.x) loads with ``--include_path DIR`` from local files, without the Hugging Face hub:

* ``craft.yaml``: the group ``craft`` (its tasks below; the name is ``--name``);
* ``craft_easy.yaml``: the random split's test part (the paper's *easy* split); ``craft_hard.yaml``: the hard
  split's test part (held-out scenes). A part without questions gets no task (the command says so);
* ``easy.jsonl``, ``hard.jsonl``: one row per question (:data:`DOC_FIELDS`), read by lmms-eval's ``json`` builder;
* ``craft_task.json``: the dataset folder (absolute path) and the visual settings, which ``utils.py`` reads;
* ``utils.py``: the functions the task files name (``!function utils....``); they call this module, so
  craft-dsl must be installed where lmms-eval runs.

What each function does:

* :func:`doc_to_text`: the prompt: the optional ``pre_prompt``, the question, and the answer kind the question's
  program returns (:data:`KIND_INSTRUCTIONS`; e.g. "Answer with a single whole number (0, 1, 2, ...) and nothing
  else."), then ``post_prompt``;
* :func:`doc_to_visual`: ``visual: frames`` (the default) decodes the video and passes ``frames`` frames spread
  evenly over it (first and last included), or with ``fps`` set, one frame every ``1/fps`` seconds from the first,
  as PIL images; ``visual: video`` passes the video file's path, and the model samples frames itself (e.g. its
  ``max_frames_num`` model argument);
* :func:`process_results`: reads the model's free text into an answer (:func:`~craft_dsl.harness.parse_answer`,
  for the question's answer kind) and returns one item per metric;
* :func:`aggregate`: accuracy (%) of one group of questions, computed by :func:`craft_dsl.verify.score` itself,
  so every figure equals ``craft-dsl score`` on the same answers: ``accuracy`` (all), ``acc_C``, ``acc_CF``,
  ``acc_D`` and one per paper sub-category present in the part (``acc_D_2Q`` ... ``acc_C_N``,
  :data:`METRIC_OF_GROUP`). A text from which no answer can be read counts as wrong, as a missing prediction does.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from ..atomic import atomic_path
from ..errors import CraftError
from ..verify import Question, category_of, family_of, score
from ..verify.categories import CATEGORIES, FAMILIES
from .answers import kind_of_record, kind_of_template, parse_answer

#: The test parts exported, as (task suffix, split file name): the paper's easy and hard test sets.
PARTS: tuple[tuple[str, str], ...] = (("easy", "random"), ("hard", "hard"))
#: The columns of every row of ``easy.jsonl`` / ``hard.jsonl``.
DOC_FIELDS: tuple[str, ...] = ("video_index", "question_index", "question", "answer", "answer_kind", "template_id",
                               "category", "family", "video")
#: The metric of each group: ``All``, the paper's columns and sub-categories.
METRIC_OF_GROUP: dict[str, str] = {
    "All": "accuracy", **{f: f"acc_{f}" for f in FAMILIES},
    **{c: "acc_" + c.replace("/", "_").replace("-", "_") for c in CATEGORIES},
}
#: What the prompt asks for, per answer kind.
KIND_INSTRUCTIONS: dict[str, str] = {
    "count": "Answer with a single whole number (0, 1, 2, ...) and nothing else.",
    "bool": "Answer with True or False and nothing else.",
    "color": "Answer with one colour (gray, red, blue, green, brown, purple, cyan or yellow) and nothing else.",
    "shape": "Answer with one shape (cube, triangle or circle) and nothing else.",
    "size": "Answer with one size (small or large) and nothing else.",
}
#: The default text before every question.
DEFAULT_PRE_PROMPT = ("The video shows a 2D physics scene: objects move, collide, fall to the ground and may enter a "
                      "basket. ")
DEFAULT_FRAMES = 8
VISUALS: tuple[str, ...] = ("frames", "video")
TASK_CONFIG = "craft_task.json"


@dataclass(frozen=True)
class VisualSettings:
    """How videos reach the model: ``visual`` ``frames`` (decoded here: ``frames`` evenly spread, or one every
    ``1/fps`` s when ``fps`` is set) or ``video`` (the file's path)."""

    visual: str = "frames"
    frames: int = DEFAULT_FRAMES
    fps: float | None = None

    def __post_init__(self) -> None:
        if self.visual not in VISUALS:
            raise CraftError(f"unknown visual {self.visual!r}; allowed: {', '.join(VISUALS)}")
        if isinstance(self.frames, bool) or not isinstance(self.frames, int) or self.frames < 1:
            raise CraftError(f"frames must be a whole number of at least 1, not {self.frames!r}")
        if self.fps is not None and not (0 < float(self.fps) <= 60):
            raise CraftError(f"fps must be above 0 and at most 60 (the videos' own rate), not {self.fps!r}")


@dataclass
class ExportResult:
    """What :func:`export_lmms_eval` wrote: the folder, the files, the rows per task, the parts skipped."""

    out: Path
    files: list[str] = field(default_factory=list)
    tasks: dict[str, int] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)


# -- the functions the task files call ---------------------------------------------------------------------------


def doc_to_text(doc: Mapping[str, Any], lmms_eval_specific_kwargs: Mapping[str, Any] | None = None) -> str:
    """The prompt of one question (see the module docstring)."""
    kwargs = lmms_eval_specific_kwargs or {}
    kind = str(doc.get("answer_kind") or kind_of_record(doc))
    pre = str(kwargs.get("pre_prompt", DEFAULT_PRE_PROMPT) or "")
    post = str(kwargs.get("post_prompt", "") or "")
    return f"{pre}{str(doc['question']).strip()}\n{KIND_INSTRUCTIONS[kind]}{post}"


def frame_indices(total: int, video_fps: float, frames: int = DEFAULT_FRAMES, fps: float | None = None) -> list[int]:
    """The frames passed to the model from a video of ``total`` frames at ``video_fps``: with ``fps``, one every
    ``1/fps`` seconds from the first (frame ``round(k * video_fps / fps)``); else ``frames`` evenly spread from the
    first to the last (all of them when the video has fewer)."""
    if total < 1:
        return []
    if fps is not None:
        step = video_fps / float(fps)
        out: list[int] = []
        k = 0
        while round(k * step) < total:
            out.append(round(k * step))
            k += 1
        return out
    if frames >= total:
        return list(range(total))
    if frames == 1:
        return [0]
    return [round(i * (total - 1) / (frames - 1)) for i in range(frames)]


def video_path(doc: Mapping[str, Any], dataset: str | os.PathLike[str]) -> Path:
    """The video file of a row (its ``video`` path is relative to the dataset folder)."""
    path = Path(dataset) / str(doc["video"])
    if not path.is_file():
        raise CraftError(f"{path}: no such video (question {doc.get('video_index')}_{doc.get('question_index')}); "
                         f"make the dataset with --videos, or set dataset_root in {TASK_CONFIG}")
    return path


def doc_to_visual(doc: Mapping[str, Any], settings: VisualSettings, dataset: str | os.PathLike[str]) -> list[Any]:
    """The visual input of one question: ``[video path]`` or the sampled frames as PIL images."""
    path = video_path(doc, dataset)
    if settings.visual == "video":
        return [str(path)]
    from PIL import Image

    stat = path.stat()
    frames = _sampled_frames(str(path), stat.st_mtime_ns, stat.st_size, settings.frames, settings.fps)
    return [Image.fromarray(frame) for frame in frames]


@lru_cache(maxsize=8)
def _sampled_frames(path: str, mtime_ns: int, size: int, frames: int, fps: float | None) -> tuple[Any, ...]:
    """The sampled frames of a video (uint8 [H, W, 3] arrays), kept for the next questions on the same video
    (the rows are in video order); keyed by the file's modification time and size too."""
    from ..reader.video import decode, frame_rate

    video = decode(path)
    rate = frame_rate(path, len(video)).fps
    return tuple(video[i].copy() for i in frame_indices(len(video), rate, frames, fps))


def process_results(doc: Mapping[str, Any], results: Sequence[Any],
                    metrics: Sequence[str] | None = None) -> dict[str, dict[str, Any]]:
    """One item per metric (every metric of :data:`METRIC_OF_GROUP` unless ``metrics`` names them): the question's
    key, template, recorded answer, the answer read from the model's text (None: none could be read) and the text."""
    text = results[0] if results else ""
    kind = str(doc.get("answer_kind") or kind_of_record(doc))
    item = {"video_index": int(doc["video_index"]), "question_index": int(doc["question_index"]),
            "template_id": str(doc["template_id"]), "answer": doc["answer"], "prediction": parse_answer(text, kind),
            "response": text if isinstance(text, str) else str(text)}
    return {m: item for m in (metrics or METRIC_OF_GROUP.values())}


def aggregate(items: Sequence[Mapping[str, Any]], group: str = "All") -> float:
    """Accuracy (%) over the items of ``group`` (``All``, ``C``, ``CF``, ``D`` or a sub-category), exactly as
    :func:`craft_dsl.verify.score` gives it for the same answers (an unread answer counts as missing, i.e. wrong);
    NaN for a group without questions."""
    if group not in METRIC_OF_GROUP:
        raise CraftError(f"unknown group {group!r}; allowed: {', '.join(METRIC_OF_GROUP)}")
    questions = [Question(int(i["video_index"]), int(i["question_index"]), str(i["template_id"]), i["answer"])
                 for i in items]
    predictions = {(int(i["video_index"]), int(i["question_index"])): i["prediction"]
                   for i in items if i["prediction"] is not None}
    report = score(questions, predictions) if questions else None
    if report is None:
        return float("nan")
    s = report.columns.get(group) if group in (*FAMILIES, "All") else report.per_category.get(group)
    return float("nan") if s is None or s.accuracy is None else float(s.accuracy)


def load_task_config(folder: str | os.PathLike[str]) -> tuple[Path, VisualSettings]:
    """The dataset folder and visual settings of an exported task folder (``craft_task.json``); the environment
    variable ``CRAFT_DATASET`` overrides the dataset folder."""
    path = Path(folder) / TASK_CONFIG
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise CraftError(f"{path}: cannot read the task settings ({err})") from None
    root = Path(os.environ.get("CRAFT_DATASET") or data["dataset_root"])
    visual = data.get("visual", {})
    return root, VisualSettings(str(visual.get("visual", "frames")), int(visual.get("frames", DEFAULT_FRAMES)),
                                None if visual.get("fps") is None else float(visual["fps"]))


# -- the export --------------------------------------------------------------------------------------------------


def question_rows(folder: Any, split: str, part: str,
                  extra: Callable[[tuple[int, int], str], dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per question of ``part`` of ``split``, in ``dataset_minimal.json`` order: its keys, text, answer,
    answer kind and template, then ``extra(key, template_id)``'s fields, then its video's path in the folder."""
    keys = folder.split(split)[part]
    out = []
    for rec in folder.records:
        key = (int(rec["video_index"]), int(rec["question_index"]))
        if key not in keys:
            continue
        tid = str(rec["template_id"])
        out.append({"video_index": key[0], "question_index": key[1], "question": str(rec.get("question", "")),
                    "answer": str(rec["answer"]), "answer_kind": kind_of_template(tid), "template_id": tid,
                    **extra(key, tid), "video": folder.video_relpath(rec).removeprefix("./")})
    return out


def _rows(folder: Any, split: str) -> list[dict[str, Any]]:
    return question_rows(folder, split, "test", lambda _key, tid: {"category": category_of(tid),
                                                                   "family": family_of(tid)})


def _groups_present(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    families = {r["family"] for r in rows}
    categories = {r["category"] for r in rows}
    return ["All", *(f for f in FAMILIES if f in families), *(c for c in CATEGORIES if c in categories)]


def _task_yaml(name: str, part: str, groups: Sequence[str], settings: VisualSettings, split: str,
               max_new_tokens: int) -> str:
    metrics = "\n".join(
        f"  - metric: {METRIC_OF_GROUP[g]}\n    aggregation: !function utils.aggregate_{METRIC_OF_GROUP[g]}\n"
        f"    higher_is_better: true" for g in groups)
    fps = "null" if settings.fps is None else repr(float(settings.fps))
    return f"""# CRAFT {part} test set ({split} split, test part), written by craft-dsl export lmms-eval
# (docs/evaluate.md)
task: {name}_{part}
dataset_path: json
dataset_kwargs:
  data_files:
    test: {part}.jsonl
test_split: test
output_type: generate_until
doc_to_visual: !function utils.doc_to_visual
doc_to_text: !function utils.doc_to_text
doc_to_target: answer
process_results: !function utils.process_results
generation_kwargs:
  max_new_tokens: {max_new_tokens}
  temperature: 0
  do_sample: false
metric_list:
{metrics}
lmms_eval_specific_kwargs:
  default:
    pre_prompt: {json.dumps(DEFAULT_PRE_PROMPT)}
    post_prompt: ""
    # how videos reach the model (craft_task.json holds the same, written by the export):
    # visual: frames (decoded here) or video (the file path; the model samples frames itself)
    visual: {settings.visual}
    frames: {settings.frames}
    fps: {fps}
metadata:
  version: 1.0
"""


_UTILS = '''"""lmms-eval functions of the CRAFT tasks in this folder (written by craft-dsl export lmms-eval; they call
craft_dsl.harness.lmms_eval, so craft-dsl must be installed where lmms-eval runs)."""

from pathlib import Path

from craft_dsl.harness import lmms_eval as _craft
from craft_dsl.harness.lmms_eval import VisualSettings

_HERE = Path(__file__).resolve().parent
_ROOT, _SETTINGS = _craft.load_task_config(_HERE)


def doc_to_text(doc, lmms_eval_specific_kwargs=None):
    return _craft.doc_to_text(doc, lmms_eval_specific_kwargs)


def doc_to_visual(doc, lmms_eval_specific_kwargs=None):
    settings = _SETTINGS
    kwargs = lmms_eval_specific_kwargs or {{}}
    if any(k in kwargs for k in ("visual", "frames", "fps")):
        fps = kwargs.get("fps", settings.fps)
        settings = VisualSettings(str(kwargs.get("visual", settings.visual)),
                                  int(kwargs.get("frames", settings.frames)), None if fps is None else float(fps))
    return _craft.doc_to_visual(doc, settings, _ROOT)


def process_results(doc, results, **kwargs):
    return _craft.process_results(doc, results)

{aggregators}
'''


def export_lmms_eval(dataset: str | os.PathLike[str], out: str | os.PathLike[str], *,
                     settings: VisualSettings | None = None, name: str = "craft",
                     max_new_tokens: int = 32) -> ExportResult:
    """Write the lmms-eval task folder of a dataset folder (see the module docstring); existing files of the same
    names are replaced, others left alone."""
    from ..dataset.folder import DatasetFolder

    settings = settings or VisualSettings()
    if not name.isidentifier():
        raise CraftError(f"task name {name!r}: use letters, digits and underscores (it prefixes the task names)")
    folder = DatasetFolder(dataset)
    target = Path(out)
    if target.exists() and not target.is_dir():
        raise CraftError(f"{target}: exists and is not a folder")
    target.mkdir(parents=True, exist_ok=True)
    result = ExportResult(target)
    tasks: list[str] = []
    for part, split in PARTS:
        rows = _rows(folder, split)
        if not rows:
            result.skipped.append(f"{part} ({split} split: its test part has no questions)")
            continue
        _write(target / f"{part}.jsonl", "".join(json.dumps(r, ensure_ascii=False) + "\n" for r in rows), result)
        _write(target / f"{name}_{part}.yaml",
               _task_yaml(name, part, _groups_present(rows), settings, split, max_new_tokens), result)
        tasks.append(f"{name}_{part}")
        result.tasks[f"{name}_{part}"] = len(rows)
    if not tasks:
        raise CraftError(f"{folder.root}: neither test part has questions (easy: split_info_random.json, hard: "
                         "split_info_hard.json); nothing to export")
    task_list = "\n".join(f"  - {t}" for t in tasks)
    _write(target / f"{name}.yaml", f"# CRAFT (docs/evaluate.md), written by craft-dsl export lmms-eval\n"
                                    f"group: {name}\ntask:\n{task_list}\n", result)
    aggregators = "\n".join(
        f"def aggregate_{metric}(items):\n    return _craft.aggregate(items, {group!r})\n\n"
        for group, metric in METRIC_OF_GROUP.items())
    _write(target / "utils.py", _UTILS.replace("{{}}", "{}").replace("{aggregators}", aggregators.rstrip() + "\n"),
           result)
    config = {"dataset_root": str(folder.root.resolve()),
              "visual": {"visual": settings.visual, "frames": settings.frames, "fps": settings.fps},
              "tasks": result.tasks, "name": name}
    _write(target / TASK_CONFIG, json.dumps(config, indent=2) + "\n", result)
    return result


def _write(path: Path, text: str, result: ExportResult) -> None:
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    result.files.append(path.name)


__all__ = ["DEFAULT_FRAMES", "DEFAULT_PRE_PROMPT", "DOC_FIELDS", "KIND_INSTRUCTIONS", "METRIC_OF_GROUP", "PARTS",
           "VISUALS", "ExportResult", "VisualSettings", "aggregate", "doc_to_text", "doc_to_visual",
           "export_lmms_eval", "frame_indices", "load_task_config", "process_results", "video_path"]
