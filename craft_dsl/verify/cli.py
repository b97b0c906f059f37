"""Command-line commands ``verify``, ``score`` and ``verify-fixture`` (see docs/verify.md).

Exit codes: ``verify`` 0 when every question agrees, 1 when some mismatch or cannot be re-answered, 2 for bad
input (raised as :class:`craft_dsl.errors.CraftError`, turned into exit code 2 by the main CLI or :func:`run`).
``score`` and ``verify-fixture`` exit 0 or 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..errors import CraftError
from ..progress import show_progress

EXIT_MISMATCH = 1
EXIT_BAD_INPUT = 2


def cmd_verify(args: argparse.Namespace) -> int:
    from . import open_annotations, read_dataset, verify_dataset

    if args.max_mismatches is not None and args.max_mismatches < 0:
        raise CraftError(f"--max-mismatches must be 0 or more, not {args.max_mismatches}")
    questions = read_dataset(args.dataset)
    annotations = open_annotations(args.annotations)
    progress = None
    bar: Any = None
    if show_progress(args):
        from tqdm import tqdm

        bar = tqdm(total=len(questions), unit="q", file=sys.stderr)
        progress = bar.update
    try:
        report = verify_dataset(questions, annotations, progress=progress)
    finally:
        if bar is not None:
            bar.close()
    if args.json:
        print(json.dumps(report.to_json(args.max_mismatches), indent=2))
    else:
        print(report.format(20 if args.max_mismatches is None else args.max_mismatches))
    return 0 if report.ok else EXIT_MISMATCH


def cmd_score(args: argparse.Namespace) -> int:
    from . import read_questions, read_split, score

    if args.part and not args.split:
        raise CraftError("--part needs --split FILE")
    questions = read_questions(args.questions)
    keys = read_split(args.split, args.part or "test") if args.split else None
    report = score(questions, args.predictions, split=keys)  # the predictions file is read as a stream
    if args.json:
        out = report.to_json()
        if args.compare_paper:
            from . import PAPER_HUMANS, PAPER_RESULTS

            cols = ("C", "CF", "D", "All")
            out["paper"] = {
                "split": args.compare_paper,
                "rows": [{"group": r.group, "model": r.model,
                          **dict(zip(cols, r.easy if args.compare_paper == "easy" else r.hard))}
                         for r in PAPER_RESULTS],
                "humans": dict(zip(cols, PAPER_HUMANS)),
            }
        print(json.dumps(out, indent=2))
    else:
        label = Path(args.predictions).stem
        print(report.format(per_template=args.per_template, compare_paper=args.compare_paper, label=label))
    return 0


def cmd_verify_fixture(args: argparse.Namespace) -> int:
    from ..physics import simulate
    from ..recorded import write_json_atomic
    from . import build_dataset, minimal_records

    sims = []
    for spec in args.sim or ["1:0", "3:0"]:
        scene, sep, seed = spec.partition(":")
        if not scene.isdigit() or (sep and not seed.lstrip("-").isdigit()):
            raise CraftError(f"--sim {spec!r}: expected SCENE:SEED, e.g. 3:7")
        sims.append(simulate(int(scene), seed=int(seed or 0)))
    dataset, annotations = build_dataset(sims, include_dropped=args.include_dropped)
    out = Path(args.out)
    write_json_atomic(dataset, out / "dataset.json")
    write_json_atomic(annotations, out / "annotations.json")
    write_json_atomic(minimal_records(dataset), out / "dataset_minimal.json")
    n = sum(len(v["questions"]["questions"]) for v in dataset)
    print(f"wrote {out}/dataset.json, dataset_minimal.json, annotations.json: {len(dataset)} videos, {n} questions",
          file=sys.stderr)
    return 0


def add_commands(subparsers: Any) -> None:
    """Register ``verify``, ``score`` and ``verify-fixture`` on the main CLI's subparsers."""
    ver = subparsers.add_parser("verify", help="re-answer every question of a dataset.json from its simulation")
    ver.add_argument("--dataset", required=True, help="dataset.json (videos with question programs)")
    ver.add_argument("--annotations", required=True,
                     help="annotations.json ({id6: simulation with variations}) or a directory of <id6>.json")
    ver.add_argument("--json", action="store_true", help="print the report as JSON")
    ver.add_argument("--max-mismatches", type=int, default=None, metavar="N",
                     help="list at most N mismatches and N errors (default: 20 in text, all in JSON)")
    ver.add_argument("--progress", action="store_true", help="a progress bar even when stderr is no terminal")
    ver.add_argument("--quiet", action="store_true", help="no progress bar")
    ver.set_defaults(func=cmd_verify)

    sc = subparsers.add_parser("score", help="score predictions per paper category (C, CF, D, sub-categories)")
    sc.add_argument("--questions", required=True, help="dataset_minimal.json or dataset.json")
    sc.add_argument("--predictions", required=True,
                    help='predictions JSON: {"<video_index>_<question_index>": answer} or a list of '
                         '{"video_index", "question_index", "answer"}, or JSON Lines (.jsonl) of such records; '
                         'read as a stream')
    sc.add_argument("--split", help="split_info_random.json or split_info_hard.json: score one part only "
                                    "(default: none, every question)")
    sc.add_argument("--part", help="part of the split to score (train, validation, test; default test)")
    sc.add_argument("--json", action="store_true", help="print the report as JSON")
    sc.add_argument("--per-template", action="store_true", help="also list the accuracy of every template")
    sc.add_argument("--compare-paper", choices=("easy", "hard"),
                    help="print the paper's results on this split beside yours (default: none)")
    sc.set_defaults(func=cmd_score)

    fx = subparsers.add_parser("verify-fixture",
                               help="write a small dataset (dataset.json, dataset_minimal.json, annotations.json) "
                                    "from live simulations, for trying verify/score (not the CRAFT pipeline)")
    fx.add_argument("--out", required=True, help="output directory")
    fx.add_argument("--sim", action="append", metavar="SCENE:SEED",
                    help="a live simulation to include (repeatable; default 1:0 and 3:0)")
    fx.add_argument("--include-dropped", action="store_true",
                    help="also ask the 19 basket-collision templates the paper drops")
    fx.set_defaults(func=cmd_verify_fixture)


def run(argv: Sequence[str]) -> int:
    """Run one of these commands as ``craft-dsl`` does (errors: a message on stderr, exit code 2)."""
    from ..cli import main

    return main(list(argv))
