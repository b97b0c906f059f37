"""``craft-dsl read``: answer CRAFT questions from the videos and the question texts alone (docs/reader.md).

Predictions go to ``--out`` (``{"<video_index>_<question_index>": answer}``, what ``craft-dsl score`` reads), written
atomically once every video is done; progress and messages go to stderr. A video that cannot be read is reported
(``error: ...``), its questions are left out, the others are still written, and the exit code is 2.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..atomic import atomic_path, write_json_atomic
from ..errors import CraftError, ReaderError
from ..parallel import add_workers_option
from .video import DECODERS

if TYPE_CHECKING:
    from .answer import Answer, Question


def read_video(path: str, questions: list[Question], decoder: str = "auto", distribution: bool = False,
               samples: int = 64) -> dict[str, Any]:
    """Perceive one video and answer its questions (the unit of work of ``--workers``)."""
    from .answer import answer_questions
    from .perceive import perceive_video

    t = time.perf_counter()
    try:
        perception = perceive_video(path, decoder)  # type: ignore[arg-type]
        perceived = time.perf_counter()
        answers = answer_questions(perception.scene, questions, distribution, samples)
    except CraftError as err:
        return {"path": path, "error": str(err)}
    done = time.perf_counter()
    return {"path": path, "answers": answers, "scene": perception.scene.dumps(),
            "timings": {**perception.timings, "perception": perceived - t, "answering": done - perceived}}


def cmd_read(args: argparse.Namespace) -> int:
    from .answer import find_videos, read_questions

    questions = read_questions(args.questions)
    by_video: dict[int, list[Question]] = defaultdict(list)
    for q in questions:
        by_video[q.video_index].append(q)
    videos = find_videos(args.videos, sorted(by_video))
    if args.workers < 1:
        raise ReaderError(f"--workers must be at least 1, got {args.workers}")
    jobs = [(str(videos[v]), by_video[v], args.decoder, args.distribution, args.samples) for v in sorted(by_video)]
    workers = min(args.workers, len(jobs))  # no process without a video to read
    results: list[dict[str, Any]] = []
    from tqdm import tqdm

    bar = tqdm(total=len(jobs), unit="video", desc="reading", disable=args.quiet, file=sys.stderr)
    try:
        if workers <= 1:
            for job in jobs:
                results.append(read_video(*job))
                bar.update(1)
        else:  # results in the videos' order, whatever the order they finish in: the same files for any --workers
            with ProcessPoolExecutor(max_workers=workers) as pool:
                for result in pool.map(read_video, *zip(*jobs)):
                    results.append(result)
                    bar.update(1)
    finally:
        bar.close()
    predictions: dict[str, str | None] = {}
    details: list[dict[str, Any]] = []
    failed = []
    perception_s = []
    for result in results:
        if "error" in result:
            failed.append(result["error"])
            continue
        answers: list[Answer] = result["answers"]
        for a in answers:
            predictions[a.question.key] = a.answer
            details.append(a.to_json())
        perception_s.append(result["timings"]["perception"])
        if args.perceived:
            stem = Path(result["path"]).stem
            with atomic_path(Path(args.perceived) / f"{stem}.json") as tmp:
                tmp.write_text(result["scene"], encoding="utf-8")
    write_json_atomic(predictions, args.out)
    if args.details:
        with atomic_path(args.details) as tmp:
            tmp.write_text("".join(json.dumps(d) + "\n" for d in details), encoding="utf-8")
    unanswered = sum(1 for v in predictions.values() if v is None)
    if not args.quiet:
        mean = sum(perception_s) / len(perception_s) if perception_s else 0.0
        read = len(results) - len(failed)
        print(f"wrote {args.out}: {len(predictions)} answers ({unanswered} unanswered) from {read} videos; "
              f"perception {mean:.2f} s per video", file=sys.stderr)
    for message in failed:
        print(f"error: {message}", file=sys.stderr)
    return 2 if failed else 0


def add_commands(sub: Any) -> None:
    """Register ``read``."""
    p = sub.add_parser(
        "read", help="answer CRAFT questions from the videos and the question texts alone",
        description="Perceive each video (layout, statics, objects, the simulation that reproduces it), read each "
                    "question's program from its text and answer it. Reads only the video files and the question "
                    "texts (video_index, question_index, question of each record).",
    )
    p.add_argument("--videos", required=True, help="folder holding <id6>.mpg (or .mp4) videos, searched recursively")
    p.add_argument("--questions", required=True, help="dataset_minimal.json (or any list of question records)")
    p.add_argument("--out", required=True, help='predictions JSON: {"<video_index>_<question_index>": answer}')
    add_workers_option(p, "worker processes (one video at a time each); the output is identical for any number")
    p.add_argument("--perceived", help="also write each video's PerceivedScene JSON into this folder (default: none)")
    p.add_argument("--details", help="also write one JSON line per question (answer, probability, program, error) "
                                     "to this file (default: none)")
    p.add_argument("--distribution", action="store_true",
                   help="answer with the mode of each question's answer distribution and give its probability")
    p.add_argument("--samples", type=int, default=64, help="Monte Carlo readings of an answer distribution")
    p.add_argument("--decoder", choices=DECODERS, default="auto",
                   help="video decoder: PyAV in-process (auto), or imageio-ffmpeg's ffmpeg process")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary")
    p.set_defaults(func=cmd_read)
