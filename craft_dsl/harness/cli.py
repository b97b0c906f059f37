"""Commands ``export lmms-eval`` and ``parse-answers`` (docs/evaluate.md)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..errors import PredictionsFileError
from ..files import parse_json, read_json, read_text

#: Fields of an outputs record that may hold the model's text, in the order they are looked for.
TEXT_FIELDS: tuple[str, ...] = ("response", "text", "output", "completion", "answer")


def cmd_export_lmms_eval(args: argparse.Namespace) -> int:
    from .lmms_eval import VisualSettings, export_lmms_eval

    settings = VisualSettings(args.visual, args.frames, args.fps)
    result = export_lmms_eval(args.dataset, args.out, settings=settings, name=args.name,
                              max_new_tokens=args.max_new_tokens)
    for part in result.skipped:
        print(f"note: no task for {part}", file=sys.stderr)
    tasks = ", ".join(f"{t} ({n} questions)" for t, n in result.tasks.items())
    print(f"wrote {result.out}: group {args.name}, tasks {tasks}", file=sys.stderr)
    print(f"run: lmms-eval --include_path {result.out} --tasks {args.name} --model ... (--model craft_reader: "
          "craft-dsl's video reader)", file=sys.stderr)
    return 0


def _records(path: str) -> Iterator[tuple[str, Any, Any]]:
    """(place, key text or record, text) of every model output in a JSON or JSON Lines file."""
    what = "model outputs file"
    if path.endswith(".jsonl"):
        for n, line in enumerate(read_text(path, what, error=PredictionsFileError).splitlines(), 1):
            if line.strip():
                where = f"{path}: line {n}"
                yield where, parse_json(line, where, what, error=PredictionsFileError), None
        return
    data = read_json(path, what, error=PredictionsFileError)
    if isinstance(data, dict):
        for key, text in data.items():
            yield f"{path}: key {key!r}", key, text
    elif isinstance(data, list):
        for i, rec in enumerate(data):
            yield f"{path}: record {i}", rec, None
    else:
        raise PredictionsFileError(f"{path}: expected an object {{\"<video>_<question>\": text}} or a list of "
                                   f"records, found {type(data).__name__}")


def _key_and_text(where: str, item: Any, text: Any) -> tuple[tuple[int, int], Any]:
    if isinstance(item, str):
        video, sep, question = item.partition("_")
        if not (sep and video.isdigit() and question.isdigit()):
            raise PredictionsFileError(f"{where}: a key is '<video_index>_<question_index>', e.g. '12_3'")
        return (int(video), int(question)), text
    if not isinstance(item, dict):
        raise PredictionsFileError(f"{where}: expected a record with video_index, question_index and "
                                   f"{' or '.join(TEXT_FIELDS)}, found {type(item).__name__}")
    try:
        key = (int(item["video_index"]), int(item["question_index"]))
    except (KeyError, TypeError, ValueError):
        raise PredictionsFileError(f"{where}: the record needs integer fields video_index and question_index"
                                   ) from None
    for name in TEXT_FIELDS:
        if name in item:
            return key, item[name]
    raise PredictionsFileError(f"{where}: the record has none of the fields {', '.join(TEXT_FIELDS)}")


def cmd_parse_answers(args: argparse.Namespace) -> int:
    from ..atomic import atomic_path
    from ..verify import read_questions
    from .answers import kind_of_template, parse_answer

    questions = {q.key: q for q in read_questions(args.questions)}
    out: dict[str, str] = {}
    unread = unknown = 0
    seen: set[tuple[int, int]] = set()
    for where, item, text in _records(args.outputs):
        key, text = _key_and_text(where, item, text)
        if key in seen:
            raise PredictionsFileError(f"{where}: question {key[0]}_{key[1]} is given twice")
        seen.add(key)
        q = questions.get(key)
        if q is None:
            unknown += 1
            continue
        if not isinstance(text, (str, bool, int, list, dict)):
            raise PredictionsFileError(f"{where}: the model output must be text, found {type(text).__name__}")
        answer = parse_answer(text, kind_of_template(q.template_id))
        if answer is None:
            unread += 1
        else:
            out[f"{key[0]}_{key[1]}"] = answer
    with atomic_path(args.out) as tmp:
        Path(tmp).write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out}: {len(out)} answers from {len(seen)} outputs; {unread} without a readable answer "
          f"(left out: scored as wrong); {unknown} for questions not in {args.questions} (ignored)", file=sys.stderr)
    return 0


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"give a whole number, not {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"give at least 1, not {value}")
    return value


def _fps(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"give a number of frames per second, not {text!r}") from None
    if not 0 < value <= 60:
        raise argparse.ArgumentTypeError(f"give a rate above 0 and at most 60 (the videos' rate), not {text}")
    return value


def add_commands(sub: Any) -> None:
    """Register ``export`` (``export lmms-eval``) and ``parse-answers``."""
    export = sub.add_parser("export", help="export a dataset for an evaluation harness (lmms-eval)")
    targets = export.add_subparsers(dest="target", required=True, metavar="TARGET")
    lm = targets.add_parser("lmms-eval", help="write an lmms-eval task folder (load it with --include_path DIR)",
                            description="Write an lmms-eval task folder: group NAME, tasks NAME_easy (random split, "
                                        "test part) and NAME_hard (hard split, test part), with prompts that state "
                                        "the expected answer kind, free-text answer parsing and accuracy per paper "
                                        "category (the figures of craft-dsl score). See docs/evaluate.md.")
    lm.add_argument("dataset", help="a dataset folder (craft-dsl generate; with --videos for the videos)")
    lm.add_argument("--out", required=True, help="the task folder to write")
    lm.add_argument("--visual", choices=("frames", "video"), default="frames",
                    help="frames: pass sampled frames as images; video: pass the video file's path (the model "
                         "samples frames itself, e.g. its max_frames_num)")
    lm.add_argument("--frames", type=_positive_int, default=8,
                    help="with --visual frames: this many frames, spread evenly over the video, first and last "
                         "included")
    lm.add_argument("--fps", type=_fps, default=None,
                    help="with --visual frames: one frame every 1/FPS seconds instead of --frames (default: none, "
                         "--frames decides)")
    lm.add_argument("--name", default="craft", help="the group's name, prefix of the task names")
    lm.add_argument("--max-new-tokens", type=_positive_int, default=32, help="the generation length limit")
    lm.set_defaults(func=cmd_export_lmms_eval)

    pa = sub.add_parser("parse-answers",
                        help="read free-text model outputs into answers for craft-dsl score",
                        description="Read free-text model outputs ('The answer is two.', '**Yes**') into the "
                                    "dataset's answers, for each question's answer kind, and write a predictions "
                                    "file for craft-dsl score. Outputs without a readable answer are left out (scored "
                                    "as wrong).")
    pa.add_argument("--questions", required=True, help="dataset_minimal.json or dataset.json")
    pa.add_argument("--outputs", required=True,
                    help='model outputs: JSON {"<video_index>_<question_index>": text}, or a list (JSON) or lines '
                         '(.jsonl) of records with video_index, question_index and response (or text, output, '
                         'completion, answer)')
    pa.add_argument("--out", required=True, help="the predictions file to write (JSON)")
    pa.set_defaults(func=cmd_parse_answers)
