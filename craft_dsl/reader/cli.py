"""``craft-dsl read``: answer CRAFT questions from the videos and the question texts alone (docs/reader.md).

Predictions go to ``--out`` (``{"<video_index>_<question_index>": answer}``, what ``craft-dsl score`` reads: answers
only, as published predictions files are); each answer's confidence goes to ``--details``. Each
finished video's answers are first made durable in a journal beside it (:mod:`craft_dsl.reader.runs`); ``--out``
and ``--details`` are written atomically from the journal once every video is done, the same bytes for any
``--workers``, for local processes or a Dask cluster (``--executor dask``), and whether or not the run was
interrupted and resumed. Progress and messages go to stderr. A video that cannot be read, or whose reading raises,
is reported (``error: ...``), its questions are left out, the others are still written, and the exit code is 2.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, ExitStack, nullcontext
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..atomic import atomic_path, write_json_atomic
from ..errors import CraftError, ReaderError
from ..parallel import add_workers_option
from .video import DECODERS, RUN_STEPS
from .votes import VOTES

if TYPE_CHECKING:
    from .answer import Answer, Question

#: ``--engine``: ``auto`` and :data:`~craft_dsl.reader.reconstruct.READER_ENGINES` (spelled out here: the command line
#: is built without importing the reconstruction; a test holds the two together).
ENGINE_CHOICES = ("auto", "box2d", "pymunk")


def read_video(path: str, questions: list[Question], decoder: str = "auto", distribution: bool = False,
               samples: int = 64, votes: int = VOTES, steps: int = RUN_STEPS, engine: str = "auto",
               first_engine: str | None = None) -> dict[str, Any]:
    """Perceive one video and answer its questions (the unit of work of ``--workers``); ``votes``: perturbed
    replays per counterfactual question (:mod:`craft_dsl.reader.votes`); ``steps``: the run's length, against which
    the video is checked for being whole (:mod:`craft_dsl.reader.whole`); ``engine``: the physics the video was made
    with, reconstructed with alone (``"auto"``: the reader's choice, :func:`~craft_dsl.reader.reconstruct.
    reader_engines`, trying ``first_engine`` first: the engine its dataset names)."""
    from .answer import answer_questions
    from .perceive import perceive_video
    from .whole import why_not_whole

    t = time.perf_counter()
    try:
        perception = perceive_video(path, decoder, engines=None if engine == "auto" else (engine,),  # type: ignore[arg-type]
                                    first_engine=first_engine)
        perceived = time.perf_counter()
        answers = answer_questions(perception.scene, questions, distribution, samples, votes=votes)
    except CraftError as err:
        return {"path": path, "error": str(err)}
    done = time.perf_counter()
    result: dict[str, Any] = {"path": path, "answers": answers, "scene": perception.scene.dumps(),
                              "timings": {**perception.timings, "perception": perceived - t,
                                          "answering": done - perceived}}
    why = why_not_whole(path, perception, steps)
    if why is not None:  # read all the same, and every answer says so (its confidence at most a guess's)
        from .confidence import rescore

        result["warning"] = f"the video is not whole: {why}"
        result["answers"] = [rescore(replace(a, warning=result["warning"])) for a in answers]
    return result


def dataset_engine(paths: Sequence[str]) -> str | None:
    """The engine the videos' dataset was generated with, where a ``generation_config.json`` says it: in the folder
    of the questions file or of a video folder, or the folder above (``DATASET/videos``); the first path that has
    one decides. ``None`` where none does."""
    from ..dataset.pipeline import recorded_engine

    for given in paths:
        path = Path(given).resolve()
        folder = path if path.is_dir() else path.parent
        for candidate in (folder, folder.parent):
            if (candidate / "generation_config.json").is_file():
                return recorded_engine(candidate)
    return None


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse output paths that could only fail once every video is read."""
    for option, value in (("--out", args.out), ("--details", args.details)):
        if value and Path(value).is_dir():
            raise ReaderError(f"{option} {value}: is a folder; expected a file to write")
    if args.details and Path(args.details).resolve() == Path(args.out).resolve():
        raise ReaderError(f"--details {args.details}: the same file as --out; give another")
    if args.perceived and Path(args.perceived).exists() and not Path(args.perceived).is_dir():
        raise ReaderError(f"--perceived {args.perceived}: is a file; expected a folder")


def _perceived_file(folder: str, index: int) -> Path:
    return Path(folder) / f"{index:06d}.json"


def _resumable(record: dict[str, Any], perceived: str | None) -> bool:
    """Whether a journal record stands for its video: with ``--perceived``, only if that video's scene file is there,
    as the record's run wrote it."""
    if perceived is None:
        return True
    from .runs import text_digest

    try:
        text = _perceived_file(perceived, record["video"]).read_text(encoding="utf-8")
    except (OSError, UnicodeError):
        return False
    return record.get("perceived") == text_digest(text)


def _cluster(scheduler: str | None) -> AbstractContextManager[Any]:
    """The Dask client of ``--scheduler`` for the block (:mod:`craft_dsl.cluster`), or None: local processes."""
    if scheduler is None:
        return nullcontext()
    from ..cluster import cluster_client

    return cluster_client(scheduler)


def cmd_read(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from .answer import find_videos, read_questions
    from .runs import Journal, check_workers, journal_path, run_header, run_tasks, text_digest
    if not args.videos and not args.video_map:
        raise ReaderError("give the videos: --videos FOLDER_OR_FILE ... and/or --video-map FILE")
    _check_outputs(args)
    if args.executor == "dask":  # the extra and the options, before anything is read
        from ..cluster import import_distributed

        import_distributed()
        if not args.scheduler:
            raise ReaderError("--executor dask needs --scheduler tcp://HOST:PORT (the address 'dask scheduler' "
                              "prints); on one machine, --workers N reads as many videos at once without Dask")
    elif args.scheduler:
        raise ReaderError("--scheduler is for --executor dask")
    from .reconstruct import reader_engines

    if args.engine != "auto" and args.engine not in reader_engines():
        raise ReaderError(f"--engine {args.engine}: Box2D is not installed (pip install 'craft-dsl[reader]'); "
                          f"installed: {', '.join(reader_engines())}")
    questions = read_questions(args.questions)
    first = None if args.engine != "auto" else dataset_engine([args.questions, *(args.videos or [])])
    by_video: dict[int, list[Question]] = defaultdict(list)
    for q in questions:
        by_video[q.video_index].append(q)
    order = sorted(by_video)
    videos = find_videos(args.videos or [], order, args.video_map)
    header = run_header(((q.video_index, q.question_index, q.text) for q in questions), videos,
                        {"distribution": args.distribution, "samples": args.samples, "decoder": args.decoder,
                         "votes": args.votes, "steps": args.steps, "engine": args.engine, "first_engine": first})
    failed: dict[int, str] = {}

    def report(message: str) -> None:
        tqdm.write(message, file=sys.stderr)

    with ExitStack() as stack:
        # the cluster first: a scheduler that does not answer, or workers that cannot read the videos, leave no
        # journal behind
        client = stack.enter_context(_cluster(args.scheduler if args.executor == "dask" else None))
        if client is not None:
            videos = {v: path.absolute() for v, path in videos.items()}  # the workers' working folder is not ours
            workers = check_workers(client, videos[order[0]]) if order else 0
            if not args.quiet:
                report(f"reading on the Dask cluster at {args.scheduler}: " + (
                    f"{workers} worker{'s' if workers > 1 else ''}" if workers else "no worker has joined yet; the "
                    "videos wait for them"))
        journal = stack.enter_context(Journal.open(journal_path(args.out), header))
        if journal.dropped_line is not None and not args.quiet:
            report(f"{journal.path}: line {journal.dropped_line} was cut short (the run was stopped while writing "
                   "it): dropped, its video is read again")
        done = {v for v, record in journal.records.items() if v in by_video and _resumable(record, args.perceived)}
        if done and not args.quiet:
            report(f"resuming {journal.path}: {len(done)} of {len(order)} videos already read")
        jobs = [(v, (str(videos[v]), by_video[v], args.decoder, args.distribution, args.samples, args.votes,
                     args.steps, args.engine, first)) for v in order if v not in done]

        def finished(index: int, result: dict[str, Any]) -> None:
            if "error" in result:
                failed[index] = result["error"]
                report(f"error: {result['error']}")
            else:
                if "warning" in result:
                    report(f"warning: video {index} ({result['path']}): {result['warning']}")
                answers: list[Answer] = result["answers"]
                record: dict[str, Any] = {"video": index, "path": result["path"],
                                          "details": [a.to_json() for a in answers],
                                          "perception_s": round(result["timings"]["perception"], 3)}
                if args.perceived:  # the file first: a record in the journal means its file is written
                    with atomic_path(_perceived_file(args.perceived, index)) as tmp:
                        tmp.write_text(result["scene"], encoding="utf-8")
                    record["perceived"] = text_digest(result["scene"])
                journal.add(record)
            bar.update(1)

        def crashed(index: int, message: str) -> None:
            failed[index] = f"video {index} ({videos[index]}): {message}"
            report(f"error: {failed[index]}")
            bar.update(1)

        bar = tqdm(total=len(order), initial=len(done), unit="video", desc="reading", disable=args.quiet,
                   file=sys.stderr, dynamic_ncols=True)
        try:
            if client is not None:
                from ..cluster import run_on_cluster

                run_on_cluster(client, read_video, jobs, finished, crashed)
            else:  # one video left is read here: no process to start
                run_tasks(read_video, jobs, min(args.workers, len(jobs)), finished, crashed)
        finally:
            bar.close()
        predictions: dict[str, str | None] = {}
        details: list[dict[str, Any]] = []
        perception_s = []
        for v in order:
            if v in failed or v not in journal.records:
                continue
            record = journal.records[v]
            for d in record["details"]:
                predictions[f"{d['video_index']}_{d['question_index']}"] = d["answer"]
                details.append(d)
            perception_s.append(record.get("perception_s", 0.0))
        write_json_atomic(predictions, args.out)
        if args.details:
            with atomic_path(args.details) as tmp:
                tmp.write_text("".join(json.dumps(d) + "\n" for d in details), encoding="utf-8")
        journal.remove()
    unanswered = sum(1 for v in predictions.values() if v is None)
    guessed = sum(1 for d in details if d.get("fallback"))
    premised = sum(1 for d in details if d.get("premise"))
    partial = len({d["video_index"] for d in details if d.get("warning")})
    if not args.quiet:
        mean = sum(perception_s) / len(perception_s) if perception_s else 0.0
        print(f"wrote {args.out}: {len(predictions)} answers ({unanswered} unanswered, {guessed} guessed: "
              f"'fallback' in --details"
              + (f"; {premised} on the reading their question names, 'premise'" if premised else "")
              + f") from {len(perception_s)} "
              f"videos; perception {mean:.2f} s per video"
              + (f"; {partial} videos not whole (their answers carry a 'warning')" if partial else "")
              + (f"; {len(failed)} videos failed (errors above)" if failed else ""), file=sys.stderr)
    return 2 if failed else 0


def _whole_number(least: int) -> Callable[[str], int]:
    """An argparse type: a whole number of at least ``least``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = least - 1
        if value < least:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {least}, got {text!r}")
        return value

    return parse


def add_commands(sub: Any) -> None:
    """Register ``read``."""
    p = sub.add_parser(
        "read", help="answer CRAFT questions from the videos and the question texts alone",
        description="Perceive each video (layout, statics, objects, the simulation that reproduces it), read each "
                    "question's program from its text and answer it. Reads only the video files and the question "
                    "texts (video_index, question_index, question of each record).",
    )
    p.add_argument("--videos", nargs="+", metavar="PATH",
                   help="folders holding <id6>.mpg (.mpeg, .mp4, .avi, .mkv, .webm, .mov, .gif) videos, searched "
                        "recursively, and/or such video files (default: none; then --video-map names them all)")
    p.add_argument("--video-map", metavar="FILE",
                   help="CSV with the header video_index,path, or JSON {\"<video_index>\": \"path\"}: the video of "
                        "each index, for names that are not the index (relative paths from the file's folder; "
                        "default: none)")
    p.add_argument("--questions", required=True, help="dataset_minimal.json (or any list of question records)")
    p.add_argument("--out", required=True,
                   help='predictions JSON: {"<video_index>_<question_index>": answer}; until it is written, '
                        '<out>.partial.jsonl journals the finished videos, and the same command resumes from it')
    add_workers_option(p, "worker processes (one video at a time each); the output is identical for any number")
    p.add_argument("--executor", default="local", choices=("local", "dask"),
                   help="where the videos are read: local worker processes (local, the default), or a Dask cluster "
                        "(dask: needs --scheduler and pip install 'craft-dsl[dask]'; its workers read the videos at "
                        "the paths found here); the output and the journal are the same")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="with --executor dask: the address of the Dask scheduler (default: none)")
    p.add_argument("--perceived", help="also write each video's PerceivedScene JSON (<id6>.json) into this folder "
                                       "(default: none)")
    p.add_argument("--details", help="also write one JSON line per question (answer, confidence: the probability "
                                     "that it is right, probability, program, error, fallback: the answer is a "
                                     "guess, premise: it is read on the reading the question names) to this file "
                                     "(default: none)")
    p.add_argument("--distribution", action="store_true",
                   help="answer with the mode of each question's answer distribution and give its probability")
    p.add_argument("--samples", type=int, default=64, help="Monte Carlo readings of an answer distribution")
    p.add_argument("--votes", type=_whole_number(0), default=VOTES, metavar="N",
                   help=f"perturbed replays that vote on each counterfactual question's answer with the reader's "
                        f"own (default {VOTES}; 0: the replay alone)")
    p.add_argument("--steps", type=_whole_number(1), default=RUN_STEPS, metavar="N",
                   help=f"steps of the run each video shows (default {RUN_STEPS}: CRAFT's 10 s; a dataset made with "
                        f"craft-dsl generate --steps N shows N): a video whose frames end earlier is not whole")
    p.add_argument("--engine", choices=ENGINE_CHOICES, default="auto",
                   help="the physics engine the videos were made with, where it is known (craft-dsl generate "
                        "--engine): each video is reconstructed with it alone, about a tenth faster "
                        "(default auto: first the engine the dataset's generation_config.json names, beside the "
                        "questions or the videos, else box2d; the other engine too where that run strays; Box2D "
                        "alone for the original renderer's look)")
    p.add_argument("--decoder", choices=DECODERS, default="auto",
                   help="video decoder: PyAV in-process (auto), or imageio-ffmpeg's ffmpeg process")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary")
    p.set_defaults(func=cmd_read)
