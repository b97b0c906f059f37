"""The video reader on held-out generated datasets: accuracy beside the paper's table, perception metrics, speed,
and the stage each wrong answer failed at.

Data: a dataset written by ``craft-dsl generate --videos`` (``--dataset DIR``), or one generated here (``--generate
SIZE --seed SEED --out DIR``, all 20 scenes; use seeds the reader was never developed on). The reader reads the
videos of the test parts of both splits (``split_info_random.json``: the paper's easy split; ``split_info_hard.json``:
the hard split, whose test scenes are unseen in its training part) and a questions file holding only
(video_index, question_index, question) of each test question, exactly as ``craft-dsl read`` does.

Measured (the benchmark, not the reader, then opens the ground truth: each video's simulation re-simulated from the
seeds in ``questions/qa_<id6>.json`` with the engine that made the dataset, ``generation_config.json``):

* accuracy per paper column, sub-category and template, for each split, beside the paper's rows (``craft-dsl score
  --compare-paper``);
* perception: layout identified, attribute accuracy (objects whose (shape, colour, size) is read exactly), mean
  position error in pixels of the reconstructed motion against the true trajectory (every step of every object),
  event precision and recall (same type, same objects, within 2 steps);
* seconds of perception per video, and its ratio to decoding alone (the decoder's time in the same run);
* each wrong answer's stage: *program* (the question's program, run on the true simulation, gives another answer),
  *execution* (the exact perceived scene of the true simulation, ``export_perceived``, answers wrong too),
  *perception: layout or attributes*, *perception: factual run* (a descriptive question, or a counterfactual one whose
  factual events differ from the truth), *re-simulation* (a counterfactual or causal question whose factual events
  all match: the counterfactual run differs).

Run: ``python benchmarks/reader.py --dataset DIR --workers 2 [--limit N] [--json out.json]``. Figures are printed
(Markdown), never asserted.

Frame rates: ``--fps 10`` reads the dataset's downsampled copies (``downsampled/10-fps/``, written by ``craft-dsl
generate --videos --downsampled 5,10``) instead of the 60-fps videos, at the rate the reader measures in them (the
same questions, the same ground truth); ``--all-questions`` scores every question of the videos read (a third table,
``all``), for small datasets whose test parts hold few.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from reader_calibration import reliability

from craft_dsl.cli import main as cli_main
from craft_dsl.dataset.folder import DatasetFolder
from craft_dsl.dataset.samplers import LEGACY_SAMPLER, ORIGINAL_SAMPLER, start_state
from craft_dsl.errors import CraftError
from craft_dsl.perception import SceneModel, export_perceived
from craft_dsl.physics import simulate
from craft_dsl.program import to_json
from craft_dsl.question_parsing import question_to_program
from craft_dsl.ranges import parse_ranges
from craft_dsl.reader.answer import Question, answer_questions, find_videos, read_questions
from craft_dsl.reader.perceive import perceive_video
from craft_dsl.reader.reconstruct import MAX_ANCHORS
from craft_dsl.reader.votes import VOTES
from craft_dsl.render.raster import world_to_pixel
from craft_dsl.verify import read_minimal, read_split, score
from craft_dsl.verify.answers import answers_agree
from craft_dsl.verify.categories import family_of
from craft_dsl.vocabulary import DEFAULT_ENGINE, LEGACY_DEFAULT_ENGINE, ORIGINAL_ENGINE
from craft_dsl.world import DEFAULT_STEPS

STEP_TOLERANCE = 2


def _events(sim: Any, uid_map: dict[int, int] | None = None) -> list[tuple[str, tuple[int, ...], int]]:
    out = []
    for e in sim.events:
        if e.type in ("Start", "End"):
            continue
        objs = tuple(sorted(uid_map.get(o, -1 - o) if uid_map is not None else o for o in e.objects))
        out.append((e.type, objs, e.step))
    return out


def _match_events(ours: list[tuple[str, tuple[int, ...], int]], truth: list[tuple[str, tuple[int, ...], int]]
                  ) -> int:
    """Events of ``ours`` matched one to one with a true event of the same type and objects within 2 steps."""
    free: dict[tuple[str, tuple[int, ...]], list[int]] = defaultdict(list)
    for t, objs, step in truth:
        free[(t, objs)].append(step)
    matched = 0
    for t, objs, step in ours:
        steps = free.get((t, objs), [])
        best = min(steps, key=lambda s: abs(s - step), default=None)
        if best is not None and abs(best - step) <= STEP_TOLERANCE:
            steps.remove(best)
            matched += 1
    return matched


def _position_errors(uid_map: dict[int, int], ours_world: Any, ot: Any, tt: Any) -> list[float]:
    """Per matched dynamic object: mean distance (pixels, every step) of our trajectory from the true one."""
    errors = []
    for ours_uid, true_uid in uid_map.items():
        if ours_uid not in ot.ids or not ours_world.body(ours_uid).dynamic:
            continue
        a = ot.positions[1:, ot.column(ours_uid)]
        b = tt.positions[1:, tt.column(true_uid)]
        ax, ay = world_to_pixel(a[:, 0], a[:, 1])
        bx, by = world_to_pixel(b[:, 0], b[:, 1])
        errors.append(float(np.mean(np.hypot(np.asarray(ax) - bx, np.asarray(ay) - by))))
    return errors


def run_video(path: str, questions: list[Question], stats: dict[str, Any], truth_answers: dict[str, Any],
              engines: list[str] | None = None, votes: int = VOTES) -> dict[str, Any]:
    """Read one video as ``craft-dsl read`` does (the dataset's engine tried first), then compare everything with the
    ground truth."""
    t = time.perf_counter()
    try:
        perception = perceive_video(path, engines=engines, first_engine=stats["engine"])
    except CraftError as err:
        return {"path": path, "error": str(err), "questions": [q.key for q in questions]}
    perceived_s = time.perf_counter() - t
    t = time.perf_counter()
    answers = answer_questions(perception.scene, questions, votes=votes)
    answer_s = time.perf_counter() - t
    # -- ground truth (the benchmark's side) -------------------------------------------------------------------
    sim = true_simulation(stats)
    rec = perception.reconstruction
    true_world = sim.world_spec
    true_triples = {(b.shape, b.color, b.size): b.uid for b in true_world.bodies if b.dynamic}
    ours_world = rec.simulation.world_spec
    our_triples = {(b.shape, b.color, b.size): b.uid for b in ours_world.bodies if b.dynamic}
    attributes_ok = sum(1 for k in true_triples if k in our_triples)
    # calibration: the probability the perceived scene gives each reading, and whether the reading is right
    n_slots = len(rec.attributes)
    by_id = {o.id: o for o in perception.scene.objects}
    confidence = []
    for s in rec.slots:
        if s < 0:
            continue
        shape, color, size = rec.attributes[s]
        o = by_id[n_slots - 1 - s]
        p = (o.color or {}).get(color, 0.0) * (o.shape or {}).get(shape, 0.0) * (o.size or {}).get(size, 0.0)
        confidence.append((float(p), (shape, color, size) in true_triples))
    uid_map = {our_triples[k]: true_triples[k] for k in our_triples if k in true_triples}
    # statics: every non-dynamic uid maps to itself when the layout is right (creation order)
    if perception.layout.scene == stats["scene"]:
        for b in ours_world.bodies:
            if not b.dynamic:
                uid_map[b.uid] = b.uid
    errors: list[float] = []
    tt, ot = sim.trajectory, rec.simulation.trajectory
    if tt is not None:  # the original simulator writes no trajectory
        errors = _position_errors(uid_map, ours_world, ot, tt)
    our_events = _events(rec.simulation, uid_map)
    true_events = _events(sim)
    matched = _match_events(our_events, true_events)
    # the exact perceived scene of the truth (needs its trajectory: none for the original simulator's runs)
    exact = SceneModel(export_perceived(sim)).simulation() if tt is not None else None
    records = []
    for q, a in zip(questions, answers):
        truth = truth_answers[q.key]
        ok = answers_agree(a.answer, truth)
        stage = None
        if not ok:
            program = question_to_program(q.text)
            family = family_of(stats["template_ids"][q.key])
            if not answers_agree(to_json(program.run(sim), original=True), truth):
                stage = "program"
            elif exact is not None and not answers_agree(to_json(program.run(exact), original=True), truth):
                stage = "execution"
            elif perception.layout.scene != stats["scene"] or attributes_ok < len(true_triples):
                stage = "perception: layout or attributes"
            elif family == "D" or matched < len(true_events) or len(our_events) != len(true_events):
                stage = "perception: factual run"
            else:
                stage = "re-simulation"
        records.append({"key": q.key, "answer": a.answer, "truth": truth, "correct": ok, "stage": stage,
                        "template_id": stats["template_ids"][q.key]})
    return {"path": path, "scene": stats["scene"], "found_scene": perception.layout.scene,
            "objects": len(true_triples), "attributes_ok": attributes_ok, "confidence": confidence,
            "position_error_px": errors,
            "events_true": len(true_events), "events_ours": len(our_events), "events_matched": matched,
            "timings": {**perception.timings, "perception": perceived_s, "answering": answer_s},
            "anchors": rec.anchors, "physics": perception.scene.physics, "tried": list(rec.tried),
            "fps": perception.frame_rate.fps, "fps_source": perception.frame_rate.source,
            "questions": records}


class HeldOutQuestions(NamedTuple):
    """A generated dataset's test questions as the reader gets them, and the answers it is scored against."""

    parts: dict[str, set[tuple[int, int]]]  # split -> (video_index, question_index) of its test part
    truth: dict[str, Any]  # question key ("<video>_<question>") -> the dataset's answer
    template: dict[str, str]  # question key -> template id
    by_video: dict[int, list[Question]]  # video index -> its test questions, text only


def true_simulation(stats: dict[str, Any]) -> Any:
    """The video's simulation as the dataset made it: its start state drawn by the dataset's sampler (the original's
    own, a revision of the layouts), run by its engine (as the original pipeline, where both are the original)."""
    scene, seed, steps = stats["scene"], stats["simulation_seed"], stats.get("steps", DEFAULT_STEPS)
    sampler = stats.get("sampler", LEGACY_SAMPLER)
    if sampler == ORIGINAL_SAMPLER and stats["engine"] == ORIGINAL_ENGINE:
        from craft_dsl.physics.original_sampler import simulate_fresh

        return simulate_fresh(scene, seed, steps)
    return simulate(start_state(scene, seed, sampler), seed=seed, steps=steps, engine=stats["engine"])


def generation_settings(root: Path) -> tuple[str, int, str]:
    """The engine, the run length (steps) and the sampler the dataset at ``root`` was generated with, from its
    ``generation_config.json`` (pymunk, CRAFT's 600 steps and revision 1 of the layouts for a dataset without
    one)."""
    config = DatasetFolder(root).config or {}
    return (str(config.get("engine", LEGACY_DEFAULT_ENGINE)), int(config.get("steps", DEFAULT_STEPS)),
            str(config.get("sampler", LEGACY_SAMPLER)))


def held_out_questions(root: Path, all_questions: bool = False) -> HeldOutQuestions:
    """The test parts of both splits of the dataset in ``root`` (every question too, as part ``all``, with
    ``all_questions``), read through a questions file holding only (video_index, question_index, question)."""
    records = read_minimal(root / "dataset_minimal.json")
    template = {f"{q.video_index}_{q.question_index}": q.template_id for q in records}
    truth = {f"{q.video_index}_{q.question_index}": q.answer for q in records}
    parts = {split: read_split(root / f"split_info_{split}.json", "test") for split in ("random", "hard")}
    if all_questions:
        parts["all"] = {(q.video_index, q.question_index) for q in records}
    wanted = set().union(*parts.values())
    # the reader's input: (video_index, question_index, question) of each test question, nothing else
    raw = json.loads((root / "dataset_minimal.json").read_text())
    stripped = [{k: r[k] for k in ("video_index", "question_index", "question")} for r in raw
                if (r["video_index"], r["question_index"]) in wanted]
    with tempfile.TemporaryDirectory() as tmp:
        qfile = Path(tmp) / "questions.json"
        qfile.write_text(json.dumps(stripped))
        questions = read_questions(qfile)
    by_video: dict[int, list[Question]] = defaultdict(list)
    for q in questions:
        by_video[q.video_index].append(q)
    return HeldOutQuestions(parts, truth, template, dict(by_video))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", help="a dataset generated with --videos")
    parser.add_argument("--generate", type=int, help="generate a dataset of this many videos first (into --out)")
    parser.add_argument("--seed", type=int, default=777001, help="seed of the generated dataset")
    parser.add_argument("--out", help="folder of the generated dataset")
    parser.add_argument("--engines", help="the reader's physics engines, in order (default: the reader's own choice, "
                                          "the dataset's engine first, as craft-dsl read); e.g. pymunk to compare")
    parser.add_argument("--engine", default=DEFAULT_ENGINE,
                        help="physics (and renderer) of the generated dataset: box2d (the default), pymunk or "
                             "original")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--votes", type=int, default=VOTES,
                        help=f"perturbed replays per counterfactual question (craft-dsl read --votes; default {VOTES})")
    parser.add_argument("--limit", type=int, help="read only the first N test videos (a quick look)")
    parser.add_argument("--only", help="read only these video indices, e.g. 437,480-499 (development runs)")
    parser.add_argument("--json", help="write every figure and per-question record here")
    parser.add_argument("--fps", type=int, default=60,
                        help="read the downsampled copies at this rate (downsampled/<fps>-fps/); 60: the videos")
    parser.add_argument("--all-questions", action="store_true",
                        help="read every question of the videos, not only the test parts' (scored as 'all')")
    parser.add_argument("--decoders", type=int, default=0,
                        help="only compare the two decoders on this many of the test videos (median of 3 passes)")
    args = parser.parse_args()
    if args.generate:
        if not args.out:
            parser.error("--generate needs --out")
        cli_main(["generate", "--size", str(args.generate), "--seed", str(args.seed), "--videos", "--workers",
                  str(args.workers), "--engine", args.engine, "--out", args.out, "--quiet"])
        root = Path(args.out)
    elif args.dataset:
        root = Path(args.dataset)
    else:
        parser.error("give --dataset DIR or --generate SIZE --out DIR")
    tests = held_out_questions(root, args.all_questions)
    parts, truth, template, by_video = tests.parts, tests.truth, tests.template, tests.by_video
    videos = sorted(by_video)[: args.limit] if args.limit else sorted(by_video)
    if args.only:
        chosen = set(parse_ranges(args.only, "--only", 0, 10 ** 9, "video indices"))
        videos = [v for v in videos if v in chosen]
    folder = root / "videos" if args.fps == 60 else root / "downsampled" / f"{args.fps}-fps"
    paths = find_videos(folder, videos)
    if args.decoders:
        compare_decoders([paths[v] for v in videos[: args.decoders]])
        return
    engine, steps, sampler = generation_settings(root)
    jobs = []
    for v in videos:
        stats = json.loads((root / "questions" / f"qa_{v:06d}.json").read_text())["stats"]
        stats = {"scene": stats["scene"], "simulation_seed": stats["simulation_seed"], "engine": engine,
                 "steps": steps, "sampler": sampler, "template_ids": {q.key: template[q.key] for q in by_video[v]}}
        jobs.append((str(paths[v]), by_video[v], stats, {q.key: truth[q.key] for q in by_video[v]}))
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    results = []
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        engines = [args.engines.split(",")] * len(jobs) if args.engines else [None] * len(jobs)
        for i, r in enumerate(pool.map(run_video, *zip(*jobs), engines, [args.votes] * len(jobs)), 1):
            results.append(r)
            print(f"\r{i}/{len(jobs)} videos", end="", file=sys.stderr, flush=True)
    elapsed = time.perf_counter() - t0
    load_after = os.getloadavg()
    print(file=sys.stderr)
    report(root, results, parts, elapsed, args.workers, load_before, load_after, args.json)


def compare_decoders(paths: list[Path]) -> None:
    """Seconds per video of each decoder (median of 3 passes per video), printed with their ratio."""
    from craft_dsl.reader.video import decode, have_pyav

    decoders = ["ffmpeg"] + (["pyav"] if have_pyav() else [])
    times: dict[str, list[float]] = defaultdict(list)
    for path in paths:
        for name in decoders:
            passes = []
            for _ in range(3):
                t = time.perf_counter()
                decode(path, name)  # type: ignore[arg-type]
                passes.append(time.perf_counter() - t)
            times[name].append(float(np.median(passes)))
    base = float(np.mean(times["ffmpeg"]))
    print(f"decoding {len(paths)} videos (load average {os.getloadavg()[0]:.2f})")
    for name in decoders:
        m = float(np.mean(times[name]))
        print(f"{name:7s}: {m:.3f} s per video, {m / base:.2f}x imageio-ffmpeg")


def report(root: Path, results: list[dict[str, Any]], parts: dict[str, set[tuple[int, int]]], elapsed: float,
           workers: int, load_before: tuple[float, float, float], load_after: tuple[float, float, float],
           json_out: str | None) -> None:
    ok = [r for r in results if "error" not in r]
    predictions = {tuple(map(int, q["key"].split("_"))): q["answer"] for r in ok for q in r["questions"]}
    questions = read_minimal(root / "dataset_minimal.json")
    rates = Counter(f"{r['fps']:g} fps ({r['fps_source']})" for r in ok)
    lines = [f"{len(results)} videos ({len(results) - len(ok)} not read; read at {', '.join(sorted(rates))}), "
             f"{len(predictions)} questions; "
             f"{elapsed:.0f} s with {workers} workers; load average {load_before[0]:.2f} before, "
             f"{load_after[0]:.2f} after", ""]
    data: dict[str, Any] = {"videos": len(results), "failed": [r for r in results if "error" in r]}
    for split, paper in (("random", "easy"), ("hard", "hard"), ("all", None)):
        if split not in parts:
            continue
        keys = {k for k in parts[split] if k in predictions}
        rep = score(questions, {k: v if v is not None else "None" for k, v in predictions.items()}, split=keys)
        lines += [f"### {split} split, test part ({len(keys)} questions)", "", "```",
                  rep.format(per_template=True, compare_paper=paper, label="reader"), "```", ""]
        data[split] = rep.to_json()
    # perception
    objects = sum(r["objects"] for r in ok)
    attrs = sum(r["attributes_ok"] for r in ok)
    pos = [e for r in ok for e in r["position_error_px"]]
    ev_true = sum(r["events_true"] for r in ok)
    ev_ours = sum(r["events_ours"] for r in ok)
    ev_match = sum(r["events_matched"] for r in ok)
    layout_ok = sum(r["scene"] == r["found_scene"] for r in ok)
    timings: dict[str, list[float]] = defaultdict(list)
    for r in ok:
        for k, v in r["timings"].items():
            timings[k].append(v)
    perception = {
        "layout identified": f"{layout_ok}/{len(ok)} ({100 * layout_ok / max(len(ok), 1):.1f} %)",
        "attribute accuracy (objects read exactly)": f"{attrs}/{objects} ({100 * attrs / max(objects, 1):.2f} %)",
        "mean position error (px, every step of every object)": (
            f"{np.mean(pos):.3f} (median object {np.median(pos):.3f}, 90th pct {np.quantile(pos, 0.9):.2f})" if pos
            else "not measured (no true trajectory: the original simulator writes start and end states only)"),
        "event precision": f"{100 * ev_match / max(ev_ours, 1):.2f} % ({ev_match}/{ev_ours})",
        "event recall": f"{100 * ev_match / max(ev_true, 1):.2f} % ({ev_match}/{ev_true})",
        "videos with re-anchored bodies": f"{sum(r['anchors'] > 0 for r in ok)}/{len(ok)}",
        "physics kept (videos)": ", ".join(f"{name} {n}" for name, n in sorted(Counter(
            r.get("physics") or "?" for r in ok).items())) + f" (a second engine tried on "
            f"{sum(len(r.get('tried', [])) > 1 for r in ok)})",
    }
    lines += ["### Perception", "", "| metric | value |", "|---|---|"]
    pairs = [(p, ok_) for r in ok for p, ok_ in r.get("confidence", [])]
    if pairs:
        stated, right = [p for p, _ in pairs], [c for _, c in pairs]
        bins = reliability(stated, right, edges=(0.0, 0.5, 0.9, 0.99, 0.999, 1.01))
        cells = [f"[{lo:g}, {min(hi, 1):g}): {k} objects, stated {mean_p:.3f}, right {acc:.3f}"
                 for lo, hi, k, mean_p, acc in bins]
        gap = sum(k * abs(mean_p - acc) for _lo, _hi, k, mean_p, acc in bins)
        perception["calibration of the stated attribute probability (bins)"] = "; ".join(cells)
        perception["expected calibration error"] = f"{gap / len(pairs):.4f}"
    lines += [f"| {k} | {v} |" for k, v in perception.items()]
    decode = float(np.mean(timings["decode"]))
    lines += ["", "| stage | seconds per video (mean) | ratio to decoding |", "|---|---|---|"]
    for k in ("decode", "layout", "detect", "reconstruct", "perception", "answering"):
        if timings.get(k):
            m = float(np.mean(timings[k]))
            lines.append(f"| {k} | {m:.3f} | {m / decode:.2f} |")
    lines += latency_lines(ok)
    stages = Counter((q["stage"], family_of(q["template_id"])) for r in ok for q in r["questions"] if q["stage"])
    lines += ["", "### Wrong answers by stage", "", "| stage | C | CF | D | all |", "|---|---|---|---|---|"]
    for stage in sorted({s for s, _ in stages}):
        row = [stages.get((stage, f), 0) for f in ("C", "CF", "D")]
        lines.append(f"| {stage} | " + " | ".join(map(str, row)) + f" | {sum(row)} |")
    print("\n".join(lines))
    data.update(perception=perception, timings={k: float(np.mean(v)) for k, v in timings.items()},
                stages={f"{s} | {f}": n for (s, f), n in stages.items()}, elapsed_s=elapsed,
                load=[load_before, load_after], per_video=ok)
    if json_out:
        Path(json_out).write_text(json.dumps(data, indent=1, default=str))


def latency_lines(ok: list[dict[str, Any]]) -> list[str]:
    """Where a video's time goes: seconds per video (perception and answering) as median, 90th percentile and
    maximum, and the reconstruction's time by the number of restarts of straying bodies (at most ``MAX_ANCHORS``)
    and whether a second engine was tried."""
    if not ok:
        return []
    total = np.array([r["timings"].get("perception", 0.0) + r["timings"].get("answering", 0.0) for r in ok])
    rec = np.array([r["timings"].get("reconstruct", 0.0) for r in ok])
    lines = ["", f"Seconds per video, perception and answering: median {np.median(total):.2f}, 90th percentile "
             f"{np.quantile(total, 0.9):.2f}, largest {total.max():.2f}.", "",
             "| videos by restarts of straying bodies | videos | reconstruction s (mean) | share of reconstruction |",
             "|---|---|---|---|"]
    groups: dict[str, list[int]] = defaultdict(list)
    for i, r in enumerate(ok):
        anchors = int(r.get("anchors", 0))
        label = ("none" if anchors == 0 else "1-2" if anchors <= 2 else "3-5" if anchors < MAX_ANCHORS
                 else f"{anchors} (the most)")
        groups[label].append(i)
        if len(r.get("tried", [])) > 1:
            groups["a second engine tried"].append(i)
    order = ["none", "1-2", "3-5"] + sorted(k for k in groups if k[0].isdigit() and "-" not in k) + [
        "a second engine tried"]
    for label in order:
        if label in groups:
            idx = groups[label]
            share = rec[idx].sum() / max(rec.sum(), 1e-9)
            lines.append(f"| {label} | {len(idx)} | {rec[idx].mean():.2f} | {share:.0%} |")
    return lines


if __name__ == "__main__":
    main()
