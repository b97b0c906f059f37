"""What the durable atomic writes (:func:`craft_dsl.atomic.atomic_path`) cost ``craft-dsl generate``.

Run: ``python benchmarks/atomic_cost.py [--size 40] [--video-size 10] [--repeat 5] [--folder-files 0,1000,10000]``.

1. ``generate``: ``craft-dsl generate --size SIZE --seed S --out DIR`` (no videos) and ``--size VIDEO_SIZE
   --videos``, each a subprocess, once as shipped (every atomic write flushes the file and its folder with
   ``os.fsync``) and once with ``os.fsync`` replaced by a no-op in every process of the run (a ``sitecustomize``
   module put first on ``PYTHONPATH``, read only by these subprocesses: the package has no such switch). The two
   variants alternate (on, off, off, on, ...) ``--repeat`` times each, each run into a fresh folder. The fsync calls
   of one run are counted.
2. ``scan``: the look for stale temporary files that atomic writes make first, in this process: 500 small atomic
   writes (after one untimed round of each variant) into a folder already holding ``--folder-files`` files, as
   shipped (the folder listed once, the listing reused for a minute), with a listing at every write, and with no
   look at all (``remove_stale_temporaries`` replaced by a no-op), fsync off in all three; the first two are given
   against the third.

Printed: ratios only (with fsync / without; with the look / without it): the median of the pairs' ratios, the ratio of
the medians and of the best times, each pair's, and the load average before and after (the machine may be
shared). Figures are printed, never asserted.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

SEED = 20
ROOT = Path(__file__).resolve().parents[1]
#: atomic writes of one round of the scan measurement
WRITES = 500

#: Read at interpreter start by every process of a generate run (workers included) when its folder is first on
#: PYTHONPATH: counts the fsync calls, and with ATOMIC_COST_NO_FSYNC=1 makes them no-ops.
SITECUSTOMIZE = '''
import atexit, os
_real_fsync = os.fsync
_calls = [0]
def _fsync(fd):
    _calls[0] += 1
    if os.environ.get("ATOMIC_COST_NO_FSYNC") != "1":
        _real_fsync(fd)
os.fsync = _fsync
def _report():
    path = os.environ.get("ATOMIC_COST_COUNT")
    if path and _calls[0]:
        with open(path, "a") as fh:
            fh.write(f"{_calls[0]}\\n")
atexit.register(_report)
'''


def _load() -> str:
    try:
        return " ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover - not POSIX
        return "?"


def _generate(size: int, videos: bool, fsync: bool, work: Path, hooks: Path) -> tuple[float, int]:
    """Seconds of one generate run and the fsync calls it made."""
    out = work / f"out-{time.monotonic_ns()}"
    count = work / f"count-{time.monotonic_ns()}"
    cmd = [sys.executable, "-m", "craft_dsl", "generate", "--size", str(size), "--seed", str(SEED), "--out",
           str(out), "--quiet", *(["--videos"] if videos else [])]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(hooks), str(ROOT), os.environ.get("PYTHONPATH", "")]),
           "ATOMIC_COST_NO_FSYNC": "0" if fsync else "1", "ATOMIC_COST_COUNT": str(count)}
    start = time.perf_counter()
    subprocess.run(cmd, check=True, env=env, cwd=work)
    seconds = time.perf_counter() - start
    calls = sum(int(line) for line in count.read_text().split()) if count.exists() else 0
    return seconds, calls


def _ratios(label: str, on: list[float], off: list[float]) -> None:
    pairs = [a / b for a, b in zip(on, off, strict=True)]
    print(f"{label}: with / without  median of pairs {statistics.median(pairs):.3f}  "
          f"of medians {statistics.median(on) / statistics.median(off):.3f}  best {min(on) / min(off):.3f}  "
          f"(pairs: {' '.join(f'{r:.3f}' for r in pairs)})")


def bench_generate(size: int, videos: bool, repeat: int, work: Path, hooks: Path) -> None:
    times: dict[bool, list[float]] = {True: [], False: []}
    calls = 0
    for i in range(repeat):
        for fsync in ((True, False) if i % 2 == 0 else (False, True)):
            seconds, n = _generate(size, videos, fsync, work, hooks)
            times[fsync].append(seconds)
            calls = max(calls, n)
    label = f"generate --size {size}" + (" --videos" if videos else "")
    _ratios(f"{label} ({calls} fsync calls a run)", times[True], times[False])


def bench_scan(folder_files: int, repeat: int, work: Path) -> None:
    from craft_dsl import atomic

    folder = work / f"scan-{folder_files}"
    folder.mkdir()
    for i in range(folder_files):
        (folder / f"qa_{i:06d}.json").write_bytes(b"{}")
    real_fsync, real_scan = os.fsync, atomic.remove_stale_temporaries
    os.fsync = lambda fd: None  # the look alone is measured

    def writes() -> float:
        start = time.perf_counter()
        for i in range(WRITES):
            with atomic.atomic_path(folder / f"new_{i:04d}.json") as tmp:
                tmp.write_bytes(b"{}")
        return time.perf_counter() - start

    def no_look(path: str | os.PathLike[str], fresh: bool = True) -> int:
        return 0

    def look_every_time(path: str | os.PathLike[str], fresh: bool = True) -> int:
        return real_scan(path, fresh=True)

    variants: dict[str, Callable[..., int]] = {"shipped": real_scan, "every write": look_every_time,
                                               "none": no_look}
    times: dict[str, list[float]] = {name: [] for name in variants}
    try:
        for scan in variants.values():  # warm-up: the folder's entries cached, the targets created
            atomic.remove_stale_temporaries = scan
            writes()
        for i in range(repeat):
            for name in (list(variants) if i % 2 == 0 else list(reversed(variants))):
                atomic.LOOK_AGAIN_S = 60.0
                atomic._LOOKS.clear()  # each round starts as a fresh process would
                atomic.remove_stale_temporaries = variants[name]
                times[name].append(writes())
    finally:
        os.fsync, atomic.remove_stale_temporaries = real_fsync, real_scan
    label = f"scan: {WRITES} atomic writes into a folder of {folder_files} files"
    _ratios(f"{label}, as shipped (one listing a minute)", times["shipped"], times["none"])
    _ratios(f"{label}, listing it at every write", times["every write"], times["none"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=40, help="videos of the run without videos")
    ap.add_argument("--video-size", type=int, default=10, help="videos of the run with --videos (0: none)")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each variant, alternating")
    ap.add_argument("--folder-files", default="0,1000,10000", help="folder sizes of the scan measurement ('': none)")
    args = ap.parse_args()
    print(f"load average before: {_load()}")
    with tempfile.TemporaryDirectory(prefix="craft-atomic-cost-") as tmp:
        work = Path(tmp)
        hooks = work / "hooks"
        hooks.mkdir()
        (hooks / "sitecustomize.py").write_text(SITECUSTOMIZE)
        if args.size:
            bench_generate(args.size, False, args.repeat, work, hooks)
        if args.video_size:
            bench_generate(args.video_size, True, args.repeat, work, hooks)
        for files in (int(x) for x in args.folder_files.split(",") if x):
            bench_scan(files, args.repeat, work)
    print(f"load average after: {_load()}")


if __name__ == "__main__":
    main()
