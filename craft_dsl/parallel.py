"""How many worker processes fit this machine: the one place that counts the usable CPU cores.

Every command that parallelises (``generate``, ``read``, ``engines compare``) takes ``--workers N`` with
:func:`usable_cpu_count` as its default (:func:`add_workers_option`); their outputs do not depend on ``N``.
"""

from __future__ import annotations

import argparse
import os
from typing import Any


def usable_cpu_count() -> int:
    """The CPU cores this process may run on (at least 1).

    ``os.process_cpu_count()`` where Python has it (3.13+: the affinity mask, and ``PYTHON_CPU_COUNT``), else the
    size of the affinity mask (Linux: a container's or ``taskset``'s cores, not the machine's), else
    ``os.cpu_count()``."""
    process_cpu_count: Any = getattr(os, "process_cpu_count", None)
    if process_cpu_count is not None:
        n = process_cpu_count()
    elif hasattr(os, "sched_getaffinity"):
        n = len(os.sched_getaffinity(0))
    else:  # pragma: no cover - macOS, Windows before 3.13
        n = os.cpu_count()
    return max(1, n or 1)


def _worker_count(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number of processes, not {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"give at least 1, not {n}")
    return n


def add_workers_option(parser: argparse.ArgumentParser, what: str) -> None:
    """Add ``--workers N`` to a command's ``parser``: ``what`` the workers are; the default is
    :func:`usable_cpu_count`, resolved here, and ``--help`` shows it."""
    n = usable_cpu_count()
    parser.add_argument("--workers", type=_worker_count, default=n, metavar="N",
                        help=f"{what} (default: the usable CPU cores, {n} here)")


__all__ = ["add_workers_option", "usable_cpu_count"]
