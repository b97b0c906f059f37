"""Command-line commands ``evaluate``, ``vocab`` and ``export-pairs`` (see docs/oracle.md).

Exit codes: 0 done (whatever the scores), 2 bad input (a message naming file, record and field).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from ..errors import CraftError
from ..progress import show_progress

#: Special tokens at the start of every vocabulary, as sequence-to-sequence code expects them.
SPECIAL_TOKENS: tuple[str, ...] = ("<NULL>", "<START>", "<END>", "<UNK>")


def cmd_evaluate(args: argparse.Namespace) -> int:
    from ..verify import read_split
    from .evaluate import evaluate_predictions

    if args.part and not args.split:
        raise CraftError("--part needs --split FILE")
    split = read_split(args.split, args.part or "test") if args.split else None
    bar: Any = None
    progress = None
    if show_progress(args):
        from tqdm import tqdm

        bar = tqdm(unit="q", file=sys.stderr)
        progress = bar.update
    try:
        report = evaluate_predictions(args.dataset, args.predictions, args.annotations, split=split,
                                      token_order=args.token_order, progress=progress)
    finally:
        if bar is not None:
            bar.close()
    if args.json:
        print(json.dumps(report.to_json(per_question=args.per_question), indent=2))
    else:
        print(report.format(per_template=args.per_template, failures=args.failures))
    return 0


def vocabulary(names: str = "canonical", fused: bool = False) -> dict[str, Any]:
    """The token vocabularies a semantic parser or a VQA model trains against: program tokens, question
    tokens, answers; each ``token -> index`` with the special tokens first."""
    from ..question_parsing import question_words
    from ..tokens import program_vocabulary
    from ..vocabulary import COLORS, SHAPES, SIZES

    def index(tokens: list[str]) -> dict[str, int]:
        return {t: i for i, t in enumerate(dict.fromkeys([*SPECIAL_TOKENS, *tokens]))}

    answers = ["false", "true", *(str(n) for n in range(11)), *COLORS, *SHAPES, *SIZES]
    return {
        "format": "craft-dsl vocabulary", "version": 1,
        "program_token_to_idx": index(program_vocabulary(names, fused)),  # type: ignore[arg-type]
        "program_tokens": {"names": names, "fused": fused,
                           "orders": ["prefix", "postfix"], "integers": "any decimal integer is also a token"},
        "question_token_to_idx": index([*question_words(), ",", "?"]),
        "question_tokens": "lower case; words and each punctuation mark are tokens (craft_dsl.question_parsing."
                           "question_tokens)",
        "answer_token_to_idx": index(answers),
        "answers": "as craft_dsl.verify.normalise_answer writes them (true/false, counts, lower-case words)",
    }


def cmd_vocab(args: argparse.Namespace) -> int:
    from ..atomic import write_json_atomic

    data = vocabulary(args.names, args.fused)
    if args.out:
        write_json_atomic(data, args.out)
        print(f"wrote {args.out}: {len(data['program_token_to_idx'])} program tokens, "
              f"{len(data['question_token_to_idx'])} question tokens, {len(data['answer_token_to_idx'])} answers",
              file=sys.stderr)
    else:
        print(json.dumps(data, indent=2))
    return 0


def cmd_export_pairs(args: argparse.Namespace) -> int:
    from ..atomic import atomic_path
    from ..program import Program
    from ..question_parsing import question_tokens
    from ..verify import read_dataset, read_split

    if args.part and not args.split:
        raise CraftError("--part needs --split FILE")
    source = Path(args.dataset)
    questions = read_dataset(source / "dataset.json" if source.is_dir() else source)
    keys = read_split(args.split, args.part or "train") if args.split else None
    n = 0
    with atomic_path(args.out) as tmp, tmp.open("w", encoding="utf-8") as fh:
        for q in questions:
            if keys is not None and q.key not in keys:
                continue
            if q.program is None:
                raise CraftError(f"{q.where}: the record has no program")
            try:
                program = Program.from_nodes(list(q.program))
            except CraftError as err:
                raise CraftError(f"{q.where}, field 'program': {err}") from None
            row = {"video_index": q.video_index, "question_index": q.question_index, "template_id": q.template_id,
                   "question": q.question, "question_tokens": question_tokens(q.question),
                   "program_tokens": program.to_tokens(args.order, names=args.names, fused=args.fused),
                   "program": str(program), "answer": q.answer}
            fh.write(json.dumps(row) + "\n")
            n += 1
    print(f"wrote {args.out}: {n} (question, program) pairs, {args.order} tokens", file=sys.stderr)
    return 0


def _token_style(p: argparse.ArgumentParser) -> None:
    p.add_argument("--names", choices=("canonical", "original"), default="canonical",
                   help="module names: the paper's (FilterColor) or the original engine's (filter_color)")
    p.add_argument("--fused", action="store_true", help="fuse side inputs into module tokens (FilterColor[red])")


def add_commands(sub: Any) -> None:
    """Register ``evaluate``, ``vocab`` and ``export-pairs``."""
    ev = sub.add_parser(
        "evaluate",
        help="evaluate predicted answers, programs (text, node lists, tokens), traces and answer distributions",
        description="Run each predicted program on the true simulation and say exactly where predictions go wrong: "
                    "program validity, exact program match, execution accuracy, answer accuracy, trace agreement "
                    "per module, per paper category.")
    ev.add_argument("--dataset", required=True,
                    help="dataset.json (with programs), or the folder holding it and annotations.json")
    ev.add_argument("--predictions", required=True, help="predictions .json or .jsonl (see docs/oracle.md)")
    ev.add_argument("--annotations", help="annotations.json or a folder of <id6>.json (default: beside dataset.json)")
    ev.add_argument("--split", help="split_info_random.json or split_info_hard.json: evaluate one part only "
                                    "(default: none, every question)")
    ev.add_argument("--part", help="part of the split (train, validation, test; default test)")
    ev.add_argument("--token-order", choices=("prefix", "postfix"), default="prefix",
                    help="how token lists without a program_format are read")
    ev.add_argument("--json", action="store_true", help="print the report as JSON")
    ev.add_argument("--per-question", action="store_true", help="with --json: include every question's result")
    ev.add_argument("--per-template", action="store_true", help="also list every template")
    ev.add_argument("--failures", type=int, default=10, metavar="N", help="list the first N problems")
    ev.add_argument("--progress", action="store_true", help="a progress bar even when stderr is no terminal")
    ev.add_argument("--quiet", action="store_true", help="no progress bar")
    ev.set_defaults(func=cmd_evaluate)

    vo = sub.add_parser("vocab",
                        help="write the token vocabularies (program, question, answer) a parser trains against")
    vo.add_argument("--out", help="write to this JSON file (default: print)")
    _token_style(vo)
    vo.set_defaults(func=cmd_vocab)

    ex = sub.add_parser("export-pairs",
                        help="write (question, program tokens) pairs as JSON Lines for training semantic parsers")
    ex.add_argument("--dataset", required=True, help="dataset.json, or the folder holding it")
    ex.add_argument("--out", required=True, help="output .jsonl file")
    ex.add_argument("--order", choices=("prefix", "postfix"), default="prefix", help="token order")
    ex.add_argument("--split", help="split file: export one part only (default: none, every question)")
    ex.add_argument("--part", help="part of the split (default train)")
    _token_style(ex)
    ex.set_defaults(func=cmd_export_pairs)
