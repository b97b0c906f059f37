"""``craft-dsl perceive ...``: export, degrade, check, fit and execute perceived scenes (see docs/perception.md).

Results go to stdout (``--json`` for machine-readable output), messages to stderr; bad input exits 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from ..errors import CraftError
from ..ranges import parse_scene
from ..vocabulary import DEFAULT_ENGINE, ENGINES, engine_help
from .schema import PerceivedScene
from .validation import Problem

_EVENT_SOURCES = ("auto", "perceived", "derived")
_CF_MODES = ("replay", "resimulate")


def _load(args: argparse.Namespace) -> tuple[PerceivedScene, list[Problem]]:
    from .validation import load_perceived

    scene, dropped = load_perceived(args.perceived, lenient=args.lenient)
    for p in dropped:
        print(f"dropped: {p}", file=sys.stderr)
    return scene, dropped


def _model(args: argparse.Namespace, scene: PerceivedScene) -> Any:
    from .world import ExecutionOptions, SceneModel

    options = ExecutionOptions(events=args.events, counterfactual=args.counterfactual, engine=args.engine,
                               refine=getattr(args, "refine", False))
    return SceneModel(scene, options)


def _write(text: str, out: str | None) -> None:
    if out:
        from ..atomic import atomic_path

        with atomic_path(out) as tmp:
            tmp.write_text(text, encoding="utf-8")
        print(f"wrote {out}", file=sys.stderr)
    else:
        sys.stdout.write(text)


# -- commands ------------------------------------------------------------------------------------------------


def cmd_export(args: argparse.Namespace) -> int:
    from ..cli import _simulation
    from .export import export_perceived

    sim = _simulation(args)
    scene = export_perceived(sim, fps=args.fps, size=args.size, velocities=not args.no_velocities)
    _write(scene.dumps(), args.out)
    return 0


def cmd_noise(args: argparse.Namespace) -> int:
    from .noise import NoiseModel, degrade

    scene, _ = _load(args)
    try:
        noise = NoiseModel(position_sigma_px=args.position_noise, angle_sigma_rad=args.angle_noise,
                           attribute_confusion=args.attribute_confusion, event_miss_rate=args.event_miss,
                           event_false_alarm_rate=args.false_alarm, timing_jitter_frames=args.timing_jitter,
                           identity_swap_rate=args.swaps, gap_rate=args.gaps, keep_velocities=args.keep_velocities,
                           track_fps=args.track_fps)
    except ValueError as err:
        raise CraftError(f"bad noise setting: {err}") from None
    _write(degrade(scene, noise, args.seed).dumps(), args.out)
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    scene, dropped = _load(args)
    summary = {"schema_version": scene.schema_version, "scene": scene.scene, "frames": scene.video.frames,
               "fps": scene.video.fps, "objects": len(scene.objects),
               "tracks": sum(o.track is not None for o in scene.objects),
               "events": None if scene.events is None else len(scene.events),
               "dropped": [str(p) for p in dropped]}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        events = "none given (derived from tracks)" if scene.events is None else str(summary["events"])
        print(f"{args.perceived}: schema {scene.schema_version}, scene {scene.scene or 'unknown'}, "
              f"{scene.video.frames} frames at {scene.video.fps:g} fps, {len(scene.objects)} objects "
              f"({summary['tracks']} tracked), events: {events}" + (f", {len(dropped)} parts dropped"
                                                                    if dropped else ""))
    return 0


def cmd_fit(args: argparse.Namespace) -> int:
    scene, _ = _load(args)
    model = _model(args, scene)
    pw = model.physics
    drift = model.drift()
    bodies = []
    for b in pw.world.bodies:
        if not b.dynamic:
            continue
        d = drift.get(b.uid)
        bodies.append({"id": b.uid, "shape": b.shape, "size": b.size, "position_m": list(b.position),
                       "angle": b.angle, "velocity_m_s": list(b.velocity), "angular_velocity": b.angular_velocity,
                       "drift_px": None if d is None else {"mean": d.mean_px, "max": d.max_px, "final": d.final_px,
                                                           "first_step_over_1px": d.first_step_over_1px}})
    out = {"bodies": bodies, "left_out": {str(k): v for k, v in pw.left_out.items()},
           "added": {str(k): v for k, v in pw.added.items()}}
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    wb = max([16, *(len(f"{b['size']} {b['shape']}") for b in bodies)])  # as wide as the longest label
    print(f"{'id':>3}  {'body':<{wb}} {'x m':>8} {'y m':>8} {'vx m/s':>8} {'vy m/s':>8}  {'drift px mean/max/end':>22}"
          "  first step > 1 px")
    for b in bodies:
        d = b["drift_px"]
        print(f"{b['id']:>3}  {b['size'] + ' ' + b['shape']:<{wb}} {b['position_m'][0]:8.3f} {b['position_m'][1]:8.3f} "
              f"{b['velocity_m_s'][0]:8.3f} {b['velocity_m_s'][1]:8.3f}  "
              f"{d['mean']:6.2f} / {d['max']:6.2f} / {d['final']:6.2f}  {d['first_step_over_1px'] or '-'}")
    for k, v in pw.left_out.items():
        print(f"left out of the physics: object {k}: {v}", file=sys.stderr)
    return 0


def _program(args: argparse.Namespace) -> Any:
    from ..cli import _load_program

    return _load_program(args)


def cmd_run(args: argparse.Namespace) -> int:
    from ..program import format_value, to_json
    from .distribution import answer_distribution

    program = _program(args)
    scene, _ = _load(args)
    model = _model(args, scene)
    if args.distribution:
        dist = answer_distribution(model, program, bound=args.bound, samples=args.samples, seed=args.seed)
        if args.json:
            print(json.dumps({"program": str(program), **dist.to_json()}))
        else:
            se = dist.method == "monte_carlo"
            print(f"mode: {dist.mode}  ({dist.method}, {dist.samples} readings"
                  + (f"; {dist.invalid:.3f} of them had no answer" if dist.invalid else "") + ")")
            w = max([12, *(len(str(dist.answers[key])) for key in dist.probabilities)])
            for key, p in dist.probabilities.items():
                err = f" +- {dist.standard_errors[key]:.3f}" if se else ""
                print(f"  {dist.answers[key]!s:<{w}} {p:.4f}{err}")
        return 0
    answer = program.run(model.simulation())
    if args.json:
        print(json.dumps({"program": str(program), "type": str(program.type), "answer": to_json(answer)}))
    else:
        print(format_value(answer))
    return 0


def cmd_answer(args: argparse.Namespace) -> int:
    from .answering import accuracy_by_family, answer_all, read_question_file, template_questions

    scene, _ = _load(args)
    model = _model(args, scene)
    items = read_question_file(args.questions, args.video_index) if args.questions else template_questions(model)
    answered = answer_all(model, items, distribution=args.distribution, bound=args.bound, samples=args.samples,
                          seed=args.seed)
    summary = accuracy_by_family(answered)
    if args.json:
        text = json.dumps({"questions": [a.to_json() for a in answered], "accuracy": summary}, indent=2) + "\n"
        _write(text, args.out)
        return 0
    lines = []
    wq = max([18, *(len(str(a.item.template_id or a.item.index)) for a in answered)])  # never cut a label
    wa = max([10, *(len(str(a.answer)) for a in answered)])
    for a in answered:
        mark = "" if a.correct is None else ("  ok" if a.correct else f"  WRONG (truth {a.item.truth})")
        dist = ""
        if a.distribution is not None:
            dist = f"  [mode {a.distribution.mode}, p={a.distribution.p(a.distribution.mode):.2f}]"
        lines.append(f"{a.item.template_id or a.item.index!s:<{wq}} {a.answer!s:<{wa}}{dist}{mark}")
    for family, row in summary.items():
        extra = f", mode of the distribution {row['mode']:.3f}" if "mode" in row else ""
        lines.append(f"{family}: {int(row['questions'])} questions, most likely world {row['most_likely']:.3f}{extra}")
    _write("\n".join(lines) + "\n", args.out)
    return 0


def cmd_schema(args: argparse.Namespace) -> int:
    from .schema import json_schema_text

    _write(json_schema_text(), args.out)
    return 0


# -- parser --------------------------------------------------------------------------------------------------


def _execution_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--perceived", required=True, help="perceived-scene JSON file")
    p.add_argument("--lenient", action="store_true", help="drop the bad parts of the file (listed on stderr)")
    p.add_argument("--events", default="auto", choices=_EVENT_SOURCES,
                   help="factual events: the file's, derived from the tracks, or auto (default auto)")
    p.add_argument("--counterfactual", default="replay", choices=_CF_MODES,
                   help="counterfactual runs: replayed against the tracks or re-simulated from the fitted start "
                        "(default replay)")
    p.add_argument("--engine", default=None, choices=ENGINES,
                   help="physics engine of the re-simulations (default: the one the scene names in its 'physics' "
                        f"field, else {DEFAULT_ENGINE})")
    p.add_argument("--json", action="store_true", help="print JSON")


def _distribution_args(p: argparse.ArgumentParser) -> None:
    from .distribution import DEFAULT_BOUND, DEFAULT_SAMPLES

    p.add_argument("--distribution", action="store_true", help="answer distributions over the uncertain readings")
    p.add_argument("--bound", type=int, default=DEFAULT_BOUND,
                   help=f"enumerate readings exactly up to this many (default {DEFAULT_BOUND})")
    p.add_argument("--samples", type=int, default=DEFAULT_SAMPLES,
                   help=f"Monte Carlo readings beyond the bound (default {DEFAULT_SAMPLES})")
    p.add_argument("--seed", type=int, default=0, help="Monte Carlo seed (default 0)")


def add_commands(sub: Any) -> None:
    perceive = sub.add_parser("perceive", help="run programs over a perceived scene (what a perception model saw)")
    cmds = perceive.add_subparsers(dest="perceive_command", required=True, metavar="COMMAND")

    export = cmds.add_parser("export", help="the ground-truth perceived scene of a simulation")
    export.add_argument("--scene", type=parse_scene,
                        help="simulate this scene layout (1-20 or a layout file) live (default: none: give --scene "
                             "or --sim)")
    export.add_argument("--seed", type=int, default=0, help="seed of the live simulation (default 0)")
    export.add_argument("--engine", default=DEFAULT_ENGINE, choices=ENGINES,
                        help=engine_help(ENGINES, " (default: %(default)s)"))
    export.add_argument("--sim", help="or a recorded simulation JSON file (no tracks: start/end states only; "
                                      "default: none)")
    export.add_argument("--fps", type=float, default=60, help="frame rate of the video and tracks (default 60)")
    export.add_argument("--size", type=int, default=256, help="video size in pixels (default 256)")
    export.add_argument("--no-velocities", action="store_true", help="tracks without velocities (positions only)")
    export.add_argument("--out", help="output file (default stdout)")
    export.set_defaults(func=cmd_export)

    noise = cmds.add_parser("noise", help="degrade a perceived scene with the seeded noise model")
    noise.add_argument("perceived", help="perceived-scene JSON file")
    noise.add_argument("--lenient", action="store_true", help="drop the bad parts of the input")
    noise.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    noise.add_argument("--position-noise", type=float, default=0.0, help="position noise, pixels (default 0)")
    noise.add_argument("--angle-noise", type=float, default=0.0, help="angle noise, radians (default 0)")
    noise.add_argument("--attribute-confusion", type=float, default=0.0,
                       help="share of colours/shapes/sizes replaced (default 0)")
    noise.add_argument("--event-miss", type=float, default=0.0, help="share of events missed (default 0)")
    noise.add_argument("--false-alarm", type=float, default=0.0,
                       help="spurious events per true event (default 0)")
    noise.add_argument("--timing-jitter", type=int, default=0, help="event frames moved by up to this (default 0)")
    noise.add_argument("--swaps", type=float, default=0.0, help="expected identity swaps per video (default 0)")
    noise.add_argument("--gaps", type=float, default=0.0, help="expected gaps per track (default 0)")
    noise.add_argument("--keep-velocities", action="store_true", help="keep the tracks' velocities")
    noise.add_argument("--track-fps", type=float,
                       help="subsample the tracks to this frame rate (default: none, every frame kept)")
    noise.add_argument("--out", help="output file (default stdout)")
    noise.set_defaults(func=cmd_noise)

    check = cmds.add_parser("check", help="validate a perceived-scene file (exit 2 with every problem named)")
    check.add_argument("perceived", help="perceived-scene JSON file")
    check.add_argument("--lenient", action="store_true", help="drop the bad parts and list them instead")
    check.add_argument("--json", action="store_true", help="print JSON")
    check.set_defaults(func=cmd_check)

    fit = cmds.add_parser("fit", help="the fitted initial state and the re-simulation's drift per object")
    _execution_args(fit)
    fit.add_argument("--refine", action="store_true", help="refine the initial velocities by minimising the drift")
    fit.set_defaults(func=cmd_fit)

    run = cmds.add_parser("run", help="run a program over a perceived scene")
    run.add_argument("program", nargs="?", help="program text, or @file")
    run.add_argument("--nodes", help="read the program as a CLEVR/CRAFT node list from this JSON file "
                                     "(default: none, the PROGRAM argument)")
    run.add_argument("--param", action="append", default=[], metavar="<Z>=small",
                     help="bind a template placeholder of a node list (repeatable; default: none)")
    _execution_args(run)
    _distribution_args(run)
    run.set_defaults(func=cmd_run)

    answer = cmds.add_parser("answer", help="answer every question (a question file, or every template) over a "
                                            "perceived scene")
    answer.add_argument("--questions", help="question records with programs (generate_questions output) or a CRAFT "
                                            "dataset.json; default: the first instance of each of the 48 templates")
    answer.add_argument("--video-index", type=int,
                        help="the video of a multi-video question file (default: none: every record of a question "
                             "list; a dataset.json must then hold one video)")
    answer.add_argument("--out", help="output file (default stdout)")
    _execution_args(answer)
    _distribution_args(answer)
    answer.set_defaults(func=cmd_answer)

    schema = cmds.add_parser("schema", help="print (or write) the JSON Schema of perceived scenes")
    schema.add_argument("--out", help="output file, e.g. docs/perceived_scene.schema.json (default stdout)")
    schema.set_defaults(func=cmd_schema)
