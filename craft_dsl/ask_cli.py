"""Command ``craft-dsl ask``: answer a CRAFT question in words over a simulation (see docs/questions.md)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from .program import to_json
from .question_parsing import match_question
from .ranges import parse_scene
from .types import INVALID
from .vocabulary import DEFAULT_ENGINE, ENGINES, engine_help


def answer_in_words(answer: Any) -> str:
    """``True`` -> "yes", ``False`` -> "no", counts and attribute values as they are, INVALID as "INVALID"."""
    if answer is INVALID:
        return "INVALID"
    if isinstance(answer, bool):
        return "yes" if answer else "no"
    return str(answer)


def cmd_ask(args: argparse.Namespace) -> int:
    from .cli import _simulation

    match = match_question(args.question)
    result: dict[str, Any] = {"question": args.question, **match.to_json()}
    if args.program_only:
        print(json.dumps(result) if args.json else match.program)
        return 0
    answer = match.program.run(_simulation(args))
    if args.json:
        print(json.dumps({**result, "answer": to_json(answer)}))
    else:
        print(answer_in_words(answer))
    if answer is INVALID:
        print("note: the answer is INVALID: an object the question names is missing or not unique in this "
              "simulation, or an event it refers to never happens", file=sys.stderr)
    return 0


def add_commands(sub: Any) -> None:
    """Register ``ask``."""
    ask = sub.add_parser(
        "ask", help="answer a CRAFT question in words (the question's template program, run on a simulation)",
        description="Read a CRAFT question (any template, paraphrase and synonym), bind its parameters, run its "
                    "program on a recorded or live simulation and print the answer in words.",
    )
    ask.add_argument("question", help='the question, e.g. "How many objects fall to the ground?"')
    ask.add_argument("--sim", help="recorded simulation JSON file (CRAFT format) (default: none: give --sim or "
                                   "--scene, or --program-only)")
    ask.add_argument("--scene", type=parse_scene,
                     help="or simulate this scene layout (1-20 or a layout file) live (default: none)")
    ask.add_argument("--seed", type=int, default=0, help="seed of the live simulation")
    ask.add_argument("--engine", default=DEFAULT_ENGINE, choices=ENGINES,
                     help=engine_help(ENGINES, " of the live simulation (default: %(default)s)"))
    ask.add_argument("--json", action="store_true",
                     help="print {question, template_id, paraphrase, params, program, answer} as JSON")
    ask.add_argument("--program-only", action="store_true",
                     help="print the question's program (canonical text) without running it; no simulation needed")
    ask.set_defaults(func=cmd_ask)
