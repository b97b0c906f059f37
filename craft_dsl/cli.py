"""The ``craft-dsl`` command line."""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
from collections.abc import Sequence
from typing import Any

from .errors import CraftError
from .files import read_json, read_text
from .program import Program, format_value, to_json
from .ranges import parse_scene
from .registry import MODULES
from .vocabulary import DEFAULT_ENGINE, ENGINES, engine_help

EXIT_USAGE = 2
#: Program files and node lists larger than this are refused (a 5,000-binding program is about 200 KB).
MAX_PROGRAM_BYTES = 64 << 20


def _read_program(text: str) -> str:
    if text.startswith("@"):
        return read_text(text[1:], "program file", max_bytes=MAX_PROGRAM_BYTES)
    return text


def _params(pairs: Sequence[str]) -> dict[str, str]:
    out = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep:
            raise CraftError(f"--param {pair!r}: expected PLACEHOLDER=VALUE, e.g. '<Z>=small'")
        out[key if key.startswith("<") else f"<{key}>"] = value
    return out


def _load_program(args: argparse.Namespace) -> Program:
    if getattr(args, "nodes", None):
        data = read_json(args.nodes, "node list", max_bytes=MAX_PROGRAM_BYTES)
        if isinstance(data, dict):  # a question record or {"nodes": [...]}
            data = data.get("program", data.get("nodes", data))
        return Program.from_nodes(data, _params(args.param))
    if not args.program:
        raise CraftError("give a PROGRAM (text or @file) or --nodes FILE")
    return Program.parse(_read_program(args.program))


def _simulation(args: argparse.Namespace) -> Any:
    if args.sim and args.scene is not None:
        raise CraftError("give either --sim FILE or --scene N, not both")
    if args.sim:
        from .recorded import load_simulation

        return load_simulation(args.sim, strict=getattr(args, "strict", False))
    if args.scene is None:
        raise CraftError("give a simulation: --sim FILE (recorded) or --scene N [--seed S] (live physics)")
    from .physics import simulate

    return simulate(args.scene, seed=args.seed, engine=args.engine)


def cmd_run(args: argparse.Namespace) -> int:
    program = _load_program(args)
    sim = _simulation(args)
    if args.trace:
        entries = program.trace(sim)
        if args.json:
            print(json.dumps([{"expression": e.expression, "type": str(e.type), "value": to_json(e.value)}
                              for e in entries], indent=2))
        else:
            for e in entries:
                print(f"{e.expression}  ->  {format_value(e.value)}  : {e.type}")
        return 0
    answer = program.run(sim)
    if args.json:
        print(json.dumps({"program": str(program), "type": str(program.type), "answer": to_json(answer)}))
    else:
        print(format_value(answer))
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    program = _load_program(args)
    if args.json:
        print(json.dumps({"program": str(program), "type": str(program.type), "nodes": program.to_nodes()}))
    else:
        print(program)
        print(f": {program.type}")
    return 0


def modules_table(markdown: bool = False) -> str:
    """The registry as a table (plain text, or Markdown for docs/modules.md)."""
    rows = []
    for m in MODULES:
        sigs = " / ".join(
            "(" + ", ".join([str(t) for t in ov.inputs] + [f'"{t}"' for t in m.side_inputs]) + f") -> {ov.output}"
            for ov in m.overloads
        )
        rows.append((m.name, sigs, ", ".join(m.aliases), m.description))
    if markdown:
        lines = ["| module | signature | original names | meaning |", "|---|---|---|---|"]
        lines += [f"| `{n}` | `{s}` | {', '.join(f'`{a}`' for a in al.split(', ') if a)} | {d} |"
                  for n, s, al, d in rows]
        return "\n".join(lines)
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    return "\n".join(f"{n:<{w0}}  {s:<{w1}}  {d}" for n, s, _, d in rows)


def cmd_modules(args: argparse.Namespace) -> int:
    print(modules_table(markdown=args.markdown))
    return 0


class HelpFormatter(argparse.HelpFormatter):
    """Every option's help shows its default: ``(default: VALUE)`` is appended to the help of an option that takes
    a value, unless the help already speaks of its default (``(default 600 = 10 s)``, ``(default: stdout)``).
    Left alone: flags (``store_true`` and the like: off unless given), required options, and options whose default
    is None or empty, whose help says in words what happens without them (tests/test_cli_help.py checks it)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if "%(default)" in text or "default" in text.lower() or not action.option_strings or action.nargs == 0 \
                or action.required or action.default in (None, argparse.SUPPRESS) or action.default == []:
            return action.help
        return f"{text} (default: %(default)s)"


class DeprecatedAlias(argparse.Action):
    """An old name of an option, still accepted, hidden from ``--help``: using it prints
    ``warning: --OLD is deprecated; use --NEW`` on stderr and sets the new option's value."""

    def __init__(self, option_strings: Sequence[str], dest: str, replacement: str, **kwargs: Any) -> None:
        kwargs.setdefault("help", argparse.SUPPRESS)
        kwargs.setdefault("default", argparse.SUPPRESS)  # the new option's default stands
        super().__init__(option_strings, dest, **kwargs)
        self.replacement = replacement

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        print(f"warning: {option_string} is deprecated; use {self.replacement}", file=sys.stderr)
        setattr(namespace, self.dest, values)


class _CommandParser(argparse.ArgumentParser):
    """Every command's parser shows its defaults in --help (:class:`HelpFormatter`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = argparse.ArgumentParser(prog="craft-dsl", description="Typed DSL for CRAFT causal video QA.")
    parser.add_argument("--version", action="version", version=f"craft-dsl {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=_CommandParser)

    run = sub.add_parser("run", help="run a program over a recorded simulation")
    run.add_argument("program", nargs="?", help="program text, or @file")
    run.add_argument("--sim", help="recorded simulation JSON file (CRAFT format) (default: none: give --sim or "
                                   "--scene)")
    run.add_argument("--scene", type=parse_scene,
                     help="or simulate this scene layout (1-20 or a layout file) live (default: none)")
    run.add_argument("--seed", type=int, default=0, help="seed of the live simulation (default 0)")
    run.add_argument("--engine", default=DEFAULT_ENGINE, choices=ENGINES,
                     help=engine_help(ENGINES, " of the live simulation (default: %(default)s)"))
    run.add_argument("--nodes", help="read the program as a CLEVR/CRAFT node list from this JSON file "
                                     "(default: none, the PROGRAM argument)")
    run.add_argument("--param", action="append", default=[], metavar="<Z>=small",
                     help="bind a template placeholder of a node list (repeatable; default: none)")
    run.add_argument("--strict", action="store_true",
                     help="also refuse a --sim file the original simulator could not have written (docs/recorded.md)")
    run.add_argument("--json", action="store_true", help="print JSON")
    run.add_argument("--trace", action="store_true", help="print every node's value")
    run.set_defaults(func=cmd_run)

    check = sub.add_parser("check", help="type-check a program; print its canonical form and type")
    check.add_argument("program", nargs="?", help="program text, or @file")
    check.add_argument("--nodes", help="read the program as a node list from this JSON file "
                                       "(default: none, the PROGRAM argument)")
    check.add_argument("--param", action="append", default=[], metavar="<Z>=small",
                       help="bind a template placeholder of a node list (repeatable; default: none)")
    check.add_argument("--json", action="store_true", help="print JSON (with the node list)")
    check.set_defaults(func=cmd_check)

    mods = sub.add_parser("modules", help="list every module with its signature")
    mods.add_argument("--markdown", action="store_true", help="print a Markdown table")
    mods.set_defaults(func=cmd_modules)

    for name in ("craft_dsl.demo", "craft_dsl.physics.cli", "craft_dsl.render.cli", "craft_dsl.verify.cli",
                 "craft_dsl.dataset.cli", "craft_dsl.oracle.cli", "craft_dsl.ask_cli", "craft_dsl.dataset.hf_cli",
                 "craft_dsl.dataset.stats_cli", "craft_dsl.viewer.cli", "craft_dsl.perception.cli",
                 "craft_dsl.reader.cli", "craft_dsl.harness.cli", "craft_dsl.dataset.heldout"):
        try:
            module = importlib.import_module(name)
        except ImportError as err:
            if err.name and name.startswith(err.name):
                continue  # that part of the package is not built
            raise
        module.add_commands(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)  # a CraftError from an option's reader (--scene) is bad input too
        result: Any = args.func(args)
    except CraftError as err:
        print(f"error: {err}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except (OSError, UnicodeError, RecursionError, MemoryError) as err:
        # Readers turn these into CraftError naming the file and the field; whatever still arrives here is named
        # as well as it can be, never shown as a traceback.
        print(f"error: {_describe_failure(err)}", file=sys.stderr)
        return EXIT_USAGE
    return int(result or 0)


def _describe_failure(err: BaseException) -> str:
    """A one-line message for an error no reader turned into a CraftError."""
    if isinstance(err, OSError):
        name = f"{err.filename}: " if err.filename else ""
        return f"{name}{err.strerror or err}"
    if isinstance(err, UnicodeError):
        return f"text that is not UTF-8: {err}"
    if isinstance(err, RecursionError):
        return "the input is nested too deeply to be processed"
    return "out of memory: the input is too large to be processed in memory"


if __name__ == "__main__":
    sys.exit(main())
