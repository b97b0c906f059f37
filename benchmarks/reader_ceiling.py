"""How far the video reader is from what its physics allows, on a held-out generated dataset.

The test questions of both splits (as ``benchmarks/reader.py`` reads them: videos and question texts only) are
answered by

* the reader;
* each engine run from the dataset's **true start state** (the simulation seeds in ``questions/qa_<id6>.json``):
  perfect perception of the first frame and no look at the video after it. For the engine that made the dataset
  this is 100% (a check of the benchmark); for another engine it is the ceiling of a reader whose physics is that
  engine and which never re-anchors its run to the frames;
* each engine run from the **reader's fitted start state** (its reconstruction's step-0 world, before any restart):
  what the reader's first fit alone gives.

Printed per split and paper column (All, C, CF, D), with, for each engine from the true start, how many of the
reader's wrong answers that run gets wrong too. Figures are printed, never asserted.

    python benchmarks/reader_ceiling.py --dataset DIR [--engines box2d,pymunk] [--workers 2] [--limit N] [--json F]

The dataset's own engine (``generation_config.json``) is always among the engines; ``original`` needs the original
simulator built (``tools/original/build.sh``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext
from pathlib import Path
from typing import Any

from reader import generation_settings, held_out_questions

from craft_dsl.dataset.samplers import start_state
from craft_dsl.errors import CraftError
from craft_dsl.physics import simulate
from craft_dsl.program import Program, to_json
from craft_dsl.question_parsing import question_to_program
from craft_dsl.reader.answer import Question, answer_questions, find_videos
from craft_dsl.reader.perceive import perceive_video
from craft_dsl.verify.answers import answers_agree
from craft_dsl.verify.categories import FAMILIES, family_of
from craft_dsl.world import WorldSpec

READER = "reader"


def _answers(sim: Any, programs: list[Program]) -> list[Any]:
    """Each program's answer on ``sim`` as the dataset writes answers; an error's text where one raises."""
    out: list[Any] = []
    for program in programs:
        try:
            out.append(to_json(program.run(sim), original=True))
        except CraftError as err:
            out.append(f"error: {err}")
    return out


def run_video(path: str, questions: list[Question], scene: int, seed: int, steps: int,
              engines: list[str], sampler: str) -> dict[str, Any]:
    """Every row's answers to one video's test questions (``"<row>": [answer per question]``) and timings. The
    true start is the one the dataset's ``sampler`` drew for (scene, seed): the original's own sampler draws
    another scene than our layouts for the same pair."""
    programs = [question_to_program(q.text) for q in questions]
    rows: dict[str, list[Any]] = {}
    seconds: dict[str, float] = {}
    t = time.perf_counter()
    try:
        perception = perceive_video(path, first_engine=engines[0])  # the dataset's own engine first, as read does
    except CraftError as err:
        rows[READER] = [f"error: {err}"] * len(questions)
        fitted = None
    else:
        rows[READER] = [a.answer for a in answer_questions(perception.scene, questions)]
        fitted = perception.reconstruction.simulation.world_spec
    seconds[READER] = time.perf_counter() - t
    starts: tuple[tuple[str, WorldSpec | None], ...] = (("true start", start_state(scene, seed, sampler)),
                                                        ("reader's start", fitted))
    for engine in engines:
        for name, start in starts:
            label = f"{engine} from the {name}"
            if start is None:
                rows[label] = rows[READER]  # the reader failed: nothing fitted
                continue
            t = time.perf_counter()
            try:
                sim = simulate(start, steps=steps, engine=engine)
                rows[label] = _answers(sim, programs)
            except CraftError as err:
                rows[label] = [f"error: {err}"] * len(questions)
            seconds[label] = time.perf_counter() - t
    return {"path": path, "keys": [q.key for q in questions], "rows": rows, "seconds": seconds}


def table(results: list[dict[str, Any]], keys: set[str], truth: dict[str, Any], template: dict[str, str]) -> list[str]:
    """Markdown rows: accuracy per row label and paper column over the questions ``keys``; for the runs from the
    true start, how many of the reader's wrong answers they share."""
    right: Counter[tuple[str, str]] = Counter()
    total: Counter[str] = Counter()
    shared: Counter[str] = Counter()
    reader_wrong = 0
    labels: list[str] = []
    for r in results:
        for label in r["rows"]:
            if label not in labels:
                labels.append(label)
        for j, key in enumerate(r["keys"]):
            if key not in keys:
                continue
            family = family_of(template[key])
            total["All"] += 1
            total[family] += 1
            ok = {label: answers_agree(answers[j], truth[key]) for label, answers in r["rows"].items()}
            reader_wrong += not ok[READER]
            for label, good in ok.items():
                right[(label, "All")] += good
                right[(label, family)] += good
                if not good and not ok[READER] and label != READER:
                    shared[label] += 1
    columns = ["All", *FAMILIES]
    lines = ["| answered by | " + " | ".join(f"{c} ({total[c]})" for c in columns)
             + " | of the reader's wrong answers, also wrong |",
             "|---|" + "---|" * (len(columns) + 1)]
    for label in labels:
        cells = [f"{100 * right[(label, c)] / total[c]:.2f}" if total[c] else "-" for c in columns]
        also = "-" if label == READER else f"{shared[label]} of {reader_wrong}"
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {also} |")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", required=True, help="a dataset generated with --videos")
    parser.add_argument("--engines", default="box2d,pymunk",
                        help="engines run from the true and the fitted start, besides the dataset's own")
    parser.add_argument("--workers", type=int, default=2, help="reader processes (1: in this process)")
    parser.add_argument("--limit", type=int, help="only the first N test videos (a quick look)")
    parser.add_argument("--json", help="write every row's answers here")
    args = parser.parse_args(argv)
    root = Path(args.dataset)
    own, steps, sampler = generation_settings(root)
    engines = [own] + [e for e in args.engines.split(",") if e and e != own]
    tests = held_out_questions(root)
    videos = sorted(tests.by_video)[: args.limit] if args.limit else sorted(tests.by_video)
    paths = find_videos(root / "videos", videos)
    jobs = []
    for v in videos:
        stats = json.loads((root / "questions" / f"qa_{v:06d}.json").read_text())["stats"]
        jobs.append((str(paths[v]), tests.by_video[v], stats["scene"], stats["simulation_seed"], steps, engines,
                     sampler))
    t0 = time.perf_counter()
    results = []
    with ProcessPoolExecutor(max_workers=args.workers) if args.workers > 1 else nullcontext() as pool:
        done = pool.map(run_video, *zip(*jobs)) if pool is not None else map(run_video, *zip(*jobs))
        for i, r in enumerate(done, 1):
            results.append(r)
            print(f"\r{i}/{len(jobs)} videos", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    print(f"{root}: {len(jobs)} test videos, dataset engine {own}, {time.perf_counter() - t0:.0f} s\n")
    for split, part in tests.parts.items():
        keys = {f"{v}_{q}" for v, q in part}
        print(f"**{'easy (random)' if split == 'random' else split} split, test part**\n")
        print("\n".join(table(results, keys, tests.truth, tests.template)))
        print()
    if args.json:
        Path(args.json).write_text(json.dumps({"results": results}, default=str))


if __name__ == "__main__":
    main()
