"""The reader's speed beside another commit's, measured side by side on the same test videos.

A machine's speed drifts between runs (on the 2-core development machine the same code read 40 videos at 2.62 s a
video in one run and 2.96 s in the next), so a change's speed is compared only with runs made at the same time: the
baseline's ``benchmarks/reader.py --workers 1`` and the current tree's run together, one pinned to each core, then
again with the cores swapped. Each round prints both codes' seconds a video (mean and median of perception and
answering, as ``reader.py`` times them), their ratio and the stages; at the end, the ratio over all rounds and whether
the two codes gave every question the same answer (a change meant to be exact must).

Run: ``python benchmarks/reader_pair.py --dataset DIR --baseline REV [--limit 40] [--rounds 2] [--json out.json]``
(``REV``: any commit, checked out in a temporary git worktree and removed after; ``--baseline-tree PATH`` instead
takes a checkout already made). Figures are printed, never asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
STAGES = ("decode", "layout", "detect", "reconstruct", "answering")


def video_seconds(run: dict[str, Any]) -> dict[str, float]:
    """Seconds of perception and answering of each video read (by its path's file name) in a ``reader.py --json``."""
    return {Path(v["path"]).name: float(v["timings"]["perception"] + v["timings"]["answering"])
            for v in run["per_video"] if "timings" in v}


def answers(run: dict[str, Any]) -> dict[str, Any]:
    """Each question's answer (by its key) in a ``reader.py --json``."""
    return {str(q["key"]): q["answer"] for v in run["per_video"] for q in v.get("questions", ())}


def compare(baseline: dict[str, Any], current: dict[str, Any]) -> dict[str, Any]:
    """One round: both codes' seconds a video (mean, median), the ratio of the means (current / baseline), the mean
    of each stage, and the questions they answer differently. The two runs must be of the same videos."""
    base_s, cur_s = video_seconds(baseline), video_seconds(current)
    if set(base_s) != set(cur_s):
        raise ValueError(f"the two runs read different videos: {sorted(set(base_s) ^ set(cur_s))[:5]}")
    if not base_s:
        raise ValueError("the runs read no video")
    base_a, cur_a = answers(baseline), answers(current)

    def stages(run: dict[str, Any]) -> dict[str, float]:
        timed = [v["timings"] for v in run["per_video"] if "timings" in v]
        return {k: statistics.fmean(t.get(k, 0.0) for t in timed) for k in STAGES}

    return {"videos": len(base_s),
            "baseline": {"mean": statistics.fmean(base_s.values()), "median": statistics.median(base_s.values()),
                         "stages": stages(baseline)},
            "current": {"mean": statistics.fmean(cur_s.values()), "median": statistics.median(cur_s.values()),
                        "stages": stages(current)},
            "ratio": statistics.fmean(cur_s.values()) / statistics.fmean(base_s.values()),
            "answers_differ": sorted(k for k in base_a if cur_a.get(k) != base_a[k])}


def round_lines(k: int, cores: tuple[int | None, int | None], r: dict[str, Any]) -> list[str]:
    """A round's table (Markdown)."""
    b, c = r["baseline"], r["current"]
    where = ["unpinned" if core is None else f"on core {core}" for core in cores]
    lines = [f"### round {k}: baseline {where[0]}, current {where[1]} ({r['videos']} videos)", "",
             "| seconds a video | baseline | current | ratio |", "|---|---|---|---|",
             f"| mean | {b['mean']:.3f} | {c['mean']:.3f} | {r['ratio']:.3f} |",
             f"| median | {b['median']:.3f} | {c['median']:.3f} | {c['median'] / b['median']:.3f} |"]
    for stage in STAGES:
        lines.append(f"| {stage} | {b['stages'][stage]:.3f} | {c['stages'][stage]:.3f} | "
                     f"{c['stages'][stage] / max(b['stages'][stage], 1e-9):.3f} |")
    return lines + [""]


def summary_lines(rounds: Sequence[dict[str, Any]]) -> list[str]:
    """The rounds together: the ratio of the summed means, and the answers either round saw differ."""
    ratio = sum(r["current"]["mean"] for r in rounds) / sum(r["baseline"]["mean"] for r in rounds)
    differ = sorted({k for r in rounds for k in r["answers_differ"]})
    same = "every answer the same" if not differ else f"{len(differ)} questions answered differently: {differ[:10]}"
    return [f"current / baseline over {len(rounds)} rounds: **{ratio:.3f}** of the time; {same}"]


def _pinned(core: int | None) -> Any:
    if core is None or not hasattr(os, "sched_setaffinity"):
        return None
    return lambda: os.sched_setaffinity(0, {core})


def read_side_by_side(trees: tuple[Path, Path], dataset: Path, limit: int, cores: tuple[int | None, int | None],
                      work: Path, tag: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """``reader.py --workers 1`` of both trees (baseline, current) at once on ``dataset``, each on its core; their
    JSON reports."""
    procs = []
    for side, tree, core in zip(("baseline", "current"), trees, cores):
        out = work / f"{tag}-{side}.json"
        log = open(work / f"{tag}-{side}.log", "w")  # noqa: SIM115 - closed after the process ends
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tree), os.environ.get("PYTHONPATH", "")]).rstrip(
            os.pathsep)}
        cmd = [sys.executable, str(tree / "benchmarks" / "reader.py"), "--dataset", str(dataset), "--workers", "1",
               "--limit", str(limit), "--json", str(out)]
        procs.append((side, out, log, subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env,
                                                      preexec_fn=_pinned(core))))
    reports = []
    for side, out, log, proc in procs:
        code = proc.wait()
        log.close()
        if code != 0:
            tail = Path(log.name).read_text()[-2000:]
            raise RuntimeError(f"the {side} reader failed (exit {code}):\n{tail}")
        reports.append(json.loads(out.read_text()))
    return reports[0], reports[1]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", required=True, type=Path, help="a dataset written by craft-dsl generate --videos")
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--baseline", help="the commit to compare with (checked out in a temporary worktree)")
    which.add_argument("--baseline-tree", type=Path, help="a checkout of the code to compare with")
    parser.add_argument("--limit", type=int, default=40, help="test videos read (the first N; default 40)")
    parser.add_argument("--rounds", type=int, default=2, help="runs side by side, cores swapped each time (default 2)")
    parser.add_argument("--json", type=Path, help="also write the rounds' figures here")
    args = parser.parse_args(argv)
    if args.limit < 1 or args.rounds < 1:
        parser.error("--limit and --rounds must be at least 1")
    if not (args.dataset / "questions").is_dir():
        parser.error(f"{args.dataset} is not a dataset with videos (no questions/ folder)")
    cores: list[int | None] = list(sorted(os.sched_getaffinity(0))[:2]) if hasattr(os, "sched_getaffinity") else []
    if len(cores) < 2:
        print("fewer than two cores: the two readers share the machine unpinned", file=sys.stderr)
        cores = [None, None]
    with tempfile.TemporaryDirectory(prefix="reader-pair-") as tmp:
        work = Path(tmp)
        tree = args.baseline_tree
        if tree is None:
            tree = work / "baseline"
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree), args.baseline],
                           check=True, capture_output=True, text=True)
        try:
            rounds = []
            for k in range(1, args.rounds + 1):
                pair = (cores[0], cores[1]) if k % 2 else (cores[1], cores[0])
                base, cur = read_side_by_side((tree.resolve(), ROOT), args.dataset, args.limit, pair, work, f"r{k}")
                rounds.append(compare(base, cur))
                print("\n".join(round_lines(k, pair, rounds[-1])), flush=True)
        finally:
            if args.baseline_tree is None:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                               check=False, capture_output=True)
    print("\n".join(summary_lines(rounds)))
    if args.json:
        args.json.write_text(json.dumps({"rounds": rounds}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
