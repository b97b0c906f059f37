"""Generation speed of each engine, measured in the same run: ``craft-dsl generate --engine E`` for box2d (the
default), pymunk and the original CRAFT simulator, without and with videos (``box2d128``, Box2D with the original's
128-gons, where Box2D is built for it: ``tools/box2d128/build.sh``).

Run: ``python benchmarks/engine_speed.py [--size 20] [--workers 2] [--engines box2d,pymunk,original]``.

Each configuration is one whole ``craft-dsl generate`` subprocess (default settings: 600 steps, 3 perturbations,
all 67 templates; scenes 1-20 in turn) into a fresh folder; the figure is videos per minute of wall time, and the
ratio against the first engine of the list measured in the same run. With videos, pymunk and box2d are drawn by
craft_dsl's renderer and the original by its own OpenGL renderer. The original must be built
(``bash tools/original/build.sh``). Figures are printed, never asserted; the load average is printed before and
after, since the machine is shared.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def generate(engine: str, size: int, workers: int, videos: bool, out: Path) -> float:
    """Seconds of one whole generate run."""
    cmd = [sys.executable, "-m", "craft_dsl", "generate", "--size", str(size), "--workers", str(workers),
           "--engine", engine, "--out", str(out), "--quiet", "--no-balance"] + (["--videos"] if videos else [])
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{done.stderr[-2000:]}")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=20, help="videos per run (default 20: scenes 1-20 once)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--engines", default="box2d,pymunk,original",
                        help="engines, the first is the baseline (default: the default engine first)")
    args = parser.parse_args()
    engines = args.engines.split(",")
    print(f"load average before: {os.getloadavg()[0]:.2f}; {args.size} videos, {args.workers} workers")
    rows = []
    with tempfile.TemporaryDirectory(prefix="engine-speed-") as tmp:
        for videos in (False, True):
            for engine in engines:
                out = Path(tmp) / f"{engine}-{int(videos)}"
                seconds = generate(engine, args.size, args.workers, videos, out)
                rows.append((engine, videos, seconds, args.size * 60 / seconds))
                print(f"  {engine:9s} videos={'yes' if videos else 'no '}: {seconds:7.1f} s, "
                      f"{args.size * 60 / seconds:7.1f} videos/min", flush=True)
    print()
    print("| engine | videos | seconds | videos/min | time vs " + engines[0] + " |")
    print("|---|---|---|---|---|")
    for engine, videos, seconds, rate in rows:
        base = next(s for e, v, s, _ in rows if e == engines[0] and v == videos)
        print(f"| {engine} | {'yes' if videos else 'no'} | {seconds:.1f} | {rate:.1f} | {seconds / base:.2f}x |")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
