"""Command-line commands of the physics package: ``simulate``, ``scenes stats`` and ``engines compare``."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..ranges import parse_scene, parse_scenes
from ..vocabulary import ENGINES
from ..world import DEFAULT_STEPS


def cmd_simulate(args: argparse.Namespace) -> int:
    from ..recorded import save_simulation
    from .live import simulate

    sim = simulate(parse_scene(args.scene), seed=args.seed, steps=args.steps, engine=args.engine)
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
    from ..analysis.engines import compare_engines, format_comparison, stderr_progress

    engines = tuple(args.engines.split(","))
    if len(engines) != 2 or any(e not in ENGINES for e in engines):
        print(f"error: --engines takes two of {', '.join(ENGINES)}, e.g. pymunk,box2d", file=sys.stderr)
        return 2
    cmp = compare_engines(parse_scenes(args.scenes), range(args.seeds), engines=(engines[0], engines[1]),
                          steps=args.steps, jobs=args.workers, perturb=args.perturb,
                          progress=None if args.quiet else stderr_progress)
    print(format_comparison(cmp, markdown=args.markdown))
    print(f"done in {cmp.seconds:.1f} s", file=sys.stderr)
    return 0


def add_commands(subparsers: Any) -> None:
    """Register ``simulate``, ``scenes stats`` and ``engines compare`` on the main CLI's subparsers."""
    sim = subparsers.add_parser("simulate", help="simulate a scene with live physics and save it as JSON")
    sim.add_argument("--scene", required=True, help="scene id 1-20 or a layout file")
    sim.add_argument("--seed", type=int, default=0)
    sim.add_argument("--steps", type=int, default=DEFAULT_STEPS)
    sim.add_argument("--engine", default="pymunk", choices=ENGINES, help="physics engine")
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
    stats.add_argument("--steps", type=int, default=DEFAULT_STEPS)
    stats.add_argument("--engine", default="pymunk", choices=ENGINES, help="physics engine")
    stats.add_argument("--markdown", action="store_true", help="print a Markdown table")
    stats.set_defaults(func=cmd_scene_stats)

    engines = subparsers.add_parser("engines", help="physics engine utilities")
    engines_sub = engines.add_subparsers(dest="engines_command", required=True, metavar="SUBCOMMAND")
    comp = engines_sub.add_parser("compare", help="how much question answers depend on the physics engine")
    comp.add_argument("--scenes", default="all", help="all, or ids, ranges and layout files, e.g. 1,2,5-7,my.json")
    comp.add_argument("--seeds", type=int, default=200, help="seeds 0..N-1 per scene")
    comp.add_argument("--steps", type=int, default=DEFAULT_STEPS)
    comp.add_argument("--engines", default="pymunk,box2d",
                      help="two engines: questions are instantiated on the first and re-run on the second")
    comp.add_argument("--workers", "--jobs", dest="workers", type=int, default=1,
                      help="worker processes (results do not depend on it; --jobs is the old name)")
    comp.add_argument("--perturb", type=float, default=0.0, metavar="AMOUNT",
                      help="start the second run from the original's perturbation (e.g. 0.02; perturbation seed ="
                           " scene seed): with the same engine twice, a chaos baseline")
    comp.add_argument("--markdown", action="store_true", help="print Markdown tables")
    comp.add_argument("--quiet", action="store_true", help="no progress on stderr")
    comp.set_defaults(func=cmd_engines_compare)
