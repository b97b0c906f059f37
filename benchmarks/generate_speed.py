"""Where the time of ``craft-dsl generate`` goes, and how fast whole runs are.

Run: ``python benchmarks/generate_speed.py [--videos 20] [--sections stages,runs,scaling,interrupt] [--baseline DIR]``.

* ``stages``: ``--videos`` videos (scenes 1-20 in turn, the default settings) computed one after the other in this
  process by the pipeline's own :func:`~craft_dsl.dataset.instance.run_instance`, timed stage by stage
  (physics runs counted apart), then the media of one video (rendering vs encoding) and the dataset-level work
  (writing the shards, merging, splits, report, Hugging Face files) of the same videos, per video. The floor
  is bare pymunk stepping (no callbacks, no recording) of the same factual worlds, times the physics runs a
  video needs.
* ``runs``: whole ``craft-dsl generate`` runs (subprocesses) with 1 and 2 workers, with and without
  ``--videos``: videos per minute, parallel efficiency, peak memory (from the run's log). With ``--baseline
  DIR`` (a checkout of an older craft_dsl, e.g. ``git worktree add /tmp/old <commit>``) the same 2-worker run of
  that version first, so the speed-up is a ratio measured in the same run.
* ``scaling``: the same run with ``--workers`` 1, 2, 3, 4 (or the counts given): videos per minute and parallel
  efficiency against one worker (on this 2-core machine, the counts above 2 show the curve flattening).
* ``interrupt``: Ctrl-C (SIGINT to the process group) sent to 2-worker runs at random moments: seconds until
  the command exits, and its exit code.

Figures are printed, never asserted. The load average is printed before and after: the machine is shared.
"""

from __future__ import annotations

import argparse
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from craft_dsl.dataset import pipeline as P
from craft_dsl.dataset.instance import InstanceResult, InstanceTask, StageClock, render_media, run_instance

STAGE_ORDER = ("factual simulation", "counterfactual variations", "question search", "perturbation filter",
               "serialisation")


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


# -- stages -------------------------------------------------------------------------------------------------------


class _Replay:
    """An executor that hands back results computed beforehand (to time the dataset-level work alone)."""

    description = "results computed beforehand"
    spare_cores = False

    def __init__(self, results: dict[int, InstanceResult]) -> None:
        self.results = results

    def run(self, tasks: Any, on_result: Any) -> list[tuple[int, str]]:
        for task in tasks:
            on_result(self.results[task.instance_id])
        return []


def stages(n: int) -> None:
    from craft_dsl.physics.pymunk_engine import PymunkEngine
    from craft_dsl.render.yuv import iter_yuv420
    from craft_dsl.scenes import sample_world

    config = P.GenerationConfig.make(size=n)
    work = P.work_list(config)
    tasks = [P.instance_task(config, i, s, questions=True, media=False) for i, s in work]
    run_instance(tasks[0])  # warm up: imports, compiled templates
    clock = StageClock()
    results = {}
    start = time.perf_counter()
    for task in tasks:
        results[task.instance_id] = run_instance(task, clock)
    total = time.perf_counter() - start

    engine = PymunkEngine()
    worlds = [sample_world(s, P.instance_seeds(config.seed, i)[0]) for i, s in work]
    start = time.perf_counter()
    for w in worlds:
        engine.run_bare(w, config.steps)
    bare = (time.perf_counter() - start) / n
    runs = sum(clock.runs.values()) / n

    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        P.generate_dataset(config, Path(tmp) / "merge", executor=_Replay(results))
        merge = (time.perf_counter() - start) / n

    from craft_dsl.physics import simulate

    # media of up to 10 of the videos: CPU time of this process (the encoder runs in it)
    sims = [simulate(s, seed=P.instance_seeds(config.seed, i)[0]) for i, s in work[:10]]
    media_tasks = [InstanceTask(i, s, config.seed, config.steps, 0, 0.0, "pymunk", ()) for i, s in work[:10]]
    render_media(sims[0], media_tasks[0])  # warm up
    start = time.process_time()
    for sim in sims:
        sum(1 for _ in iter_yuv420(sim))
    render = (time.process_time() - start) / len(sims)
    start = time.process_time()
    for sim, media_task in zip(sims, media_tasks, strict=True):
        render_media(sim, media_task)
    media = (time.process_time() - start) / len(sims)

    per = total / n
    print(f"stage breakdown: {n} videos (scenes 1-20), {config.steps} steps, {config.perturbations} perturbations, "
          f"one process; load {load()}")
    print("| stage | ms / video | share | physics runs / video |")
    print("|---|---|---|---|")
    for name in STAGE_ORDER:
        sec = clock.seconds.get(name, 0.0)
        sub = [(k, v) for k, v in clock.seconds.items() if k.startswith(name + ": ")]
        nruns = sum(clock.runs.get(k, 0) for k, _ in sub) / n
        print(f"| {name} | {sec / n * 1000:.0f} | {sec / total:.0%} | {nruns:.1f} |")
        rest = sec
        for key, v in sorted(sub):
            label = key.split(": ", 1)[1]
            label = {"runs": "whole-scene runs", "variations": "counterfactual re-runs"}[label]
            print(f"| &nbsp; of which {label} | {v / n * 1000:.0f} | {v / total:.0%} | "
                  f"{clock.runs[key] / n:.1f} |")
            rest -= v
        if sub and name == "perturbation filter":
            print(f"| &nbsp; of which re-answering the questions | {rest / n * 1000:.0f} | {rest / total:.0%} | |")
    print(f"| **per video, in a worker** | **{per * 1000:.0f}** | 100% | {runs:.1f} |")
    print(f"| dataset level (shards written, merge, splits, report, HF files), main process | {merge * 1000:.1f} | "
          f"{merge / per:.0%} of a video | |")
    print(f"| with --videos: render {config.steps} frames to YUV + MPEG-1 encode (PyAV, in the worker) + 2 PNG | "
          f"{media * 1000:.0f} (render and YUV {render * 1000:.0f}) | {media / per:.0%} of a video | |")
    floor = bare / config.steps * clock.frames / n
    print(f"floor: bare pymunk stepping (Chipmunk's step alone) {bare * 1000:.1f} ms per {config.steps}-step run; "
          f"a video simulates {clock.frames / n:.0f} frames in {runs:.1f} runs = {floor * 1000:.0f} ms of bare "
          f"stepping; pipeline / floor = {per / floor:.2f}")
    print(f"one worker: {60 / per:.0f} videos/min; 2 ideal workers: {120 / per:.0f} videos/min (target 333)")


# -- whole runs -----------------------------------------------------------------------------------------------------


def _generate(out: Path, size: int, workers: int, videos: bool, pythonpath: str | None = None,
              extra: tuple[str, ...] = ()) -> tuple[float, str]:
    cmd = [sys.executable, "-m", "craft_dsl", "generate", "--size", str(size), "--out", str(out), "--workers",
           str(workers), "--quiet", *(["--videos"] if videos else []), *extra]
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    start = time.perf_counter()
    subprocess.run(cmd, check=True, env=env, cwd=pythonpath or None)
    elapsed = time.perf_counter() - start
    log = out / P.LOG_FILE
    return elapsed, log.read_text() if log.is_file() else ""


def runs(size: int, baseline: str | None) -> None:
    print(f"\nwhole runs: craft-dsl generate --size {size} (scenes 1-20, defaults); load before {load()}")
    print("| run | seconds | videos / min | peak memory |")
    print("|---|---|---|---|")
    rates: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        plan: list[tuple[str, int, bool, str | None]] = []
        if baseline:
            plan.append(("baseline, 2 workers", 2, False, baseline))
        plan += [("new, 1 worker", 1, False, None), ("new, 2 workers", 2, False, None),
                 ("new, 2 workers, --videos", 2, True, None)]
        for k, (label, workers, videos, path) in enumerate(plan):
            out = Path(tmp) / f"run{k}"
            elapsed, log = _generate(out, size, workers, videos, path)
            rates[label] = 60 * size / elapsed
            peak = re.search(r"peak memory: (.*)$", log, re.M)
            print(f"| {label} | {elapsed:.1f} | {rates[label]:.0f} | {peak.group(1) if peak else '-'} |")
            shutil.rmtree(out)
    one, two = rates["new, 1 worker"], rates["new, 2 workers"]
    print(f"parallel efficiency 1 -> 2 workers: {two / (2 * one):.0%}; --videos adds "
          f"{two / rates['new, 2 workers, --videos'] - 1:.0%}; load after {load()}")
    if baseline:
        print(f"new / baseline (2 workers): {two / rates['baseline, 2 workers']:.2f}x")


def scaling(size: int, workers: list[int]) -> None:
    """The scaling curve: the same run with each number of workers (parallel efficiency against one worker)."""
    print(f"\nscaling: craft-dsl generate --size {size} with {', '.join(map(str, workers))} workers on "
          f"{os.cpu_count()} cores; load before {load()}")
    print("| workers | seconds | videos / min | parallel efficiency |")
    print("|---|---|---|---|")
    per_worker = 0.0  # videos/min per worker of the first (smallest) count
    with tempfile.TemporaryDirectory() as tmp:
        for n in workers:
            out = Path(tmp) / f"w{n}"
            elapsed, _ = _generate(out, size, n, False)
            rate = 60 * size / elapsed
            per_worker = per_worker or rate / n
            print(f"| {n} | {elapsed:.1f} | {rate:.0f} | {rate / (n * per_worker):.0%} |")
            shutil.rmtree(out)
    print(f"load after {load()}")


# -- interruption --------------------------------------------------------------------------------------------------


def interrupt(trials: int) -> None:
    print(f"\nCtrl-C: SIGINT to the process group of 'generate --size 200' at a random moment; load {load()}")
    rng = random.Random(0)
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(trials):
            out = Path(tmp) / f"i{k}"
            workers = 1 + k % 3
            proc = subprocess.Popen([sys.executable, "-m", "craft_dsl", "generate", "--size", "200", "--out",
                                     str(out), "--workers", str(workers), "--quiet"], start_new_session=True,
                                    stderr=subprocess.PIPE, text=True)
            while not (out / P.LOG_FILE).is_file() or "start:" not in (out / P.LOG_FILE).read_text():
                time.sleep(0.05)
            time.sleep(rng.uniform(0.5, 5.0))
            sent = time.perf_counter()
            os.killpg(proc.pid, signal.SIGINT)
            _out, err = proc.communicate()
            took = time.perf_counter() - sent
            print(f"  trial {k}, {workers} worker(s): exited {proc.returncode} after {took:.2f} s; "
                  f"traceback: {'Traceback' in err}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--videos", type=int, default=20, help="videos of the stage breakdown (default 20)")
    parser.add_argument("--size", type=int, default=40, help="videos of each whole run (default 40)")
    parser.add_argument("--sections", default="stages,runs,interrupt", help="any of stages, runs, scaling, interrupt")
    parser.add_argument("--baseline", help="a checkout of an older craft_dsl to compare whole runs with")
    parser.add_argument("--trials", type=int, default=6, help="Ctrl-C trials, with 1, 2, 3 workers in turn")
    parser.add_argument("--workers", default="1,2,3,4", help="worker counts of the scaling section (default 1,2,3,4)")
    args = parser.parse_args()
    sections = set(args.sections.split(","))
    if "stages" in sections:
        stages(args.videos)
    if "runs" in sections:
        runs(args.size, args.baseline)
    if "scaling" in sections:
        scaling(args.size, sorted(int(w) for w in args.workers.split(",")))
    if "interrupt" in sections:
        interrupt(args.trials)


if __name__ == "__main__":
    main()
