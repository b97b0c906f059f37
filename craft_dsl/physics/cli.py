"""Command-line commands of the physics package: ``simulate``, ``scenes stats`` and ``engines compare``."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..cli import DeprecatedAlias
from ..parallel import add_workers_option
from ..ranges import parse_scene, parse_scenes
from ..vocabulary import DEFAULT_ENGINE, ORIGINAL_ENGINE, SIMULATORS, engine_help
from ..world import DEFAULT_STEPS

_STEPS_HELP = f"simulation steps per run, 60 per second (default {DEFAULT_STEPS} = {DEFAULT_STEPS // 60} s)"


def cmd_simulate(args: argparse.Namespace) -> int:
    from ..recorded import save_simulation
    from ..simulation import Simulation
    from .live import simulate, world_and_meta

    sim: Simulation
    if args.video is None:
        sim = simulate(parse_scene(args.scene), seed=args.seed, steps=args.steps, engine=args.engine)
    elif args.engine != ORIGINAL_ENGINE:
        print("error: --video takes the original renderer's video (--engine original); for pymunk and box2d "
              "use craft-dsl render", file=sys.stderr)
        return 2
    else:  # one run of the original, drawn and encoded
        from .original import simulate_original

        world, meta = world_and_meta(parse_scene(args.scene), args.seed)
        sim = simulate_original(world, args.steps, video=args.video, meta=meta)
    save_simulation(sim, args.out, variations=not args.no_variations)
    n_var = 0 if args.no_variations else len(sim.dynamic_ids)
    print(f"wrote {args.out}: scene {sim.meta['scene']} seed {sim.meta['seed']}, {len(sim.events)} events, "
          f"{n_var} variations", file=sys.stderr)
    return 0


def cmd_scene_stats(args: argparse.Namespace) -> int:
    from ..analysis.scene_stats import format_table, scene_stats

    rows = []
    for scene in parse_scenes(args.scenes):
        row = scene_stats(scene, range(args.seeds), engine=args.engine, steps=args.steps)
        rows.append(row)
        print(f"scene {scene}: {row.runs} runs, {row.sims_per_second:.1f} sims/s", file=sys.stderr, flush=True)
    print(format_table(rows, markdown=args.markdown))
    return 0


def cmd_engines_compare(args: argparse.Namespace) -> int:
    from ..analysis.engines import compare_engines, default_reference, format_comparison, stderr_progress
    from .live import get_engine

    engines = tuple(e.strip() for e in args.engines.split(","))
    unknown = [e for e in engines if e not in SIMULATORS]
    if unknown or not engines or (len(engines) < 2 and args.perturb <= 0):
        what = f"unknown engine {unknown[0]!r}" if unknown else "it needs two engines, or one and --perturb"
        print(f"error: --engines: {what}; takes a comma-separated list of {', '.join(SIMULATORS)}, e.g. "
              "pymunk,box2d or pymunk,box2d,original", file=sys.stderr)
        return 2
    reference = args.reference or default_reference(engines)
    if reference not in engines:
        print(f"error: --reference {reference} is not among --engines {','.join(engines)}", file=sys.stderr)
        return 2
    if ORIGINAL_ENGINE in engines:
        from .original import find_binary

        find_binary()  # one clear error before any work if it is not built
    for name in dict.fromkeys(e for e in engines if e != ORIGINAL_ENGINE):
        get_engine(name)  # a missing extra (box2d): one line naming its pip install before any process starts
    scenes = parse_scenes(args.scenes)
    jobs = max(1, min(args.workers, len(scenes) * args.seeds))  # no process without a (scene, seed) to run
    cmp = compare_engines(scenes, range(args.seeds), engines=engines, reference=reference,
                          steps=args.steps, jobs=jobs, perturb=args.perturb,
                          progress=None if args.quiet else stderr_progress)
    print(format_comparison(cmp, markdown=args.markdown))
    print(f"done in {cmp.seconds:.1f} s", file=sys.stderr)
    return 0


def cmd_engines_original(args: argparse.Namespace) -> int:
    from .original import check, find_binary

    if args.check:
        print(check())
    else:
        print(find_binary())
    return 0


def add_commands(subparsers: Any) -> None:
    """Register ``simulate``, ``scenes stats`` and ``engines compare`` on the main CLI's subparsers."""
    sim = subparsers.add_parser("simulate", help="simulate a scene with live physics and save it as JSON")
    sim.add_argument("--scene", required=True, help="scene id 1-20 or a layout file")
    sim.add_argument("--seed", type=int, default=0, help="seed of the scene's random layout")
    sim.add_argument("--steps", type=int, default=DEFAULT_STEPS, help=_STEPS_HELP)
    sim.add_argument("--engine", default=DEFAULT_ENGINE, choices=SIMULATORS,
                     help=engine_help(SIMULATORS, " (default: %(default)s)"))
    sim.add_argument("--video", metavar="FILE.mpg",
                     help="with --engine original: also write the original renderer's MPEG-1 video of the factual "
                          "run (default: none)")
    sim.add_argument("--out", required=True, help="output JSON (original format)")
    sim.add_argument("--no-variations", action="store_true", help="do not run the counterfactuals")
    sim.set_defaults(func=cmd_simulate)

    if "scenes" in subparsers.choices:  # another package owns "scenes"; expose stats on its own
        scenes_sub = None
    else:
        scenes = subparsers.add_parser("scenes", help="scene utilities")
        scenes_sub = scenes.add_subparsers(dest="scenes_command", required=True, metavar="SUBCOMMAND")
    stats = (scenes_sub.add_parser("stats", help="per-scene statistics over seeds") if scenes_sub is not None
             else subparsers.add_parser("scene-stats", help="per-scene statistics over seeds"))
    stats.add_argument("--seeds", type=int, default=200, help="seeds 0..N-1 per scene")
    stats.add_argument("--scenes", help="ids, ranges and layout files, e.g. 1,2,5-7 (default: all 20)")
    stats.add_argument("--steps", type=int, default=DEFAULT_STEPS, help=_STEPS_HELP)
    stats.add_argument("--engine", default=DEFAULT_ENGINE, choices=SIMULATORS,
                       help=engine_help(SIMULATORS, " (default: %(default)s)"))
    stats.add_argument("--markdown", action="store_true", help="print a Markdown table")
    stats.set_defaults(func=cmd_scene_stats)

    engines = subparsers.add_parser("engines", help="physics engine utilities")
    engines_sub = engines.add_subparsers(dest="engines_command", required=True, metavar="SUBCOMMAND")
    comp = engines_sub.add_parser("compare", help="how much question answers depend on the physics engine")
    comp.add_argument("--scenes", default="all", help="all, or ids, ranges and layout files, e.g. 1,2,5-7,my.json")
    comp.add_argument("--seeds", type=int, default=200, help="seeds 0..N-1 per scene")
    comp.add_argument("--steps", type=int, default=DEFAULT_STEPS, help=_STEPS_HELP)
    comp.add_argument("--engines", default="pymunk,box2d",
                      help="engines, comma-separated, of " + ", ".join(SIMULATORS) + ": questions are instantiated "
                           "on the reference and re-run on each of the others (default: %(default)s)")
    comp.add_argument("--reference", choices=SIMULATORS,
                      help="the engine the others are compared with (default: original if listed, else the first)")
    add_workers_option(comp, "worker processes, one (scene, seed) at a time each; the results are identical for "
                             "any number")
    comp.add_argument("--jobs", type=int, dest="workers", action=DeprecatedAlias, replacement="--workers")
    comp.add_argument("--perturb", type=float, default=0.0, metavar="AMOUNT",
                      help="also run the reference from the original's perturbation of the start state (e.g. 0.02; "
                           "perturbation seed = scene seed): its agreement with itself is the floor chaos sets "
                           "(default: %(default)s, none)")
    comp.add_argument("--markdown", action="store_true", help="print Markdown tables")
    comp.add_argument("--quiet", action="store_true", help="no progress on stderr")
    comp.set_defaults(func=cmd_engines_compare)

    orig = engines_sub.add_parser("original", help="the original CRAFT simulator: is it built, and does it run?")
    orig.add_argument("--check", action="store_true",
                      help="run scene 1 for 60 steps with it and report (exit 2 with the reason if it fails)")
    orig.set_defaults(func=cmd_engines_original)
