"""What reading a video costs against what making it costs: CPU seconds per video, as ratios measured in one run.

A fresh dataset is made with ``craft-dsl generate --size N --seed S --videos --workers 1`` (the default engine, or
``--engine``) and its test videos are read with ``craft-dsl read --workers 1`` (one reader, one core) and then
``--workers 2``, both as a user runs them. Each command runs in a child process, and its CPU seconds (user and
system, of it and every process it waited for) come from ``resource.getrusage(RUSAGE_CHILDREN)``. So the figures
include start-up, imports and every dataset-level step, and are made on the same machine in the same run:

* **read / make**: the reader's CPU seconds per test video over the generator's CPU seconds per video (goal at
  most 1.0);
* **two readers / one**: the wall-clock throughput of ``read --workers 2`` over ``--workers 1`` on the same
  videos (goal at least 1.8 on two cores).

Seconds are printed beside the ratios only to show where the time goes; they vary 2-3x between machines and decide
nothing. BLAS and OpenMP pools are held to one thread, so that "one reader" is one core.

    python benchmarks/reader_cost.py [--size 120] [--seed 20261240] [--limit 40] [--out DIR] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ONE_THREAD = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}


def run_child(args: list[str]) -> tuple[float, float]:
    """Run ``python -m craft_dsl ARGS`` to its end: (CPU seconds of it and its children, wall seconds)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "craft_dsl", *args], check=True, env={**os.environ, **ONE_THREAD},
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall


def test_questions(dataset: Path, limit: int | None) -> tuple[list[dict[str, Any]], list[int]]:
    """The records (video_index, question_index, question) of both splits' test questions of the first ``limit``
    test videos, and those videos."""
    wanted = set()
    for split in ("random", "hard"):
        wanted |= {(int(q["video_index"]), int(q["question_index"]))
                   for q in json.loads((dataset / f"split_info_{split}.json").read_text())["test"]}
    videos = sorted({v for v, _q in wanted})[:limit]
    chosen = set(videos)
    records = [{k: r[k] for k in ("video_index", "question_index", "question")}
               for r in json.loads((dataset / "dataset_minimal.json").read_text())
               if (r["video_index"], r["question_index"]) in wanted and r["video_index"] in chosen]
    return records, videos


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=120, help="videos to generate (default 120: about 45 test videos)")
    parser.add_argument("--seed", type=int, default=20261240, help="seed of the fresh dataset (default 20261240)")
    parser.add_argument("--engine", help="the generator's engine (default: generate's default)")
    parser.add_argument("--limit", type=int, default=40, help="test videos read (default 40)")
    parser.add_argument("--out", help="keep the dataset here (default: a temporary folder)")
    parser.add_argument("--json", help="write the figures here")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        dataset = Path(args.out) if args.out else Path(tmp) / "dataset"
        make = ["generate", "--size", str(args.size), "--seed", str(args.seed), "--videos", "--workers", "1",
                "--out", str(dataset), "--quiet"] + (["--engine", args.engine] if args.engine else [])
        make_cpu, make_wall = run_child(make)
        records, videos = test_questions(dataset, args.limit)
        if not videos:
            parser.error(f"the {args.size} videos made hold no test question: make more (--size)")
        questions = Path(tmp) / "questions.json"
        questions.write_text(json.dumps(records))
        reads = {}
        for workers in (1, 2):
            out = Path(tmp) / f"predictions-{workers}.json"
            reads[workers] = run_child(["read", "--videos", str(dataset / "videos"), "--questions", str(questions),
                                        "--out", str(out), "--workers", str(workers), "--quiet"])
        same = (Path(tmp) / "predictions-1.json").read_bytes() == (Path(tmp) / "predictions-2.json").read_bytes()
    make_per_video = make_cpu / args.size
    read_per_video = reads[1][0] / len(videos)
    figures = {
        "videos made": args.size, "test videos read": len(videos), "questions": len(records),
        "make CPU s per video": make_per_video, "read CPU s per video (one reader)": read_per_video,
        "read / make": read_per_video / make_per_video,
        "two readers / one (throughput)": reads[1][1] / reads[2][1],
        "two readers' CPU / one reader's": reads[2][0] / reads[1][0],
        "predictions identical for 1 and 2 readers": same,
        "make wall s": make_wall, "read wall s (1, 2 readers)": [reads[1][1], reads[2][1]],
        "load average after": os.getloadavg()[0],
    }
    print(f"{args.size} videos made (seed {args.seed}), {len(videos)} test videos read ({len(records)} questions)")
    print(f"  read / make, CPU per video: {figures['read / make']:.2f}   goal <= 1.0   "
          f"(make {make_per_video:.2f} CPU-s a video, read {read_per_video:.2f}; seconds decide nothing)")
    print(f"  two readers / one, throughput: {figures['two readers / one (throughput)']:.2f}   goal >= 1.8   "
          f"(their CPU {reads[2][0] / reads[1][0]:.2f}x one reader's)")
    print(f"  predictions identical for one and two readers: {same}")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
