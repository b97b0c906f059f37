"""The progress convention of every long-running command."""

from __future__ import annotations

import argparse
import sys


def show_progress(args: argparse.Namespace) -> bool:
    """The progress convention of every long-running command: a bar on stderr when it is a terminal, none with
    ``--quiet``, always with ``--progress``."""
    if getattr(args, "quiet", False):
        return False
    return bool(getattr(args, "progress", False)) or sys.stderr.isatty()
