"""Throughput of the fresh-data stream (:class:`craft_dsl.torch.CraftStream`) beside ``craft-dsl generate``.

Run: ``python benchmarks/stream_throughput.py [--videos 40] [--workers 1,2] [--modes file,video,none] [--batch 16]
[--fps 10 --size 128] [--repeat 1]``.

For each worker count N, in the same run on the same machine, with the same seed, scenes (1-20) and engine
(the default, Box2D):

* ``generate``: ``craft-dsl generate --size VIDEOS --workers N --videos`` (a subprocess: interpreter start,
  imports, workers, merge, files);
* ``stream MODE``: a subprocess that iterates ``DataLoader(CraftStream(seed, videos=VIDEOS, frames=MODE),
  batch_size=BATCH, collate_fn=collate, num_workers=N)`` to the end (interpreter start, imports and worker start
  included). ``file`` writes the same MPEG-1 videos and frame PNGs as ``generate --videos`` (to a cache folder);
  ``video`` draws the frames in memory (``--fps``, ``--size``; no encoding) and sends them through the loader;
  ``none`` no frames.

Printed: seconds, videos per second and questions per second, the ratio stream / generate of videos per
second, and for the stream the seconds before its loader started (interpreter, imports: torch takes 1-3 s). The
stream yields exactly the questions of ``generate --no-balance`` (every question that passes the per-video
filters), so the ratio of questions per second against those is the same number. Generate's balanced questions are
fewer: it is compared by videos. Figures are printed, never asserted; the load average is printed before and after
(the machine may be shared). Runs alternate (generate, then each mode) ``--repeat`` times; the best time of each is
used.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

SEED = 20


def _load() -> str:
    try:
        return " ".join(f"{x:.1f}" for x in os.getloadavg())
    except OSError:  # pragma: no cover - not POSIX
        return "?"


def _generate(videos: int, workers: int, tmp: Path) -> dict[str, Any]:
    out = tmp / f"generate-{workers}-{time.monotonic_ns()}"
    cmd = [sys.executable, "-m", "craft_dsl", "generate", "--size", str(videos), "--seed", str(SEED), "--out",
           str(out), "--workers", str(workers), "--videos", "--quiet"]
    start = time.perf_counter()
    subprocess.run(cmd, check=True)
    seconds = time.perf_counter() - start
    report = json.loads((out / "generation_report.json").read_text())
    return {"seconds": seconds, "questions": report["questions"]["after_post_process"],
            "final": report["questions"]["final"]}


def _stream(videos: int, workers: int, mode: str, fps: float | None, size: int, batch: int,
            tmp: Path) -> dict[str, Any]:
    cache = tmp / f"cache-{workers}-{time.monotonic_ns()}"
    cmd = [sys.executable, __file__, "--child", mode, "--videos", str(videos), "--workers", str(workers),
           "--size", str(size), "--cache", str(cache), "--batch", str(batch)] + (["--fps", str(fps)] if fps else [])
    start = time.perf_counter()
    done = subprocess.run(cmd, check=True, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    return {"seconds": seconds, **json.loads(done.stdout.strip().splitlines()[-1])}


def _child(args: argparse.Namespace) -> None:
    """Iterate the stream to its end in this process (the timed subprocess)."""
    from torch.utils.data import DataLoader

    from craft_dsl.torch import CraftStream, collate

    started = time.perf_counter()
    stream = CraftStream(SEED, videos=args.videos, frames=args.child, fps=args.fps, size=args.size,
                         cache_dir=args.cache)
    batch = args.batch or None
    loader = DataLoader(stream, batch_size=batch, collate_fn=collate if batch else None, num_workers=int(args.workers))
    questions = 0
    pixels = 0
    videos: set[int] = set()
    for item in loader:
        indices = item["video_index"].tolist() if batch else [item["video_index"]]
        questions += len(indices)
        pixels += int(item["frames"].numel())
        videos.update(indices)
    print(json.dumps({"questions": questions, "videos_with_questions": len(videos), "pixels": pixels,
                      "after_imports": time.perf_counter() - started}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--videos", type=int, default=40, help="videos per run (default 40)")
    parser.add_argument("--workers", default="1,2", help="worker counts, comma-separated (default 1,2)")
    parser.add_argument("--modes", default="file,video,none", help="stream frame modes (default file,video,none)")
    parser.add_argument("--fps", type=float, default=None, help="frame rate of the video mode (default: all 60)")
    parser.add_argument("--size", type=int, default=256, help="frame side of the video mode (default 256)")
    parser.add_argument("--batch", type=int, default=16,
                        help="loader batch size, batched by craft_dsl.torch.collate (default 16; 0: one sample at a "
                             "time, about 1 ms of inter-process transfer each)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each, the best kept (default 1)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--cache", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        _child(args)
        return
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    video_mode = f"fps {args.fps or 60:g}, {args.size} px; batches of {args.batch or 1}"
    print(f"stream vs generate --videos: {args.videos} videos, seed {SEED}, scenes 1-20, engine box2d "
          f"(video mode: {video_mode}); {os.cpu_count()} CPUs; load before {_load()}")
    with tempfile.TemporaryDirectory(prefix="craft-stream-bench-") as tmp_name:
        tmp = Path(tmp_name)
        for workers in [int(w) for w in args.workers.split(",")]:
            best: dict[str, dict[str, Any]] = {}
            for _ in range(args.repeat):
                runs = {"generate": _generate(args.videos, workers, tmp)}
                for mode in modes:
                    runs[f"stream {mode}"] = _stream(args.videos, workers, mode, args.fps, args.size, args.batch, tmp)
                for name, run in runs.items():
                    if name not in best or run["seconds"] < best[name]["seconds"]:
                        best[name] = run
            base = args.videos / best["generate"]["seconds"]
            print(f"\nN = {workers} (generate --workers {workers}; DataLoader num_workers={workers})")
            print(f"{'run':<14} {'seconds':>8} {'videos/s':>9} {'questions/s':>12} {'ratio (videos/s)':>17} "
                  f"{'start (s)':>10}")
            for name, run in best.items():
                rate = args.videos / run["seconds"]
                start = f"{run['seconds'] - run['after_imports']:.1f}" if "after_imports" in run else "-"
                print(f"{name:<14} {run['seconds']:>8.1f} {rate:>9.2f} {run['questions'] / run['seconds']:>12.1f} "
                      f"{rate / base:>17.2f} {start:>10}")
            g = best["generate"]
            print(f"(generate: {g['questions']} questions after the per-video filters, {g['final']} after balancing; "
                  "its questions/s counts the former)")
    print(f"\nload after {_load()}")


if __name__ == "__main__":
    main()
