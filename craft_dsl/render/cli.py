"""``craft-dsl render``: a video or a single frame of a simulated scene."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..errors import CraftError
from ..ranges import parse_scene
from ..vocabulary import DEFAULT_ENGINE, ENGINES, engine_help
from ..world import DEFAULT_STEPS


def cmd_render(args: argparse.Namespace) -> int:
    from ..physics import simulate
    from . import write_png, write_video

    out = Path(args.out)
    ext = out.suffix.lower()
    if args.frame is None and ext == ".png":
        raise CraftError("a .png output needs --frame N (the state after N steps)")
    if args.frame is not None and ext != ".png":
        raise CraftError(f"--frame writes a PNG; give --out with the .png extension, not {ext or '(none)'!r}")
    sim = simulate(args.scene, seed=args.seed, steps=args.steps, engine=args.engine)
    if args.frame is not None:
        write_png(sim, out, args.frame)
    else:
        write_video(sim, out, fps=args.fps, progress=not args.quiet and sys.stderr.isatty())
    print(f"wrote {out}")
    return 0


def add_commands(sub: Any) -> None:
    render = sub.add_parser("render", help="render a simulated scene as a video (.mp4, .mpg, .gif) or a frame (.png)")
    render.add_argument("--scene", type=parse_scene, required=True, help="scene layout 1-20, or a layout file")
    render.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    render.add_argument("--out", required=True,
                        help="output file: .mp4 (H.264), .mpg (MPEG-1, as the published CRAFT videos), .gif, "
                             "or .png with --frame")
    render.add_argument("--frame", type=int,
                        help="write only the frame after this many steps, as PNG (default: none, the video)")
    render.add_argument("--fps", type=float, default=60, help="frames per second, at most 60 (default 60)")
    render.add_argument("--steps", type=int, default=DEFAULT_STEPS, help="simulation steps (default 600 = 10 s)")
    render.add_argument("--engine", default=DEFAULT_ENGINE, choices=ENGINES,
                        help=engine_help(ENGINES, " (default: %(default)s)"))
    render.add_argument("--quiet", action="store_true", help="no progress bar")
    render.set_defaults(func=cmd_render)
