"""Command ``craft-dsl generate``: generate a CRAFT-format dataset (see docs/dataset.md).

Exit codes: 0 done; 2 bad configuration, a folder made with other settings, or failed instances (raised as
:class:`CraftError`; re-running the same command resumes); 130 interrupted (Ctrl-C; re-running resumes).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import TYPE_CHECKING, Any

from ..errors import CraftError
from ..files import read_json
from ..parallel import add_workers_option
from ..ranges import parse_ranges, parse_scenes
from ..vocabulary import DEFAULT_ENGINE, ORIGINAL_ENGINE, SIMULATORS, engine_help
from .samplers import DEFAULT_SAMPLER, ORIGINAL_SAMPLER, SAMPLER_ALIASES, SAMPLERS

if TYPE_CHECKING:
    from .pipeline import GenerationConfig

#: Frame rates ``--downsampled`` accepts (the videos run at 60 frames per second).
DOWNSAMPLED_FPS = (1, 60)


class _Bars:
    """One tqdm bar per stage (rate and time left), on stderr."""

    def __init__(self) -> None:
        self.bars: dict[str, Any] = {}

    def start(self, stage: str, total: int, unit: str) -> None:
        from tqdm import tqdm

        label = {"videos": "simulate + ask", "merge": "merge"}.get(stage, stage)
        self.bars[stage] = tqdm(total=total, unit=unit, desc=f"{label:>14}", file=sys.stderr,
                                position=len(self.bars), dynamic_ncols=True)

    def advance(self, stage: str, n: int = 1) -> None:
        bar = self.bars.get(stage)
        if bar is not None and n:
            bar.update(n)

    def close(self) -> None:
        for bar in self.bars.values():
            bar.close()
        self.bars.clear()


#: The options that decide what a dataset holds: with ``--config`` the file decides them, so none may be given.
CONTENT_OPTIONS = ("size", "seed", "scenes", "steps", "perturbations", "amount", "engine", "sampler", "templates",
                   "no_balance", "videos", "video_format", "downsampled")


def config_from_args(args: argparse.Namespace) -> GenerationConfig:
    """The generation config of the command line, or of ``--config FILE`` (a recorded ``generation_config.json``).

    Without ``--engine`` (``--sampler``), a run in a folder that holds a dataset resumes with the engine (sampler)
    its configuration names, or the default of its time where it names none: pymunk (revision 1 of the layouts);
    a new folder gets the default engine (sampler)."""
    from .pipeline import GenerationConfig, recorded_setting

    if args.config is not None:
        given = [f"--{k.replace('_', '-')}" for k in CONTENT_OPTIONS if getattr(args, k) != args.defaults[k]]
        if given:
            raise CraftError(f"--config {args.config} decides every setting of the dataset; drop {', '.join(given)}")
        return GenerationConfig.from_recorded(read_json(args.config, "generation config"), args.config,
                                              workers=args.workers)
    if args.size is None:
        raise CraftError("give --size N (the number of videos), or --config FILE to make a dataset its "
                         "generation_config.json records")
    fields: dict[str, Any] = {"size": args.size, "seed": args.seed, "steps": args.steps,
                              "perturbations": args.perturbations, "amount": args.amount,
                              "workers": args.workers, "videos": args.videos,
                              "engine": args.engine or recorded_setting(args.out, "engine") or DEFAULT_ENGINE,
                              "sampler": (SAMPLER_ALIASES.get(args.sampler, args.sampler)
                                          or recorded_setting(args.out, "sampler") or DEFAULT_SAMPLER),
                              "balance": not args.no_balance, "video_format": args.video_format}
    if args.downsampled:
        fields["downsampled"] = parse_ranges(args.downsampled, "--downsampled", *DOWNSAMPLED_FPS, "frame rates")
    if args.scenes is not None:
        fields["scenes"] = tuple(parse_scenes(args.scenes))
    if args.templates is not None:
        fields["templates"] = tuple(t.strip() for t in args.templates.split(",") if t.strip())
    return GenerationConfig.make(**fields)


def cmd_generate(args: argparse.Namespace) -> int:
    from .executors import make_executor
    from .pipeline import generate_dataset

    config = config_from_args(args)
    if args.scheduler and args.executor != "dask":
        raise CraftError("--scheduler is for --executor dask")
    if config.engine == ORIGINAL_ENGINE or config.sampler == ORIGINAL_SAMPLER:
        from ..physics.original import find_binary

        find_binary()  # not built: one line saying how to build it, not one per video
    if config.engine != ORIGINAL_ENGINE and args.executor == "local":
        from ..physics.live import get_engine

        get_engine(config.engine)  # a missing extra (box2d): one line naming its pip install, not one per video
    executor = make_executor(args.executor, config.workers, args.scheduler)

    bars = _Bars() if not args.quiet and sys.stderr.isatty() else None
    echo: Any = None if args.quiet else _resume_note if bars is not None else _print_err
    start = time.perf_counter()
    try:
        report = generate_dataset(config, args.out, executor=executor, progress=bars, force=args.force, echo=echo)
    except KeyboardInterrupt:
        if bars is not None:
            bars.close()
        print(f"\ninterrupted: the finished work is saved in {args.out}; re-run the same command to resume",
              file=sys.stderr)
        return 130
    elapsed = time.perf_counter() - start
    if not args.quiet:
        q = report["questions"]
        v = report["videos"]
        computed = v["total"] - report["resumed"]
        rate = f", {60 * computed / elapsed:.1f} videos/min" if computed and elapsed > 0 else ""
        print(f"generated {args.out}: {v['total']} videos ({v['with_questions']} with questions), "
              f"{q['final']} questions in {elapsed:.1f} s{rate}")
        pp = sum(q["dropped_by_post_process"].values())
        bal = sum(q["dropped_by_balancing"].values())
        print(f"  questions: {q['generated']} generated, -{q['dropped_by_perturbation']} perturbation filter, "
              f"-{pp} post-process, -{bal} balancing = {q['final']}")
        if q["final"] == 0 and q["after_post_process"] > 0:
            print("  warning: balancing removed every question: it purges (scene, template) groups with a single "
                  "answer, so each scene needs several videos (e.g. --size 40 --scenes 1-4), or use --no-balance",
                  file=sys.stderr)
        for name in ("hard", "random"):
            s = report["splits"][name]
            print(f"  split {name}: train {s['train']}, validation {s['validation']}, test {s['test']}")
        print(f"  check it: craft-dsl verify --dataset {args.out}/dataset.json "
              f"--annotations {args.out}/annotations.json")
        hf = "JSONL and Parquet" if report.get("hf_parquet") else "JSONL (pip install 'craft-dsl[hf]' for Parquet)"
        print(f"  Hugging Face: {hf} in {args.out}/hf, card {args.out}/README.md; "
              f"charts: craft-dsl stats {args.out}; browse: craft-dsl view {args.out}")
    return 0


def _print_err(message: str) -> None:
    print(message, file=sys.stderr)


def _resume_note(message: str) -> None:
    """With progress bars, only the resume note is printed (the log file has every line)."""
    if message.startswith("resuming"):
        print(message, file=sys.stderr)


def add_commands(sub: Any) -> None:
    gen = sub.add_parser("generate", help="generate a CRAFT-format dataset (simulate, ask, filter, balance, split)",
                         description="Generate a CRAFT-format dataset into --out (docs/dataset.md). Re-running the "
                                     "same command in the same folder resumes an interrupted run.")
    gen.add_argument("--size", type=int, help="number of videos (no default: required unless --config)")
    gen.add_argument("--config", metavar="generation_config.json",
                     help="make the dataset this recorded configuration describes (another dataset's "
                          "generation_config.json: the same bytes, resumed or anew); every content option is then "
                          "the file's (default: none, the options given)")
    gen.add_argument("--seed", type=int, default=0, help="the seed of every random draw (default 0)")
    gen.add_argument("--out", required=True, help="output folder")
    gen.add_argument("--scenes", help="scene ids, ranges and layout files, e.g. 1,2,5-7 or 1-4,my_layouts/ramp.json "
                                      "(default: all, 1-20); a layout's records use its own \"scene\" id")
    add_workers_option(gen, "local worker processes; the output is identical for any number")
    gen.add_argument("--executor", default="local", choices=("local", "dask"),
                     help="where videos are computed: local processes (default) or a Dask cluster (needs "
                          "--scheduler and pip install 'craft-dsl[dask]'); the output is identical")
    gen.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                     help="with --executor dask: the address of the Dask scheduler (default: none)")
    gen.add_argument("--force", action="store_true",
                     help="run in a folder made with other settings: start over (or only add media when just "
                          "--videos/--downsampled differ)")
    gen.add_argument("--perturbations", type=int, default=3,
                     help="perturbed re-simulations per video for the robustness filter (default 3; 0 = none)")
    gen.add_argument("--amount", type=float, default=0.02, help="perturbation noise amount (default 0.02)")
    gen.add_argument("--steps", type=int, default=600, help="simulation steps per video (default 600 = 10 s)")
    gen.add_argument("--videos", action="store_true",
                     help="also render each video with its first and last frames as PNG (slower)")
    gen.add_argument("--video-format", default="mpg", choices=("mpg", "mp4"),
                     help="mpg: MPEG-1 as the published CRAFT dataset (default); mp4: H.264 for modern loaders")
    gen.add_argument("--downsampled", metavar="FPS",
                     help="with --videos, also write H.264 videos at these frame rates (1-60), e.g. 5,10 "
                          "(downsampled/<fps>-fps/, as the published models read them; default: none)")
    gen.add_argument("--engine", default=None, choices=SIMULATORS,
                     help=engine_help(SIMULATORS, "; with original its renderer draws the videos too. Default: the "
                                                  "engine the --out folder's generation_config.json names when "
                                                  f"resuming (pymunk where it names none), else {DEFAULT_ENGINE}"))
    gen.add_argument("--sampler", default=None, choices=(*SAMPLER_ALIASES, *SAMPLERS),
                     help="who draws each video's start state: layouts (the layout files, revision 2 = layouts-2), "
                          "layouts-1 (the layouts' revision of datasets made before), or original (the original "
                          "simulator's own sampler, seeded; built-in scenes only; build it first: docs/original.md). "
                          "With --engine original --sampler original the dataset is made as the original pipeline "
                          "makes it. Default: the sampler the --out folder's generation_config.json names when "
                          f"resuming (layouts-1 where it names none), else {DEFAULT_SAMPLER}")
    gen.add_argument("--templates", help="comma-separated template ids (default: all 67)")
    gen.add_argument("--no-balance", action="store_true",
                     help="skip answer balancing (small datasets: balancing purges every (scene, template) group "
                          "with a single answer)")
    gen.add_argument("--quiet", action="store_true",
                     help="no progress display and no summary (the log file generation.log is still written)")
    gen.set_defaults(func=cmd_generate, defaults={k: gen.get_default(k) for k in CONTENT_OPTIONS})
