"""What re-encoding, rescaling and frame-rate changes cost the video reader: its accuracy on copies of a dataset's
test videos made with ffmpeg, beside its accuracy on the files as generated.

Data: a dataset written by ``craft-dsl generate --videos`` (``--dataset DIR``). The videos read are those of the
test parts of its splits (``split_info_random.json``: the paper's easy split, ``split_info_hard.json``: the hard
one), the questions given to the reader only (video_index, question_index, question) of their test questions, as
``benchmarks/reader.py`` does.

Variants (:data:`VARIANTS`), each written by the ffmpeg of ``imageio_ffmpeg.get_ffmpeg_exe()`` into a folder of its
own as ``<id6>.<ext>``, the names ``craft-dsl read --videos FOLDER`` finds:

* ``original``: the files as generated (MPEG-1 elementary streams, 256x256, 60 fps), read where they are;
* ``h264-crf28``: H.264 (libx264 ``-crf 28``), ``.mp4``;
* ``mpeg4-q8``: MPEG-4 part 2 (``-c:v mpeg4 -q:v 8``), ``.avi``;
* ``scale-128``, ``scale-512``: rescaled (ffmpeg's ``scale`` filter, its default bicubic), lossless H.264;
* ``fps-10``: 10 frames per second by ffmpeg's ``fps=10`` filter (its default ``round=near``), lossless H.264. Its
  frame i (1-based) is the original's frame of step 6i-3 (measured: :func:`step_offsets`), not the renderer's
  convention (``craft_dsl.render.raster.frame_steps``: step round(i * 60 / fps) = 6i);
* ``fps-10-down``: ``fps=10:round=down``, lossless H.264: frame i is the original's frame of step 6i exactly, the
  renderer's convention (``craft-dsl render --fps 10``);
* ``fps-5``: 5 frames per second by ffmpeg's ``fps=5`` filter, lossless H.264: frame i is the original's frame of
  step 12i-6, 6 steps before the renderer's.
* ``range-tv``: a full-range picture squeezed to limited range and read back as full range (``scale=in_range=pc:
  out_range=tv``: white at 235, black at 16), lossless H.264;
* ``grade-strong``: ``eq=gamma=1.5:saturation=0.6`` (lighter mid-tones, paler colours), lossless H.264. The reader
  measures a graded video's colours against the palette and undoes the grading (``craft_dsl.reader.tone``).
* ``crop-8``: cropped by 8 px on every side (``crop=iw-16:ih-16:8:8``: 240x240 from 256), lossless H.264. The reader
  reads it at 256 px, flags it (its wall and ground lines are gone: ``craft_dsl.reader.whole``) and warns on every
  answer; reading a cropped picture at its own scale and offset is not built;
* ``letterbox-16x9``: black bars to 16:9 (``pad=ceil(ih*16/9/2)*2:ih:(ow-iw)/2:0:color=black``: 456x256), lossless
  H.264; the reader finds the picture between the bars (``craft_dsl.reader.picture``);
* ``pad-4x3-gray``: grey bars (``0x808080``) to 4:3 (342x256), lossless H.264.

The reader measures the step offset of a resampled copy (``craft_dsl.reader.timing``); each resampled variant's row
says how many of its videos were read at which offset.

Lossless H.264 (``-qp 0``, yuv420p like the originals) makes the rescaled and resampled copies differ from the
originals by that one change. The reader reads each variant as ``craft-dsl read`` does (its unit of work
``craft_dsl.reader.cli.read_video``, in ``--workers`` processes, default decoder); ffmpeg runs ``--workers``
processes at a time, one thread each. A variant whose encoder this ffmpeg lacks, or whose copies cannot be made, is
reported as failed in the table and skipped; a video the reader cannot read counts its questions as wrong.

Printed (Markdown): per variant, accuracy (%) per test part and paper column (C, CF, D, All) with the difference in
points against ``original``, the questions it answers wrong that ``original`` answers right and the reverse, the
calibration of the answers' confidences over the test questions of both parts (expected calibration error, 10
equal-width bins; the accuracy of the most confident 80%), videos whose layout was identified, fallback answers
(guesses: ``fallback`` in ``craft-dsl read --details``), videos read with a warning (not whole), videos not read,
seconds of perception per video (decoding included) and of encoding per video; then the answers each variant lost
and gained against ``original`` per part and paper column; then the **paired intervals** (:func:`paired_intervals`):
per variant, test part and paper column, the paired difference in points (the variant's accuracy minus
``original``'s on the same questions) with its 95% interval from a bootstrap over videos (:func:`bootstrap_difference`:
the videos resampled with replacement, :data:`RESAMPLES` times from seed :data:`SEED`: the questions of one video are
read from one perception, so they are not independent), as ``diff [lo, hi]``, and a verdict on issue 57's goal: every
interval's lower end above :data:`GOAL_LOW` points in columns C, CF and D of both parts, over at least
:data:`GOAL_QUESTIONS` test questions; then accuracy per paper sub-category
over the test questions of both parts; then what was checked of each variant's first copy (codec, size, frames; the
step offset of resampled frames). ``--json OUT`` writes every figure (the paired intervals as ``paired``), with how
near whole copies come to the
reader's cut-at-the-start warning (:mod:`craft_dsl.reader.whole`): the largest distance of one body, and of a
video's median body, from the run fitted from the layout's start (``start_px_max``, ``start_px_median_max``).
No randomness but the bootstrap's, from a fixed seed: the same inputs give the same figures (timings aside).

Each variant's reading imports ``craft_dsl`` afresh (its worker processes): in a checkout being edited, run it with
``PYTHONPATH`` at a snapshot (``git archive HEAD | tar -x -C SNAP``), or variants are read by different readers.

Run: ``python benchmarks/reader_robustness.py --dataset DIR --workers 2 [--variants a,b] [--videos N] [--keep DIR]
[--json out.json]``. Copies read in runs of their own (one ``--variants`` and ``--json`` each, so that a long
read's figures survive the next one's interruption) print as one table with ``--dataset DIR --tables-from
original.json h264.json ...``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from reader_calibration import ece, risk_coverage

from craft_dsl.errors import CraftError
from craft_dsl.reader.answer import Question, find_videos, read_questions
from craft_dsl.reader.cli import read_video
from craft_dsl.reader.runs import run_tasks
from craft_dsl.reader.video import RUN_STEPS
from craft_dsl.render.raster import frame_steps
from craft_dsl.verify import answers_agree, read_minimal, read_split, score
from craft_dsl.verify.categories import CATEGORIES, FAMILIES, family_of

#: ffmpeg options of lossless H.264 in the originals' pixel format.
LOSSLESS_H264 = ("-c:v", "libx264", "-qp", "0", "-pix_fmt", "yuv420p")
#: The share of the answers, the most confident first, whose accuracy the table gives (risk-coverage).
KEPT = 0.8
#: The test parts read, as (split file stem, the paper's name).
PARTS = (("random", "easy"), ("hard", "hard"))
#: The bootstrap of the paired intervals: resamples of the videos, the generator's seed, the interval's level.
RESAMPLES = 2000
SEED = 0
LEVEL = 0.95
#: Issue 57's goal: every paired interval's lower end above this (points), in each paper column of each test part,
#: over at least this many test questions.
GOAL_LOW = -2.0
GOAL_QUESTIONS = 1000


@dataclass(frozen=True)
class Variant:
    """One way of copying the videos: ffmpeg output options (empty: the files as generated, not copied), the
    container, the encoder it needs, and what its copies hold (``size``, ``fps``: None = as the source; ``crop``:
    pixels cut from each side; ``aspect``: (width, height) the frame is padded to, its height kept)."""

    name: str
    suffix: str
    options: tuple[str, ...]
    encoder: str | None
    codec: str
    size: int | None = None
    fps: float | None = None
    crop: int = 0
    aspect: tuple[int, int] | None = None

    @property
    def copied(self) -> bool:
        return bool(self.options)


VARIANTS: dict[str, Variant] = {v.name: v for v in (
    Variant("original", ".mpg", (), None, "mpeg1video"),
    Variant("h264-crf28", ".mp4", ("-c:v", "libx264", "-crf", "28", "-pix_fmt", "yuv420p"), "libx264", "h264"),
    Variant("mpeg4-q8", ".avi", ("-c:v", "mpeg4", "-q:v", "8"), "mpeg4", "mpeg4"),
    Variant("scale-128", ".mp4", ("-vf", "scale=128:128", *LOSSLESS_H264), "libx264", "h264", size=128),
    Variant("scale-512", ".mp4", ("-vf", "scale=512:512", *LOSSLESS_H264), "libx264", "h264", size=512),
    Variant("fps-10", ".mp4", ("-vf", "fps=10", *LOSSLESS_H264), "libx264", "h264", fps=10),
    Variant("fps-10-down", ".mp4", ("-vf", "fps=10:round=down", *LOSSLESS_H264), "libx264", "h264", fps=10),
    Variant("fps-5", ".mp4", ("-vf", "fps=5", *LOSSLESS_H264), "libx264", "h264", fps=5),
    # graded colours: a full-range picture read as limited range (washed out), and a strong grade (gamma, paler)
    Variant("range-tv", ".mp4", ("-vf", "scale=in_range=pc:out_range=tv", *LOSSLESS_H264), "libx264", "h264"),
    Variant("grade-strong", ".mp4", ("-vf", "eq=gamma=1.5:saturation=0.6", *LOSSLESS_H264), "libx264", "h264"),
    # the picture's geometry: cropped (its border lines cut off), or boxed in bars to another aspect
    Variant("crop-8", ".mp4", ("-vf", "crop=iw-16:ih-16:8:8", *LOSSLESS_H264), "libx264", "h264", crop=8),
    Variant("letterbox-16x9", ".mp4", ("-vf", "pad=ceil(ih*16/9/2)*2:ih:(ow-iw)/2:0:color=black", *LOSSLESS_H264),
            "libx264", "h264", aspect=(16, 9)),
    Variant("pad-4x3-gray", ".mp4", ("-vf", "pad=ceil(ih*4/3/2)*2:ih:(ow-iw)/2:0:color=0x808080", *LOSSLESS_H264),
            "libx264", "h264", aspect=(4, 3)),
)}


class CopyError(Exception):
    """A copy could not be made (the message names the file and ffmpeg's last words)."""


def ffmpeg_exe() -> str:
    """The ffmpeg binary of imageio-ffmpeg (``IMAGEIO_FFMPEG_EXE`` overrides it)."""
    import imageio_ffmpeg

    return str(imageio_ffmpeg.get_ffmpeg_exe())


def encoders(exe: str) -> set[str]:
    """Names of the video encoders ``exe`` has."""
    proc = subprocess.run([exe, "-hide_banner", "-encoders"], capture_output=True, text=True, check=False)
    names = set()
    for line in proc.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and len(parts[0]) == 6 and parts[0].startswith("V"):
            names.add(parts[1])
    return names


def unavailable(variant: Variant, exe: str | None, have: set[str]) -> str | None:
    """Why ``variant`` cannot be made with ``exe`` (None: no ffmpeg found; None returned if it can)."""
    if variant.encoder is None or (exe is not None and variant.encoder in have):
        return None
    if exe is None:
        return "no ffmpeg: imageio-ffmpeg found none; pip install imageio-ffmpeg, or set IMAGEIO_FFMPEG_EXE"
    return (f"{exe} has no {variant.encoder} encoder; point IMAGEIO_FFMPEG_EXE at an ffmpeg built with it "
            f"(`ffmpeg -encoders` lists them)")


def reencode(source: Path, target: Path, variant: Variant, exe: str | None = None) -> Path:
    """Write ``source`` as ``variant`` to ``target`` with one ffmpeg process of one thread; raise CopyError."""
    if not variant.copied:
        raise CopyError(f"{variant.name}: the files as generated are read where they are, not copied")
    exe = exe or ffmpeg_exe()
    fmt = ["-f", "mpegvideo"] if source.suffix.lower() == ".mpg" else []  # as the reader's decoders read .mpg
    cmd = [exe, "-y", "-nostdin", "-loglevel", "error", "-threads", "1", *fmt, "-i", str(source), *variant.options,
           "-threads", "1", "-an", str(target)]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0 or not target.is_file() or target.stat().st_size == 0:
        said = proc.stderr.strip().splitlines()
        raise CopyError(f"{variant.name}: ffmpeg could not write {target.name} from {source} "
                        f"({said[-1] if said else f'exit code {proc.returncode}'})")
    return target


def make_copies(sources: dict[int, Path], variant: Variant, folder: Path, workers: int, exe: str,
                progress: Callable[[int], None] | None = None) -> dict[int, Path]:
    """Copies of ``sources`` (video_index -> file) as ``folder/<id6><suffix>``, ``workers`` ffmpeg processes at a
    time; raise CopyError naming the first failure."""
    folder.mkdir(parents=True, exist_ok=True)
    targets = {v: folder / f"{v:06d}{variant.suffix}" for v in sources}
    with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
        futures = {v: pool.submit(reencode, sources[v], targets[v], variant, exe) for v in sorted(sources)}
        for done, v in enumerate(futures, 1):
            futures[v].result()
            if progress:
                progress(done)
    return targets


def describe(path: Path) -> dict[str, Any]:
    """What a video holds: codec, width, height, frames decoded and frame rate (PyAV's guess from the stream)."""
    import av

    fmt = "mpegvideo" if path.suffix.lower() == ".mpg" else None
    with av.open(str(path), format=fmt) as container:
        stream = container.streams.video[0]
        frames = sum(1 for _ in container.decode(stream))
        rate = float(stream.guessed_rate) if stream.guessed_rate else None  # a raw MPEG-1 stream's average_rate is 25
        return {"codec": stream.codec_context.name, "width": stream.width, "height": stream.height,
                "frames": frames, "fps": rate}


def expected(variant: Variant, source_frames: int, source_size: int) -> dict[str, Any]:
    """What a copy of a video of ``source_frames`` 60 fps frames of ``source_size`` px should hold."""
    size = (variant.size or source_size) - 2 * variant.crop
    width = size if variant.aspect is None else 2 * math.ceil(size * variant.aspect[0] / variant.aspect[1] / 2)
    frames = source_frames if variant.fps is None else len(frame_steps(source_frames, variant.fps))
    return {"codec": variant.codec, "width": width, "height": size, "frames": frames}


def step_offsets(source: Path, copy: Path, fps: float, reach: int | None = None) -> list[int]:
    """For each frame i of ``copy`` (a resampling of the 60 fps ``source``, same size) whose nearest source frame
    (within ``reach`` frames, default the copy's frame spacing) is unambiguous: the step that source frame shows
    minus ``frame_steps``'s step of frame i (0: the renderer's convention). Source frame k (0-based) shows step
    k + 1."""
    from craft_dsl.reader.video import decode

    src = decode(source).astype(np.int16)
    ours = decode(copy).astype(np.int16)
    rows = frame_steps(len(src), fps)
    if reach is None:
        reach = max(int(round(60 / fps)), 1)
    out = []
    for i, frame in enumerate(ours[: len(rows)]):
        k = int(rows[i]) - 1
        near = list(range(max(k - reach, 0), min(k + reach + 1, len(src))))
        errors = np.array([np.abs(src[j] - frame).mean() for j in near])
        best = int(np.argmin(errors))
        if np.sum(errors <= errors[best] + 1e-9) == 1:  # a still scene matches several frames: not counted
            out.append(near[best] - k)
    return out


# -- the dataset's test questions ------------------------------------------------------------------------------


@dataclass
class Suite:
    """The test questions of a dataset (only what the reader is given), the keys of each test part, the videos."""

    root: Path
    questions: list[Question]
    parts: dict[str, set[tuple[int, int]]]
    videos: list[int]
    steps: int = RUN_STEPS  # the run each video shows (generation_config.json's steps)

    def by_video(self) -> dict[int, list[Question]]:
        out: dict[int, list[Question]] = {v: [] for v in self.videos}
        for q in self.questions:
            if q.video_index in out:
                out[q.video_index].append(q)
        return out


def load_suite(root: Path, limit: int | None = None) -> Suite:
    """The test parts of ``root``'s splits, limited to the first ``limit`` videos (by index) if given; raise
    FileNotFoundError naming a missing file."""
    for name in ("dataset_minimal.json", *(f"split_info_{s}.json" for s, _ in PARTS)):
        if not (root / name).is_file():
            raise FileNotFoundError(f"{root / name}: missing; --dataset must be a folder written by "
                                    "craft-dsl generate --videos")
    if not (root / "videos").is_dir():
        raise FileNotFoundError(f"{root / 'videos'}: missing; the dataset was generated without --videos")
    parts = {split: read_split(root / f"split_info_{split}.json", "test") for split, _ in PARTS}
    wanted = set().union(*parts.values())
    raw = json.loads((root / "dataset_minimal.json").read_text())
    stripped = [{k: r[k] for k in ("video_index", "question_index", "question")} for r in raw
                if (r["video_index"], r["question_index"]) in wanted]
    with tempfile.TemporaryDirectory() as tmp:  # read as craft-dsl read reads its questions file
        qfile = Path(tmp) / "questions.json"
        qfile.write_text(json.dumps(stripped))
        questions = read_questions(qfile)
    videos = sorted({q.video_index for q in questions})[:limit] if limit else sorted({q.video_index
                                                                                      for q in questions})
    chosen = set(videos)
    questions = [q for q in questions if q.video_index in chosen]
    parts = {split: {k for k in keys if k[0] in chosen} for split, keys in parts.items()}
    return Suite(root, questions, parts, videos, run_steps(root))


def run_steps(root: Path) -> int:
    """The steps of each run of the dataset at ``root`` (its ``generation_config.json``; CRAFT's 600 without one)."""
    config = root / "generation_config.json"
    if not config.is_file():
        return RUN_STEPS
    return int(json.loads(config.read_text()).get("steps", RUN_STEPS))


# -- reading a variant ------------------------------------------------------------------------------------------


def read_variant(paths: dict[int, Path], tests: Suite, workers: int) -> dict[int, dict[str, Any]]:
    """Each video read as ``craft-dsl read`` reads it: video_index -> {answers, fallback, warning, perception_s,
    scene, frame_offset, start_px} or {error}."""
    by_video = tests.by_video()
    jobs = [(v, (str(paths[v]), by_video[v])) for v in tests.videos]
    out: dict[int, dict[str, Any]] = {}

    def finished(index: int, result: dict[str, Any]) -> None:
        if "error" in result:
            out[index] = {"error": result["error"]}
        else:
            perceived = json.loads(result["scene"])
            out[index] = {"answers": {a.question.key: a.answer for a in result["answers"]},
                          "confidence": {a.question.key: a.confidence for a in result["answers"]
                                         if a.confidence is not None},
                          "fallback": sum(a.fallback for a in result["answers"]),
                          "warning": result.get("warning"), "perception_s": result["timings"]["perception"],
                          "scene": perceived.get("scene"),
                          "frame_offset": int((perceived.get("meta") or {}).get("frame_offset", 0)),
                          "start_px": sorted(float(d) for d in
                                             ((perceived.get("meta") or {}).get("start_px") or {}).values())}
        print(f"\r  read {len(out)}/{len(jobs)} videos", end="", file=sys.stderr, flush=True)

    def crashed(index: int, message: str) -> None:
        out[index] = {"error": f"video {index} ({paths[index]}): {message}"}

    run_tasks(partial(read_video, steps=tests.steps), jobs, max(1, min(workers, len(jobs))), finished, crashed)
    print(file=sys.stderr)
    return out


def true_scenes(tests: Suite) -> dict[int, int]:
    """The layout (1-20) of each test video, from ``questions/qa_<id6>.json`` (the benchmark's side)."""
    out = {}
    for v in tests.videos:
        path = tests.root / "questions" / f"qa_{v:06d}.json"
        if path.is_file():
            out[v] = json.loads(path.read_text())["stats"]["scene"]
    return out


def figures(results: dict[int, dict[str, Any]], tests: Suite, scenes: dict[int, int]) -> dict[str, Any]:
    """Accuracy per part (paper columns, sub-categories) and the reader's own counts for one variant. A video not
    read counts its questions as wrong (``missing`` in the scores)."""
    predictions = {tuple(map(int, key.split("_"))): (a if a is not None else "None") for r in results.values()
                   for key, a in r.get("answers", {}).items()}
    minimal = read_minimal(tests.root / "dataset_minimal.json")
    out: dict[str, Any] = {"parts": {}}
    for split, _ in PARTS:
        out["parts"][split] = score(minimal, predictions, split=tests.parts[split]).to_json()
    out["both"] = score(minimal, predictions, split=set().union(*tests.parts.values())).to_json()
    keys = set().union(*tests.parts.values())
    out["correct"] = {f"{q.key[0]}_{q.key[1]}": q.key in predictions and answers_agree(predictions[q.key], q.answer)
                      for q in minimal if q.key in keys}
    confidence = {k: c for r in results.values() for k, c in r.get("confidence", {}).items()}
    rated = [(confidence[k], ok) for k, ok in out["correct"].items() if k in confidence]
    out["calibration"] = calibration([c for c, _ in rated], [ok for _, ok in rated])
    read = [r for r in results.values() if "error" not in r]
    out.update(
        videos=len(results), not_read=len(results) - len(read),
        errors=[r["error"] for r in results.values() if "error" in r],
        fallback=sum(r["fallback"] for r in read), warnings=sum(r["warning"] is not None for r in read),
        layout_ok=sum(scenes.get(v) == r.get("scene") for v, r in results.items() if "error" not in r),
        layout_known=sum(v in scenes for v, r in results.items() if "error" not in r),
        perception_s=float(np.mean([r["perception_s"] for r in read])) if read else None,
        frame_offsets={str(k): n for k, n in sorted(Counter(r.get("frame_offset", 0) for r in read).items())},
        # how near whole videos come to the reader's cut-at-the-start warning (craft_dsl.reader.whole): the largest
        # distance of one body, and of a video's median body, from the run fitted from the layout's start
        start_px_max=max((max(r["start_px"]) for r in read if r.get("start_px")), default=None),
        start_px_median_max=max((float(np.median(r["start_px"])) for r in read if r.get("start_px")), default=None),
    )
    return out


def calibration(confidence: list[float], correct: list[bool]) -> dict[str, Any]:
    """The answers' stated confidences against their correctness: expected calibration error (10 equal-width bins),
    mean confidence, and the accuracy of the most confident :data:`KEPT` of the answers (risk-coverage)."""
    if not confidence:
        return {"answers": 0, "ece": None, "mean_confidence": None, "kept_accuracy": None}
    (_, _, kept), = risk_coverage(confidence, correct, (KEPT,))
    return {"answers": len(confidence), "ece": ece(confidence, correct),
            "mean_confidence": float(np.mean(confidence)), "kept_accuracy": kept * 100}


# -- the table -------------------------------------------------------------------------------------------------


def _cell(value: float | None, base: float | None) -> str:
    if value is None:
        return "-"
    if base is None:
        return f"{value:.1f}"
    return f"{value:.1f} ({value - base:+.1f})"


def paired_difference(base: dict[str, bool], other: dict[str, bool], keys: Iterable[str]
                      ) -> tuple[int, int, float, float, float]:
    """Answers ``other`` lost and gained against ``base`` over ``keys`` (both judge the same questions), the
    difference in points and its 95% interval (normal approximation for paired proportions: the spread comes from
    the questions that changed, taken as independent; the tables print :func:`bootstrap_difference`'s interval,
    which resamples videos)."""
    chosen = [k for k in keys if k in base]
    n = len(chosen)
    lost = sum(base[k] and not other.get(k, False) for k in chosen)
    gained = sum(not base[k] and other.get(k, False) for k in chosen)
    if n == 0:
        return lost, gained, 0.0, 0.0, 0.0
    diff = (gained - lost) / n
    half = 1.96 * math.sqrt(max(gained + lost - (gained - lost) ** 2 / n, 0.0)) / n
    return lost, gained, 100 * diff, 100 * (diff - half), 100 * (diff + half)


def bootstrap_difference(base: dict[str, bool], other: dict[str, bool], keys: Iterable[str],
                         resamples: int = RESAMPLES, seed: int = SEED, level: float = LEVEL
                         ) -> tuple[float, float, float]:
    """The paired difference in points of ``other``'s accuracy minus ``base``'s over ``keys`` (``"<video>_<question>"``;
    keys ``base`` lacks are left out, a key ``other`` lacks is a wrong answer) and its ``level`` interval from a
    bootstrap over videos: the videos (with all their questions) drawn with replacement ``resamples`` times from
    ``numpy.random.default_rng(seed)``, each draw's difference its questions' changes over its questions, the
    interval the draws' percentiles. The questions of one video share its perception, so their changes are not
    independent: resampling questions would make the interval too narrow. (0, 0, 0) where no key is judged."""
    changes: dict[str, list[int]] = {}
    for k in keys:
        if k in base:
            changes.setdefault(k.split("_")[0], []).append(int(other.get(k, False)) - int(base[k]))
    if not changes:
        return 0.0, 0.0, 0.0
    delta = np.array([sum(c) for c in changes.values()], dtype=np.float64)  # per video: answers gained - lost
    count = np.array([len(c) for c in changes.values()], dtype=np.float64)  # per video: questions
    diff = 100 * float(delta.sum() / count.sum())
    draws = np.random.default_rng(seed).integers(0, len(delta), size=(resamples, len(delta)))
    sampled = 100 * delta[draws].sum(axis=1) / count[draws].sum(axis=1)
    tail = 100 * (1 - level) / 2
    low, high = np.percentile(sampled, [tail, 100 - tail])
    return diff, float(low), float(high)


def _families(tests: Suite) -> dict[str, str]:
    """The paper column of each question of ``tests``' dataset, by ``"<video>_<question>"``."""
    return {f"{q.video_index}_{q.question_index}": family_of(q.template_id)
            for q in read_minimal(tests.root / "dataset_minimal.json")}


def paired_intervals(rows: dict[str, dict[str, Any]], tests: Suite) -> dict[str, Any]:
    """Every variant's paired differences against ``original`` (:func:`bootstrap_difference`) per test part and
    paper column (C, CF, D, All): {variant: {"parts": {split: {column: {diff, low, high, lost, gained, questions,
    videos}}}, "goal_met", "short"}}, ``short``: the cells of C, CF and D whose interval's lower end is not above
    :data:`GOAL_LOW`; ``goal_met``: none is, over at least :data:`GOAL_QUESTIONS` questions. Empty without
    ``original`` or another variant read."""
    base = rows.get("original", {}).get("figures")
    others = [(n, r["figures"]) for n, r in rows.items() if n != "original" and r.get("figures")
              and "reason" not in r]
    if base is None or not others:
        return {}
    family = _families(tests)
    questions = len(set().union(*tests.parts.values()))
    out: dict[str, Any] = {}
    for name, fig in others:
        parts: dict[str, Any] = {}
        short = []
        for split, paper in PARTS:
            if not tests.parts[split]:
                continue
            keys = [f"{v}_{q}" for v, q in sorted(tests.parts[split])]
            cells = {}
            for col in (*FAMILIES, "All"):
                chosen = [k for k in keys if col == "All" or family.get(k) == col]
                lost, gained, *_ = paired_difference(base["correct"], fig["correct"], chosen)
                diff, low, high = bootstrap_difference(base["correct"], fig["correct"], chosen)
                judged = [k for k in chosen if k in base["correct"]]
                cells[col] = {"diff": diff, "low": low, "high": high, "lost": lost, "gained": gained,
                              "questions": len(judged), "videos": len({k.split("_")[0] for k in judged})}
                if col != "All" and judged and low <= GOAL_LOW:
                    short.append(f"{paper} {col}")
            parts[split] = cells
        out[name] = {"parts": parts, "short": short, "goal_met": not short and questions >= GOAL_QUESTIONS}
    return out


def paired_lines(rows: dict[str, dict[str, Any]], tests: Suite) -> list[str]:
    """Two tables against ``original``, per part and paper column: every variant's answers lost and gained, and its
    paired differences with their 95% intervals from the bootstrap over videos (:func:`paired_intervals`), with the
    verdict on the goal (every lower end of C, CF and D above :data:`GOAL_LOW` points)."""
    found = paired_intervals(rows, tests)
    if not found:
        return []
    parts = [(split, paper) for split, paper in PARTS if tests.parts[split]]
    cols = (*FAMILIES, "All")
    head = "| variant | " + " | ".join(f"{paper} {c}" for _s, paper in parts for c in cols)
    rule = "|" + "---|" * (1 + len(parts) * len(cols))
    lines = ["", "Against original, the same questions: answers lost / gained:", "", head + " |", rule]
    for name, found_row in found.items():
        counts = [found_row["parts"][s][c] for s, _p in parts for c in cols]
        lines.append(f"| {name} | " + " | ".join(f"-{n['lost']} +{n['gained']}" for n in counts) + " |")
    questions = len(set().union(*tests.parts.values()))
    videos = len(tests.videos)
    too_few = (f"; only {questions} test questions, the goal asks {GOAL_QUESTIONS:,}" if questions < GOAL_QUESTIONS
               else "")
    lines += ["", f"Paired differences against original, points (variant minus original on the same questions) "
                  f"[{LEVEL:.0%} interval: bootstrap over the {videos} videos, {RESAMPLES} resamples, seed {SEED}]; "
                  f"goal: every lower end of C, CF and D above {GOAL_LOW:+g} points{too_few}:", "",
              head + " | goal |", rule + "---|"]
    for name, found_row in found.items():
        cells = []
        for split, _paper in parts:
            for col in cols:
                cell = found_row["parts"][split][col]
                cells.append(f"{cell['diff']:+.1f} [{cell['low']:+.1f}, {cell['high']:+.1f}]")
        if found_row["short"]:
            verdict = "not met: " + ", ".join(found_row["short"])
        else:
            verdict = "met" if found_row["goal_met"] else "met on these questions (too few)"
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {verdict} |")
    return lines


def table(rows: dict[str, dict[str, Any]], tests: Suite) -> str:
    """The Markdown tables of every variant's figures (differences in points against ``original`` if it ran)."""
    base = rows.get("original", {}).get("figures")
    parts = [(split, paper) for split, paper in PARTS if tests.parts[split]]
    head = ["variant"]
    for _split, paper in parts:
        head += [f"{paper} {col}" for col in (*FAMILIES, "All")]
    head += ["right→wrong / wrong→right vs original", "ECE", f"% right, most confident {KEPT:.0%}", "layout ok",
             "fallback answers", "warnings", "videos not read",
             "perception s/video", "encode s/video"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, row in rows.items():
        fig = row.get("figures")
        if fig is None or "reason" in row:
            lines.append(f"| {name} | failed: {row['reason']} |" + " |" * (len(head) - 2))
            continue
        cells = [name]
        for split, _ in parts:
            acc = fig["parts"][split]["accuracy"]
            ref = base["parts"][split]["accuracy"] if base is not None and name != "original" else {}
            cells += [_cell(acc[c], ref.get(c)) for c in (*FAMILIES, "All")]
        if base is not None and name != "original":
            lost, gained, *_ = paired_difference(base["correct"], fig["correct"], base["correct"])
            cells.append(f"{lost} / {gained}")
        else:
            cells.append("-")
        cal = fig.get("calibration") or {}
        cells += [f"{cal['ece']:.3f}" if cal.get("ece") is not None else "-",
                  f"{cal['kept_accuracy']:.1f}" if cal.get("kept_accuracy") is not None else "-"]
        cells += [f"{fig['layout_ok']}/{fig['layout_known']}", str(fig["fallback"]), str(fig["warnings"]),
                  str(fig["not_read"]),
                  f"{fig['perception_s']:.2f}" if fig["perception_s"] is not None else "-",
                  f"{row['encode_s_per_video']:.2f}" if row.get("encode_s_per_video") is not None else "-"]
        lines.append("| " + " | ".join(cells) + " |")
    # sub-categories, the test questions of both parts
    lines += paired_lines(rows, tests)
    both = next((r["figures"]["both"] for r in rows.values() if r.get("figures")), None)
    if both is None:
        return "\n".join(lines)
    cats = [c for c in CATEGORIES if c in both["per_category"]]
    lines += ["", f"Per paper sub-category, the test questions of both parts ({both['questions']}), % (points "
                  "against original):", "",
              "| variant | " + " | ".join(f"{c} ({both['per_category'][c]['total']})" for c in cats) + " |",
              "|" + "---|" * (len(cats) + 1)]
    for name, row in rows.items():
        fig = row.get("figures")
        if fig is None or "reason" in row:
            continue
        ref = base["both"]["per_category"] if base is not None and name != "original" else {}
        lines.append(f"| {name} | " + " | ".join(
            _cell(fig["both"]["per_category"][c]["accuracy"], (ref.get(c) or {}).get("accuracy")) for c in cats)
            + " |")
    return "\n".join(lines)


# -- main ------------------------------------------------------------------------------------------------------


def check_copy(source: Path, copy: Path, variant: Variant) -> dict[str, Any]:
    """What a variant's copy of ``source`` holds against what it should; for a resampled copy, the step offsets
    of its frames (:func:`step_offsets`) counted."""
    src = describe(source)
    found = describe(copy)
    want = expected(variant, src["frames"], src["width"])
    out: dict[str, Any] = {"found": found, "expected": want,
                           "problems": [f"{k} {found[k]} (expected {want[k]})" for k in want if found[k] != want[k]]}
    if variant.fps is not None and variant.size is None and variant.copied:
        offsets = step_offsets(source, copy, variant.fps)
        counts = {str(k): n for k, n in sorted({o: offsets.count(o) for o in offsets}.items())}
        out["step_offsets"] = counts
    return out


def run_variant(variant: Variant, tests: Suite, sources: dict[int, Path], folder: Path, workers: int,
                exe: str | None, have: set[str], scenes: dict[int, int]) -> dict[str, Any]:
    """Copy (unless ``original``) and read one variant: {figures, encode_s_per_video, check} or {reason}."""
    row: dict[str, Any] = {"variant": variant.name, "options": list(variant.options), "suffix": variant.suffix}
    why = unavailable(variant, exe, have)
    if why is not None:
        return {**row, "reason": why}
    first = tests.videos[0]
    if variant.copied and exe is not None:
        t = time.perf_counter()
        try:
            paths = make_copies(sources, variant, folder, workers, exe, lambda n: print(
                f"\r  encoded {n}/{len(sources)} videos", end="", file=sys.stderr, flush=True))
        except CopyError as err:
            print(file=sys.stderr)
            return {**row, "reason": str(err)}
        print(file=sys.stderr)
        row["encode_s_per_video"] = (time.perf_counter() - t) * max(1, min(workers, len(sources))) / len(sources)
        try:
            found = find_videos([folder], tests.videos)  # the names craft-dsl read --videos FOLDER finds
        except CraftError as err:
            return {**row, "reason": f"the reader does not find the copies: {err}"}
        if found != paths:
            return {**row, "reason": f"the reader finds other files in {folder} than the copies"}
    else:
        paths = sources
    try:
        row["check"] = check_copy(sources[first], paths[first], variant)
    except Exception as err:  # noqa: BLE001 - PyAV's own errors; the reader's reading below says more
        row["check"] = {"error": f"{paths[first]}: {type(err).__name__}: {err}"}
    t = time.perf_counter()
    results = read_variant(paths, tests, workers)
    row["read_s"] = time.perf_counter() - t
    fig = figures(results, tests, scenes)
    row["figures"] = fig
    if fig["not_read"] == fig["videos"]:
        return {**row, "reason": f"no video read: {fig['errors'][0] if fig['errors'] else '?'}"}
    return row


def saved_rows(paths: Sequence[Path], videos: Sequence[int]) -> dict[str, dict[str, Any]]:
    """The variants' rows of earlier runs' ``--json`` files, in the order given; raise ValueError naming a file that
    is not such a run, was made on other test videos, or repeats a variant."""
    rows: dict[str, dict[str, Any]] = {}
    for path in paths:
        try:
            saved = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as err:
            raise ValueError(f"{path}: cannot be read as a --json file of this benchmark: {err}") from err
        if not isinstance(saved, dict) or not isinstance(saved.get("variants"), dict):
            raise ValueError(f"{path}: not a --json file of this benchmark (it has no 'variants')")
        if saved.get("videos") != list(videos):
            raise ValueError(f"{path}: made on other test videos ({len(saved.get('videos') or [])}) than the "
                             f"dataset's ({len(videos)}); give --dataset and --videos as that run had them")
        for name, row in saved["variants"].items():
            if name in rows:
                raise ValueError(f"{path}: variant {name} is in an earlier file too; give each variant once")
            rows[name] = row
    return rows


def print_saved_tables(root: Path, paths: Sequence[Path], limit: int | None,
                       parser: argparse.ArgumentParser) -> int:
    """Print the tables of the runs saved in ``paths`` (``--tables-from``) as one run of them all would."""
    try:
        tests = load_suite(root, limit)
        rows = saved_rows(paths, tests.videos)
    except (FileNotFoundError, CraftError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if "original" not in rows:
        parser.error("--tables-from: no file holds the variant 'original', against which the others are counted")
    print(f"{root}: {len(tests.videos)} test videos; the runs of {', '.join(str(p) for p in paths)}\n")
    print(table({"original": rows.pop("original"), **rows}, tests))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", required=True, help="a dataset folder written by craft-dsl generate --videos")
    parser.add_argument("--variants", default=",".join(VARIANTS),
                        help=f"comma list of variants (default all: {','.join(VARIANTS)})")
    parser.add_argument("--videos", type=int, help="only the first N test videos (by index), for quick runs")
    parser.add_argument("--workers", type=int, default=2, help="reader processes and ffmpeg processes (default 2)")
    parser.add_argument("--keep", help="write the copies into DIR/<variant>/ and keep them (default: temporary "
                                       "folders, each removed once its variant is read)")
    parser.add_argument("--json", help="write every figure here")
    parser.add_argument("--tables-from", nargs="+", metavar="JSON",
                        help="read nothing: print the tables of earlier runs' --json files together (each copy read "
                             "in a run of its own, points against the original of one of them), for --dataset")
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.variants.split(",") if n.strip()]
    unknown = [n for n in names if n not in VARIANTS]
    if unknown or not names:
        parser.error(f"--variants: unknown {', '.join(unknown) or '(none given)'}; known: {', '.join(VARIANTS)}")
    if args.videos is not None and args.videos < 1:
        parser.error("--videos must be at least 1")
    if args.workers < 1:
        parser.error("--workers must be at least 1")
    root = Path(args.dataset)
    if not root.is_dir():
        parser.error(f"--dataset {root}: no such folder")
    if args.tables_from:
        return print_saved_tables(root, [Path(p) for p in args.tables_from], args.videos, parser)
    try:
        tests = load_suite(root, args.videos)
        if not tests.videos:
            parser.error(f"--dataset {root}: its test parts hold no questions")
        sources = find_videos(root / "videos", tests.videos)
    except (FileNotFoundError, CraftError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    try:
        exe: str | None = ffmpeg_exe()
    except RuntimeError:  # imageio-ffmpeg has no binary for this platform and none is installed
        exe = None
    have = encoders(exe) if exe is not None else set()
    scenes = true_scenes(tests)
    keep = Path(args.keep) if args.keep else None
    if keep is not None:
        keep.mkdir(parents=True, exist_ok=True)
        (keep / "questions.json").write_text(json.dumps(
            [{"video_index": q.video_index, "question_index": q.question_index, "question": q.text}
             for q in tests.questions]))
    rows: dict[str, dict[str, Any]] = {}
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    for name in names:
        variant = VARIANTS[name]
        print(f"{name}:", file=sys.stderr)
        if keep is not None:
            folder = keep / name
            if variant.copied and folder.exists():
                shutil.rmtree(folder)
        else:
            folder = Path(tempfile.mkdtemp(prefix=f"craft-robustness-{name}-"))
        try:
            rows[name] = run_variant(variant, tests, sources, folder, args.workers, exe, have, scenes)
        except Exception as err:  # noqa: BLE001 - one variant's failure is reported in its row; the others go on
            rows[name] = {"variant": name, "reason": f"{type(err).__name__}: {err}"}
        finally:
            if keep is None:
                shutil.rmtree(folder, ignore_errors=True)
        if "reason" in rows[name]:
            print(f"  {name} failed: {rows[name]['reason']}", file=sys.stderr)
    elapsed = time.perf_counter() - t0
    load_after = os.getloadavg()[0]
    counts = ", ".join(f"{paper} {len(tests.parts[split])}" for split, paper in PARTS)
    lines = [f"{root}: {len(tests.videos)} test videos, questions: {counts}; {args.workers} workers, "
             f"{elapsed:.0f} s; load average {load_before:.1f} before, {load_after:.1f} after",
             "", table(rows, tests), "", "Videos checked (the first test video of each variant):", ""]
    for name, row in rows.items():
        check = row.get("check")
        if check is None:
            continue
        if "error" in check:
            lines.append(f"* {name}: cannot be described: {check['error']}")
            continue
        found = check["found"]
        note = (f"{found['codec']} {found['width']}x{found['height']}, {found['frames']} frames"
                + (f" at {found['fps']:g} fps" if found.get("fps") else "")
                + (f"; NOT AS EXPECTED: {'; '.join(check['problems'])}" if check["problems"] else ""))
        if "step_offsets" in check:
            note += ("; step shown minus frame_steps' step (frames: count): "
                     + ", ".join(f"{k}: {n}" for k, n in check["step_offsets"].items()))
            offsets = row.get("figures", {}).get("frame_offsets")
            if offsets:
                note += ("; the reader's measured offset (videos: count): "
                         + ", ".join(f"{k}: {n}" for k, n in offsets.items()))
        lines.append(f"* {name}: {note}")
    for name, row in rows.items():
        errors = row.get("figures", {}).get("errors") or []
        if errors and "reason" not in row:
            lines.append(f"* {name}: {len(errors)} videos not read, e.g. {errors[0]}")
    if keep is not None:
        lines += ["", f"Copies kept in {keep}/<variant>/; read one again with: craft-dsl read --videos "
                      f"{keep}/<variant> --questions {keep}/questions.json --out predictions.json"]
    print("\n".join(lines))
    if args.json:
        Path(args.json).write_text(json.dumps({"dataset": str(root), "videos": tests.videos, "workers": args.workers,
                                               "ffmpeg": exe, "elapsed_s": elapsed, "load": [load_before, load_after],
                                               "parts": {s: len(k) for s, k in tests.parts.items()},
                                               "variants": rows, "paired": paired_intervals(rows, tests),
                                               "bootstrap": {"resamples": RESAMPLES, "seed": SEED, "level": LEVEL,
                                                             "unit": "video", "goal_low_points": GOAL_LOW,
                                                             "goal_questions": GOAL_QUESTIONS}},
                                              indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
