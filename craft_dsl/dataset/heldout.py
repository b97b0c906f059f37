"""Command ``craft-dsl heldout``: a held-out evaluation set generated from a fresh seed (see docs/evaluate.md).

It is ``craft-dsl generate --videos`` with a seed drawn from ``os.urandom`` (or given), recorded in
``heldout.json`` and in a section of the dataset card (``README.md``) that says how the set was made and that no
model can have trained on it unless that model was given the seed. Re-running the command in the same folder
without ``--seed`` resumes with the recorded seed.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
import time
from pathlib import Path
from typing import Any

from ..atomic import atomic_path
from ..errors import CraftError
from ..parallel import add_workers_option
from ..ranges import parse_scenes
from ..vocabulary import DEFAULT_ENGINE, ORIGINAL_ENGINE, SIMULATORS, engine_help
from .pipeline import GenerationConfig, generate_dataset

#: The record of how the set was made, beside the dataset files.
HELDOUT_FILE = "heldout.json"
#: Videos of a held-out set unless ``--size`` says otherwise.
DEFAULT_SIZE = 200
SECTION_TITLE = "## Held-out evaluation set"
DEFAULT_STEPS = GenerationConfig.model_fields["steps"].default
DEFAULT_PERTURBATIONS = GenerationConfig.model_fields["perturbations"].default


def fresh_seed() -> int:
    """A seed no one chose: 63 random bits from ``os.urandom``."""
    return int.from_bytes(os.urandom(8), "big") >> 1


def reproducing_command(out: str, config: GenerationConfig, scenes: str | None) -> str:
    """The ``craft-dsl heldout`` command that makes this set again (the seed spelled out)."""
    parts = ["craft-dsl", "heldout", "--out", out, "--size", str(config.size), "--seed", str(config.seed)]
    if scenes is not None:
        parts += ["--scenes", scenes]
    if config.steps != DEFAULT_STEPS:
        parts += ["--steps", str(config.steps)]
    if config.perturbations != DEFAULT_PERTURBATIONS:
        parts += ["--perturbations", str(config.perturbations)]
    if config.engine != DEFAULT_ENGINE:
        parts += ["--engine", config.engine]
    if not config.balance:
        parts.append("--no-balance")
    return shlex.join(parts)


def card_section(record: dict[str, Any]) -> str:
    """The card's section on how the set was made (Markdown, ending with a blank line)."""
    seed = record["seed"]
    source = ("drawn from `os.urandom` when the set was made" if record["seed_source"] == "os.urandom"
              else "given on the command line")
    rows = [("command", f"`{record['command']}`"), ("seed", f"`{seed}` ({source})"),
            ("engine", f"`{record['engine']}`"), ("craft_dsl version", f"`{record['craft_dsl_version']}`"),
            ("made", record["made"])]
    lines = [SECTION_TITLE, "",
             "This folder is a held-out evaluation set, made by `craft-dsl heldout`: the normal `craft-dsl generate` "
             "pipeline with videos (simulation, questions, perturbation filter, post-process, "
             + ("balancing, " if record.get("balance", True) else "no balancing, ") + "splits), from a fresh seed.",
             "",
             "| | |", "|---|---|", *(f"| {k} | {v} |" for k, v in rows), "",
             f"Every video and question derives from the seed {seed} alone. No model can have trained on this set "
             "unless that model, or whoever made its training data, was given the seed: keep it out of training "
             "configurations. The set is new draws of the same scene layouts and question templates as any data "
             "`craft-dsl` makes, not new kinds of scenes or questions. Evaluate on all of it (every split and part) "
             f"or on one part. `{HELDOUT_FILE}` holds this record; `craft-dsl hf` rewrites this card without the "
             "section.", ""]
    return "\n".join(lines)


def write_card_section(root: Path, record: dict[str, Any]) -> Path:
    """Put :func:`card_section` into the folder's card, before its first ``##`` section (replacing an earlier
    one)."""
    card = root / "README.md"
    text = card.read_text(encoding="utf-8") if card.is_file() else ""
    if SECTION_TITLE in text:  # a resumed run: replace the old section
        start = text.index(SECTION_TITLE)
        end = text.find("\n## ", start + len(SECTION_TITLE))
        text = text[:start] + (text[end + 1:] if end >= 0 else "")
    at = text.find("\n## ")
    section = card_section(record)
    text = text + "\n" + section if at < 0 else text[:at + 1] + section + "\n" + text[at + 1:]
    with atomic_path(card) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return card


def _recorded(root: Path) -> dict[str, Any] | None:
    path = root / HELDOUT_FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise CraftError(f"{path}: unreadable ({err}); give --seed, or use a new folder") from None
    if not isinstance(data, dict) or not isinstance(data.get("seed"), int):
        raise CraftError(f"{path}: not a held-out record (no seed); give --seed, or use a new folder")
    return data


def make_heldout(out: str | os.PathLike[str], *, size: int = DEFAULT_SIZE, seed: int | None = None,
                 scenes: str | None = None, steps: int = DEFAULT_STEPS, perturbations: int = DEFAULT_PERTURBATIONS,
                 engine: str = DEFAULT_ENGINE, balance: bool = True, workers: int = 1,
                 progress: Any = None, echo: Any = None, note: Any = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """Generate the held-out set in ``out`` and write its record and card section; return (generation report,
    record). Without ``seed``: the seed recorded in ``out`` (resuming), else :func:`fresh_seed`. ``echo`` gets
    generate's log lines, ``note(message)`` the seed."""
    from .. import __version__

    root = Path(out)
    old = _recorded(root)
    if old is None and (root / "generation_config.json").exists():
        raise CraftError(f"{root} holds a dataset that craft-dsl heldout did not make: use a new folder")
    if old is not None and seed is not None and int(old["seed"]) != seed:
        raise CraftError(f"{root} holds the held-out set of seed {old['seed']}, not {seed}: use a new folder (or drop "
                         "--seed to resume it)")
    if seed is None and old is not None:
        seed, source = int(old["seed"]), str(old.get("seed_source", "given"))
        if note is not None:
            note(f"resuming the held-out set of seed {seed} ({root / HELDOUT_FILE})")
    elif seed is None:
        seed, source = fresh_seed(), "os.urandom"
    else:
        source = "given" if old is None else str(old.get("seed_source", "given"))
    fields: dict[str, Any] = {"size": size, "seed": seed, "steps": steps, "perturbations": perturbations,
                              "engine": engine, "balance": balance, "videos": True,
                              "workers": workers}
    if scenes is not None:
        fields["scenes"] = tuple(parse_scenes(scenes))
    config = GenerationConfig.make(**fields)
    record = {"seed": seed, "seed_source": source, "command": reproducing_command(str(out), config, scenes),
              "engine": config.engine, "size": config.size, "balance": config.balance, "craft_dsl_version": __version__,
              "made": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    if old is not None and old.get("seed") == seed:
        record["made"] = old.get("made", record["made"])
    root.mkdir(parents=True, exist_ok=True)
    if note is not None and old is None:
        note(f"held-out seed {seed} ({'drawn from os.urandom' if source == 'os.urandom' else 'given'}); "
             f"recorded in {root / HELDOUT_FILE}")
    with atomic_path(root / HELDOUT_FILE) as tmp:  # first, so that an interrupted run resumes with this seed
        tmp.write_text(json.dumps(record, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    report = generate_dataset(config, root, progress=progress, echo=echo)
    write_card_section(root, record)
    return report, record


def cmd_heldout(args: argparse.Namespace) -> int:
    from .cli import _Bars

    if args.size < 1:
        raise CraftError(f"--size: give at least 1 video, not {args.size}")
    if args.engine == ORIGINAL_ENGINE:
        from ..physics.original import find_binary

        find_binary()
    bars = _Bars() if not args.quiet and sys.stderr.isatty() else None

    def note(message: str) -> None:
        print(message, file=sys.stderr)

    echo = None if args.quiet or bars is not None else note
    start = time.perf_counter()
    try:
        report, record = make_heldout(args.out, size=args.size, seed=args.seed, scenes=args.scenes, steps=args.steps,
                                      perturbations=args.perturbations, engine=args.engine,
                                      balance=not args.no_balance, workers=args.workers, progress=bars, echo=echo,
                                      note=None if args.quiet else note)
    except KeyboardInterrupt:
        if bars is not None:
            bars.close()
        print(f"\ninterrupted: re-run `craft-dsl heldout --out {args.out}` to resume (the seed is recorded in "
              f"{Path(args.out) / HELDOUT_FILE})", file=sys.stderr)
        return 130
    if not args.quiet:
        print(f"held-out set {args.out}: {report['videos']['total']} videos, {report['questions']['final']} questions "
              f"in {time.perf_counter() - start:.1f} s; seed {record['seed']} ({record['seed_source']}); card "
              f"{Path(args.out) / 'README.md'}")
    return 0


def add_commands(sub: Any) -> None:
    cmd = sub.add_parser("heldout", help="generate a held-out evaluation set (with videos) from a fresh seed",
                         description="Generate a held-out evaluation set into --out: craft-dsl generate --videos with "
                                     "a seed drawn from os.urandom (or --seed), recorded in heldout.json and the "
                                     "dataset card (docs/evaluate.md). Re-running in the same folder resumes.")
    cmd.add_argument("--out", required=True, help="output folder")
    cmd.add_argument("--size", type=int, default=DEFAULT_SIZE, help="number of videos")
    cmd.add_argument("--seed", type=int,
                     help="the generation seed (default: the one recorded in --out when resuming, else 63 random "
                          "bits from os.urandom)")
    cmd.add_argument("--scenes", help="scene ids, ranges and layout files, e.g. 1-4 (default: all, 1-20)")
    cmd.add_argument("--steps", type=int, default=DEFAULT_STEPS, help="simulation steps per video (60 per second)")
    cmd.add_argument("--perturbations", type=int, default=DEFAULT_PERTURBATIONS,
                     help="perturbed re-simulations per video for the robustness filter (0 = none)")
    cmd.add_argument("--engine", default=DEFAULT_ENGINE, choices=SIMULATORS,
                     help=engine_help(SIMULATORS, " (default: %(default)s)"))
    add_workers_option(cmd, "local worker processes; the output is identical for any number")
    cmd.add_argument("--no-balance", action="store_true",
                     help="skip answer balancing (small sets: balancing purges (scene, template) groups with a single "
                          "answer)")
    cmd.add_argument("--quiet", action="store_true", help="no progress display and no summary")
    cmd.set_defaults(func=cmd_heldout)


__all__ = ["DEFAULT_SIZE", "HELDOUT_FILE", "card_section", "fresh_seed", "make_heldout", "reproducing_command",
           "write_card_section"]
