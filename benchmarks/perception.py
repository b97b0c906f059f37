"""Perceived scenes: accuracy of every CRAFT question answered over what a perception model saw, and its cost.

Videos: video i is scene ``i % 20 + 1`` with seed ``i // 20`` (live pymunk physics, 600 steps), so every scene
appears. Questions: :func:`craft_dsl.dataset.questions.generate_questions` on the live simulation (one instance of
each of the paper's 48 templates that has a valid binding, seeded by the video index), *without* the
perturbation filter (it re-simulates every scene three times more; the fragile questions it would drop stay in).
The ground truth is the live simulation's answer.

Measured, per paper column (C, CF, D; ``craft_dsl.verify.categories.family_of``):

1. exact perception (the ground-truth export at 60 fps): counterfactuals replayed against the tracks or
   re-simulated from the fitted start, tracks with velocities or positions only, events given or derived from the
   tracks; the counterfactual and causal failures of the default mode counted by cause; the re-simulation's drift;
2. noise, one knob at a time (positions only, replay): position noise 0/1/2/4 px, attribute confusion 0/5/10/20 %,
   event misses 0/5/10 %; the most likely world beside the mode of the answer distribution (Monte Carlo,
   ``--samples`` readings), with the mean log-likelihood and Brier score of the true answer;
3. cost per question of each mode beside a plain ``Program.run`` on the true simulation (its counterfactuals
   computed lazily, as every mode's are), measured in the same run.

Run: ``python benchmarks/perception.py [--videos 200] [--workers 2] [--samples 64] [--out results.json]``; a quick
look: ``--videos 20``. Figures are printed (Markdown), never asserted.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections import defaultdict
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from typing import Any

import numpy as np

from craft_dsl import Program
from craft_dsl.dataset.questions import generate_questions
from craft_dsl.perception import ExecutionOptions, PerceivedScene, SceneModel, export_perceived
from craft_dsl.perception.distribution import answer_distributions
from craft_dsl.perception.noise import NoiseModel, degrade
from craft_dsl.physics import simulate
from craft_dsl.physics.engine import RawRun
from craft_dsl.physics.live import LiveSimulation
from craft_dsl.program import to_json
from craft_dsl.templates import DROPPED
from craft_dsl.verify.answers import answers_agree
from craft_dsl.verify.categories import family_of

FAMILIES = ("C", "CF", "D")

#: (label, velocities in the export, execution options)
EXACT_MODES: tuple[tuple[str, bool, ExecutionOptions], ...] = (
    ("replay, tracks with velocities", True, ExecutionOptions()),
    ("replay, positions only", False, ExecutionOptions()),
    ("re-simulate, tracks with velocities", True, ExecutionOptions(counterfactual="resimulate")),
    ("re-simulate, positions only", False, ExecutionOptions(counterfactual="resimulate")),
    ("replay, events derived from the tracks", True, ExecutionOptions(events="derived")),
)

#: (label, noise model): one knob at a time, positions only.
NOISE_SWEEP: tuple[tuple[str, NoiseModel], ...] = (
    ("none (positions only)", NoiseModel()),
    ("position 1 px", NoiseModel(position_sigma_px=1)),
    ("position 2 px", NoiseModel(position_sigma_px=2)),
    ("position 4 px", NoiseModel(position_sigma_px=4)),
    ("attributes 5 %", NoiseModel(attribute_confusion=0.05)),
    ("attributes 10 %", NoiseModel(attribute_confusion=0.10)),
    ("attributes 20 %", NoiseModel(attribute_confusion=0.20)),
    ("event misses 5 %", NoiseModel(event_miss_rate=0.05)),
    ("event misses 10 %", NoiseModel(event_miss_rate=0.10)),
)


def _video(index: int) -> tuple[int, int]:
    return index % 20 + 1, index // 20


def _answers(sim: Any, programs: Sequence[Program]) -> list[Any]:
    return [to_json(p.run(sim), original=True) for p in programs]


def _fresh(sim: LiveSimulation) -> LiveSimulation:
    """The same run with an empty counterfactual cache (for timing)."""
    return LiveSimulation(sim.world_spec, sim.raw, sim.engine, meta=dict(sim.meta))


def _ids(values: Any) -> list[int]:
    """Every object id in (nested tuples of) trace values: the candidates a counterfactual module removed."""
    out: list[int] = []
    for v in values:
        if isinstance(v, tuple):
            out += _ids(v)
        elif isinstance(v, int) and not isinstance(v, bool):
            out.append(v)
    return out


def _cause(sim: LiveSimulation, world: Any, program: Program, truth: Any, seed: int) -> str:
    """Why an exact-perception answer differs from the truth."""
    if world.moving(0) != sim.moving(0) or world.moving(-1) != sim.moving(-1):
        return "moving at the start or end judged differently"
    removed = sorted(set(_ids(e.value for e in program.trace(sim))) & set(sim.dynamic_ids))
    differs = any(sorted((e.type, e.step, e.objects) for e in sim.counterfactual(u).events)
                  != sorted((e.type, e.step, tuple(sorted(e.objects, reverse=True))) for e in world.counterfactual(
                      u).events) for u in removed)
    if _chaotic(sim, program, truth, seed):
        return "counterfactual: the true answer flips under a 1e-6 m/s perturbation"
    if differs:
        return "counterfactual: the re-simulated run differs"
    return "other"


def _chaotic(sim: LiveSimulation, program: Program, truth: Any, seed: int) -> bool:
    """Whether the true answer changes when the counterfactuals are replayed against the true run with its
    velocities perturbed by 1e-6 m/s (the answer then depends on numerical noise, not on perception)."""
    rng = np.random.default_rng(seed)
    raw = sim.raw
    traj = replace(raw.trajectory, velocities=raw.trajectory.velocities
                   + 1e-6 * rng.standard_normal(raw.trajectory.velocities.shape))
    shaken = LiveSimulation(sim.world_spec, RawRun(traj, raw.awake, raw.log), sim.engine)
    return not answers_agree(to_json(program.run(shaken), original=True), truth)


def run_video(index: int, samples: int, noise_seed: int) -> dict[str, Any]:
    scene_id, seed = _video(index)
    sim = simulate(scene_id, seed)
    rng = np.random.default_rng(index)
    records = [q for q in generate_questions(sim, rng, video_index=index, video_filename=f"{index:06d}.mp4")
               if q["template_id"] not in DROPPED]
    programs = [Program.from_nodes(q["program"]) for q in records]
    truth = [q["answer"] for q in records]
    families = [family_of(q["template_id"]) for q in records]
    out: dict[str, Any] = {"video": index, "scene": scene_id, "seed": seed, "families": families, "exact": {},
                           "noise": {}, "time": {}, "drift": {}, "causes": []}
    t = time.perf_counter()
    _answers(_fresh(sim), programs)
    out["time"]["plain Program.run on the true simulation"] = time.perf_counter() - t
    for label, velocities, options in EXACT_MODES:
        scene = export_perceived(sim, velocities=velocities)
        t = time.perf_counter()
        model = SceneModel(scene, options)
        answers = _answers(model.simulation(), programs)
        out["time"][f"most likely world, {label}"] = time.perf_counter() - t
        correct = [answers_agree(a, b) for a, b in zip(answers, truth)]
        out["exact"][label] = correct
        if options.counterfactual == "resimulate":
            out["drift"][label] = [d.max_px for d in model.drift().values()]
        if label in (EXACT_MODES[0][0], EXACT_MODES[1][0]):
            world = model.simulation()
            for i, ok in enumerate(correct):
                if not ok:
                    out["causes"].append({"mode": label, "template_id": records[i]["template_id"],
                                          "family": families[i], "truth": truth[i], "answer": answers[i],
                                          "cause": _cause(sim, world, programs[i], truth[i], index * 1000 + i)})
    base = export_perceived(sim, velocities=False)
    for k, (label, noise) in enumerate(NOISE_SWEEP):
        noisy: PerceivedScene = degrade(base, noise, noise_seed * 1_000_003 + index * 101 + k)
        model = SceneModel(noisy)
        t = time.perf_counter()
        answers = _answers(model.simulation(), programs)
        map_time = time.perf_counter() - t
        dists = answer_distributions(model, programs, samples=samples, seed=index)
        out["noise"][label] = {
            "most_likely": [answers_agree(a, b) for a, b in zip(answers, truth)],
            "mode": [answers_agree(d.mode, b) for d, b in zip(dists, truth)],
            "log_likelihood": [d.log_likelihood(b) for d, b in zip(dists, truth)],
            "brier": [d.brier(b) for d, b in zip(dists, truth)],
        }
        if k == 4:  # attribute confusion 5 %: uncertain readings; the distribution timed on a fresh model
            t = time.perf_counter()
            answer_distributions(SceneModel(noisy), programs, samples=samples, seed=index)
            dist_time = time.perf_counter() - t
            out["time"]["most likely world, attribute confusion 5 %"] = map_time
            out["time"][f"answer distribution ({samples} readings), attribute confusion 5 %"] = dist_time
    return out


# -- report -------------------------------------------------------------------------------------------------


def _accuracy(results: list[dict[str, Any]], get: Any) -> dict[str, tuple[int, float]]:
    hits: dict[str, list[bool]] = defaultdict(list)
    for r in results:
        for family, value in zip(r["families"], get(r)):
            hits[family].append(value)
            hits["All"].append(value)
    return {k: (len(v), sum(v) / len(v)) for k, v in hits.items() if v}


def _mean(results: list[dict[str, Any]], get: Any) -> dict[str, float]:
    values: dict[str, list[float]] = defaultdict(list)
    for r in results:
        for family, value in zip(r["families"], get(r)):
            values[family].append(value)
            values["All"].append(value)
    return {k: float(np.mean(v)) for k, v in values.items()}


def _pct(x: float) -> str:
    return f"{100 * x:.1f}"


def report(results: list[dict[str, Any]], samples: int, elapsed: float, workers: int) -> tuple[str, dict[str, Any]]:
    n_videos = len(results)
    n_questions = sum(len(r["families"]) for r in results)
    counts = _accuracy(results, lambda r: [True] * len(r["families"]))
    lines = [f"{n_videos} videos (scenes 1-20), {n_questions} questions "
             f"(C {counts['C'][0]}, CF {counts['CF'][0]}, D {counts['D'][0]}); "
             f"{elapsed:.0f} s with {workers} worker(s)", ""]
    data: dict[str, Any] = {"videos": n_videos, "questions": n_questions, "exact": {}, "noise": {}, "cost": {},
                            "drift": {}, "causes": {}}
    lines += ["### Exact perception (ground-truth export, 60 fps)", "",
              "| mode | C | CF | D | all |", "|---|---|---|---|---|"]
    for label, _, _ in EXACT_MODES:
        acc = _accuracy(results, lambda r, label=label: r["exact"][label])
        data["exact"][label] = acc
        lines.append(f"| {label} | " + " | ".join(_pct(acc[f][1]) for f in (*FAMILIES, "All")) + " |")
    causes: dict[str, int] = defaultdict(int)
    for r in results:
        for c in r["causes"]:
            causes[f"{c['mode']} | {c['family']} | {c['cause']}"] += 1
    data["causes"] = dict(causes)
    lines += ["", "| failures of the replay modes: mode | column | cause | questions |", "|---|---|---|---|"]
    lines += [f"| {k.replace(' | ', ' | ')} | {n} |" for k, n in sorted(causes.items())] or ["| none | | | |"]
    lines += [""]
    lines += ["| re-simulated factual run | objects | max drift < 1 px | median max drift (px) | 90th pct (px) |",
              "|---|---|---|---|---|"]
    for label in results[0]["drift"]:
        drift = np.array([d for r in results for d in r["drift"][label]])
        data["drift"][label] = {"objects": int(drift.size), "under_1px": float(np.mean(drift < 1.0)),
                                "median": float(np.median(drift)), "p90": float(np.quantile(drift, 0.9))}
        lines.append(f"| {label} | {drift.size} | {_pct(float(np.mean(drift < 1.0)))} % | {np.median(drift):.3f} "
                     f"| {np.quantile(drift, 0.9):.2f} |")
    lines += ["", f"### Noise (positions only, replay; distribution: {samples} Monte Carlo readings)", "",
              "| noise | most likely: C | CF | D | distribution mode: C | CF | D | log-likelihood | Brier |",
              "|---|---|---|---|---|---|---|---|---|"]
    for label, _ in NOISE_SWEEP:
        ml = _accuracy(results, lambda r, label=label: r["noise"][label]["most_likely"])
        mode = _accuracy(results, lambda r, label=label: r["noise"][label]["mode"])
        ll = _mean(results, lambda r, label=label: r["noise"][label]["log_likelihood"])
        brier = _mean(results, lambda r, label=label: r["noise"][label]["brier"])
        data["noise"][label] = {"most_likely": ml, "mode": mode, "log_likelihood": ll["All"], "brier": brier["All"]}
        lines.append(f"| {label} | " + " | ".join(_pct(ml[f][1]) for f in FAMILIES) + " | "
                     + " | ".join(_pct(mode[f][1]) for f in FAMILIES) + f" | {ll['All']:.3f} | {brier['All']:.3f} |")
    lines += ["", "### Cost per question", "", "| mode | ms per question | ratio to the plain run |", "|---|---|---|"]
    totals: dict[str, float] = defaultdict(float)
    for r in results:
        for label, seconds in r["time"].items():
            totals[label] += seconds
    plain = totals["plain Program.run on the true simulation"]
    for label, seconds in totals.items():
        data["cost"][label] = {"ms_per_question": 1000 * seconds / n_questions, "ratio": seconds / plain}
        lines.append(f"| {label} | {1000 * seconds / n_questions:.2f} | {seconds / plain:.2f} |")
    return "\n".join(lines) + "\n", data


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--videos", type=int, default=200, help="number of videos (default 200)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--samples", type=int, default=64, help="Monte Carlo readings per distribution (default 64)")
    parser.add_argument("--noise-seed", type=int, default=0, help="seed of the noise model (default 0)")
    parser.add_argument("--out", help="write the figures as JSON here")
    args = parser.parse_args()
    start = time.perf_counter()
    indexes = list(range(args.videos))
    results: list[dict[str, Any]] = []
    if args.workers > 1:
        with ProcessPoolExecutor(args.workers) as pool:
            futures = [pool.submit(run_video, i, args.samples, args.noise_seed) for i in indexes]
            for k, f in enumerate(futures):
                results.append(f.result())
                print(f"\rvideo {k + 1}/{len(indexes)}", end="", file=sys.stderr, flush=True)
    else:
        for i in indexes:
            results.append(run_video(i, args.samples, args.noise_seed))
            print(f"\rvideo {i + 1}/{len(indexes)}", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    text, data = report(results, args.samples, time.perf_counter() - start, args.workers)
    print(text)
    if args.out:
        data["failures"] = [dict(c, video=r["video"]) for r in results for c in r["causes"]]
        with open(args.out, "w", encoding="utf-8") as fh:
            json.dump(data, fh, indent=2, default=lambda x: x if not isinstance(x, float) or math.isfinite(x)
                      else None)


if __name__ == "__main__":
    main()
