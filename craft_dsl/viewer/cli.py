"""Command ``craft-dsl view DIR``: serve the dataset viewer on a local port until interrupted.

Exit codes: 0 stopped with Ctrl-C; 2 not a dataset folder, or the port cannot be opened.
"""

from __future__ import annotations

import argparse
import sys
import webbrowser
from typing import Any

from ..errors import CraftError


def cmd_view(args: argparse.Namespace) -> int:
    from .server import Viewer

    try:
        viewer = Viewer(args.dataset, args.host, args.port,
                        log=(lambda line: print(line, file=sys.stderr)) if args.verbose else None)
    except OSError as err:
        raise CraftError(f"cannot serve on {args.host}:{args.port}: {err.strerror}") from None
    print(f"serving {args.dataset} at {viewer.url} (Ctrl-C to stop)", file=sys.stderr, flush=True)
    if args.open:
        webbrowser.open(viewer.url)
    try:
        viewer.serve_forever()
    except KeyboardInterrupt:
        print("stopped", file=sys.stderr)
    finally:
        viewer.httpd.server_close()
    return 0


def add_commands(sub: Any) -> None:
    p = sub.add_parser("view", help="browse a dataset folder in a local web viewer",
                       description="Serve a local web page to browse a CRAFT-format dataset folder: videos and "
                                   "questions with filters, each question's program with every node's value, the "
                                   "causal graph of the video's events, and counterfactual runs beside the factual "
                                   "one (docs/dataset-users.md).")
    p.add_argument("dataset", help="dataset folder (holds dataset_minimal.json, dataset.json, annotations.json)")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=8765, help="port (default 8765; 0 picks a free one)")
    p.add_argument("--open", action="store_true", help="open the page in the default web browser")
    p.add_argument("--verbose", action="store_true", help="log every request on stderr")
    p.set_defaults(func=cmd_view)
