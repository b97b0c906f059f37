"""Calibration of the reader's confidences: refit ``craft_dsl/reader/confidence.json`` from labelled read-details and
print the reliability diagram, the expected calibration error and the risk-coverage table.

A labelled set is a dataset written by ``craft-dsl generate --videos`` and the ``--details`` of ``craft-dsl read`` on
its videos and question texts (every part: train, val and test; ``--read`` makes them), given as
``DATASET:DETAILS[:PERCEIVED]`` (``DETAILS``: a ``--details`` file, or the journal of a run, ``<out>.partial.jsonl``).
Details written before answers carried confidences lack ``confidence_inputs``: with the ``--perceived`` folder of
that read (``PERCEIVED``) they are measured again from the perceived scenes (and kept in
``DETAILS.measured.jsonl``). Each
answer is right when it agrees with the dataset's (``craft_dsl.verify.answers.answers_agree``, as
``benchmarks/reader.py`` scores). ``--measure-again`` measures every answer's inputs again from the perceived scenes
with the current code (kept in ``DETAILS.measured-again.jsonl``); ``--without-engine-alternative`` does so as an
install without the other physics engine would (the engine alternative unavailable for every answer; kept in
``DETAILS.measured-without-engine.jsonl``), so that calibration is measured both ways.

Run::

    python benchmarks/reader_calibration.py --read /tmp/ho --out /tmp/conf/ho --workers 2   # details + perceived
    python benchmarks/reader_calibration.py --fit /tmp/ho:/tmp/conf/ho/details.jsonl ... \\
        --eval /tmp/ho2:/tmp/conf/ho2/details.jsonl ... [--write]
    python benchmarks/reader_calibration.py --without-engine-alternative \\
        --eval /tmp/ho2:/tmp/conf/ho2/details.jsonl:/tmp/conf/ho2/perceived

Figures are printed (Markdown), never asserted.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from craft_dsl.reader.confidence import MODEL_PATH, ConfidenceModel, confidence_inputs, default_model, fit_model
from craft_dsl.verify.answers import answers_agree

#: Coverages of the risk-coverage table (fraction of the answers kept, the most confident first).
COVERAGES = (1.0, 0.9, 0.8, 0.7, 0.5)
BINS = 10


@dataclass
class Labelled:
    """One answer of a labelled set: its confidence inputs, whether it is a fallback, and whether it is right."""

    source: str
    key: str
    inputs: dict[str, Any] | None
    fallback: bool
    warning: bool
    correct: bool
    template_id: str
    premise: bool = False


def reliability(confidence: Sequence[float], correct: Sequence[bool], bins: int = BINS,
                edges: Sequence[float] | None = None) -> list[tuple[float, float, int, float, float]]:
    """Equal-width bins of ``confidence`` over [0, 1] (the last one closed), or the bins [edges[i], edges[i + 1])
    where ``edges`` are given: ``(low, high, answers, mean confidence, accuracy)`` for each bin that holds an
    answer."""
    c = np.asarray(confidence, dtype=float)
    y = np.asarray(correct, dtype=float)
    if edges is None:
        bounds = [b / bins for b in range(bins + 1)]
        index = np.minimum((c * bins).astype(int), bins - 1)
    else:
        bounds = list(edges)
        index = np.searchsorted(np.asarray(bounds), c, side="right") - 1
    out = []
    for b in range(len(bounds) - 1):
        inside = index == b
        if inside.any():
            out.append((bounds[b], bounds[b + 1], int(inside.sum()), float(c[inside].mean()),
                        float(y[inside].mean())))
    return out


def ece(confidence: Sequence[float], correct: Sequence[bool], bins: int = BINS) -> float:
    """Expected calibration error: the answer-weighted mean of |accuracy - mean confidence| over the bins of
    :func:`reliability`."""
    n = len(confidence)
    if n == 0:
        return 0.0
    return sum(k * abs(acc - conf) for _, _, k, conf, acc in reliability(confidence, correct, bins)) / n


def risk_coverage(confidence: Sequence[float], correct: Sequence[bool], coverages: Sequence[float] = COVERAGES
                  ) -> list[tuple[float, int, float]]:
    """``(coverage, answers kept, accuracy of those)``: the ``ceil(coverage * n)`` most confident answers kept (ties
    in the order given; a stable sort)."""
    c = np.asarray(confidence, dtype=float)
    y = np.asarray(correct, dtype=float)
    order = np.argsort(-c, kind="stable")
    out = []
    for cov in coverages:
        k = int(np.ceil(cov * len(c) - 1e-9))
        out.append((cov, k, float(y[order[:k]].mean()) if k else float("nan")))
    return out


def _details(path: Path) -> list[dict[str, Any]]:
    """The answers of a ``--details`` file, or of a run's journal (``<out>.partial.jsonl``: its finished videos)."""
    rows = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.strip():
            continue
        value = json.loads(line)
        if "journal" in value:
            continue
        rows += value.get("details", [value])
    return rows


def _measured_again(rows: list[dict[str, Any]], questions: dict[tuple[int, int], str], perceived: Path,
                    every: bool = False) -> None:
    """Fill ``confidence_inputs`` of the rows that lack it (``every``: of every row) from the perceived scene of
    their video."""
    from craft_dsl.perception.schema import PerceivedScene
    from craft_dsl.reader.answer import Answer, Question

    by_video: dict[int, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        if every or "confidence_inputs" not in r:
            by_video[r["video_index"]].append(r)
    for done, (v, group) in enumerate(sorted(by_video.items()), 1):
        scene = PerceivedScene.model_validate_json((perceived / f"{v:06d}.json").read_text(encoding="utf-8"))
        qs = [Question(v, r["question_index"], questions[(v, r["question_index"])]) for r in group]
        answers = [Answer(q, r["answer"], fallback=bool(r.get("fallback")), premise=r.get("premise"))
                   for q, r in zip(qs, group)]
        for r, inputs in zip(group, confidence_inputs(scene, qs, answers)):
            r["confidence_inputs"] = inputs
        print(f"\r{perceived}: {done}/{len(by_video)} videos measured", end="", file=sys.stderr, flush=True)
    if by_video:
        print(file=sys.stderr)


def without_engine_alternative() -> None:
    """Measure from now on as an install without the other physics engine would: the engine alternative
    unavailable for every answer (:func:`craft_dsl.reader.confidence.engine_missing`)."""
    from craft_dsl.reader import confidence

    def missing(engine: str) -> str:
        return f"{engine}: left out (benchmarks/reader_calibration.py --without-engine-alternative)"

    confidence.engine_missing = missing


def load_labelled(spec: str, again: str = "") -> list[Labelled]:
    """The labelled answers of ``DATASET:DETAILS[:PERCEIVED]``; ``again``: measure every answer's inputs again
    from the perceived scenes, kept in ``DETAILS.measured-<again>.jsonl``."""
    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise SystemExit(f"{spec}: expected DATASET:DETAILS or DATASET:DETAILS:PERCEIVED")
    root, details = Path(parts[0]), Path(parts[1])
    records = json.loads((root / "dataset_minimal.json").read_text(encoding="utf-8"))
    truth = {(r["video_index"], r["question_index"]): r for r in records}
    # the rows measured again, kept for later runs
    measured = details.with_name(details.name + (f".measured-{again}" if again else ".measured") + ".jsonl")
    rows = _details(measured if measured.exists() else details)
    if (again and not measured.exists()) or any("confidence_inputs" not in r for r in rows):
        if len(parts) != 3:
            raise SystemExit(f"{details}: answers to measure again (without confidence_inputs, or "
                             "--measure-again / --without-engine-alternative); give the --perceived folder of that "
                             "read as DATASET:DETAILS:PERCEIVED")
        _measured_again(rows, {k: r["question"] for k, r in truth.items()}, Path(parts[2]), every=bool(again))
        measured.write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    out = []
    for r in rows:
        t = truth[(r["video_index"], r["question_index"])]
        out.append(Labelled(spec, f"{r['video_index']}_{r['question_index']}", r["confidence_inputs"],
                            bool(r.get("fallback")), r.get("warning") is not None,
                            r["answer"] is not None and answers_agree(r["answer"], t["answer"]), t["template_id"],
                            r.get("premise") is not None))
    return out


def ece_interval(confidence: Sequence[float], correct: Sequence[bool], resamples: int = 1000, seed: int = 0
                 ) -> tuple[float, float]:
    """The 5th and 95th percentiles of the ECE over ``resamples`` bootstrap resamples of the answers (drawn from
    ``numpy.random.default_rng(seed)``)."""
    rng = np.random.default_rng(seed)
    c = np.asarray(confidence, dtype=float)
    y = np.asarray(correct, dtype=bool)
    values = []
    for _ in range(resamples):
        pick = rng.integers(0, len(c), len(c))
        values.append(ece(c[pick].tolist(), y[pick].tolist()))
    low, high = np.percentile(values, [5, 95])
    return float(low), float(high)


def cross_validated(labelled: list[Labelled], folds: int, l2: float, drop: Sequence[str], seed: int = 0
                    ) -> list[float]:
    """Each answer's confidence from a model fitted on the other folds (``folds`` folds of whole videos of each
    set, assigned by ``numpy.random.default_rng(seed)``)."""
    videos = sorted({(x.source, x.key.split("_")[0]) for x in labelled})
    fold_of = dict(zip(videos, np.random.default_rng(seed).integers(0, folds, len(videos)).tolist()))
    fold = [fold_of[(x.source, x.key.split("_")[0])] for x in labelled]
    out = [0.0] * len(labelled)
    for k in range(folds):
        train = [x for x, f in zip(labelled, fold) if f != k]
        model = fit_model([x.inputs or {} for x in train], [x.correct for x in train], [x.fallback for x in train],
                          l2, drop=drop)
        for i, (x, f) in enumerate(zip(labelled, fold)):
            if f == k:
                out[i] = model.confidence(x.inputs, x.fallback, x.warning, x.premise)
    return out


def report(name: str, labelled: list[Labelled], model: ConfidenceModel,
           confidences: Sequence[float] | None = None) -> dict[str, Any]:
    """Print the reliability diagram, ECE (with its bootstrap interval) and risk-coverage table of ``model`` on
    ``labelled`` (or of the ``confidences`` given); return them."""
    conf = list(confidences) if confidences is not None else \
        [model.confidence(x.inputs, x.fallback, x.warning, x.premise) for x in labelled]
    ok = [x.correct for x in labelled]
    e = ece(conf, ok)
    low, high = ece_interval(conf, ok)
    print(f"### {name}: {len(ok)} answers, accuracy {100 * np.mean(ok):.2f} %, mean confidence "
          f"{100 * np.mean(conf):.2f} %, ECE {e:.4f} (90 % bootstrap interval {low:.4f}-{high:.4f})\n")
    print("| confidence | answers | mean confidence | accuracy |\n|---|---|---|---|")
    bins = reliability(conf, ok)
    for lo, hi, k, c, acc in bins:
        print(f"| [{lo:.1f}, {hi:.1f}{']' if hi == 1 else ')'} | {k} | {c:.3f} | {acc:.3f} |")
    print("\n| coverage | answers kept | accuracy |\n|---|---|---|")
    table = risk_coverage(conf, ok)
    for cov, k, acc in table:
        print(f"| {100 * cov:.0f} % | {k} | {100 * acc:.2f} % |")
    print()
    return {"answers": len(ok), "accuracy": float(np.mean(ok)), "ece": e, "ece_interval": (low, high), "bins": bins,
            "risk_coverage": table}


def read_dataset(root: Path, out: Path, workers: int, every: int = 1, offset: int = 0) -> None:
    """``craft-dsl read`` on every question (texts only) of the videos of a dataset whose index is ``offset``
    modulo ``every`` into ``out``: details.jsonl, perceived/ (videos are numbered scene by scene: every third one
    still covers every scene)."""
    from craft_dsl.cli import main as cli_main

    out.mkdir(parents=True, exist_ok=True)
    raw = json.loads((root / "dataset_minimal.json").read_text(encoding="utf-8"))
    questions = out / "questions.json"
    questions.write_text(json.dumps([{k: r[k] for k in ("video_index", "question_index", "question")} for r in raw
                                     if r["video_index"] % every == offset]))
    cli_main(["read", "--videos", str(root / "videos"), "--questions", str(questions), "--out",
              str(out / "preds.json"), "--details", str(out / "details.jsonl"), "--perceived", str(out / "perceived"),
              "--workers", str(workers), "--quiet"])


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--read", help="read every question of this dataset first (into --out)")
    parser.add_argument("--out", help="folder of --read's details.jsonl, preds.json and perceived/")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--every", type=int, default=1, help="with --read: only the videos whose index is --offset "
                                                             "modulo this")
    parser.add_argument("--offset", type=int, default=0, help="with --every: the remainder of the videos read")
    parser.add_argument("--fit", nargs="*", default=[], metavar="DATASET:DETAILS[:PERCEIVED]",
                        help="labelled sets to fit the model on")
    parser.add_argument("--eval", nargs="*", default=[], metavar="DATASET:DETAILS[:PERCEIVED]",
                        help="held-out labelled sets to report on")
    parser.add_argument("--l2", type=float, default=30.0, help="L2 penalty of the standardised weights (30: the best "
                                                               "log-loss of 1, 10, 30, 100 in 5-fold cross-validation "
                                                               "by video on the fit set)")
    parser.add_argument("--drop", nargs="*", default=[], metavar="FEATURE",
                        help="features to leave out of the fit (name prefixes, e.g. differs:resimulate category=)")
    parser.add_argument("--cv", type=int, default=0, help="also report K-fold cross-validation by video on the fit "
                                                          "set (default: none)")
    parser.add_argument("--write", action="store_true", help=f"write the fitted model to {MODEL_PATH}")
    parser.add_argument("--measure-again", action="store_true",
                        help="measure every answer's inputs again from the perceived scenes with the current code "
                             "(sets given as DATASET:DETAILS:PERCEIVED)")
    parser.add_argument("--without-engine-alternative", action="store_true",
                        help="measure every answer's inputs again as an install without the other physics engine "
                             "would (the engine alternative unavailable), from the perceived scenes")
    args = parser.parse_args(argv)
    again = ""
    if args.without_engine_alternative:
        without_engine_alternative()
        again = "without-engine"
    elif args.measure_again:
        again = "again"
    if args.read:
        if not args.out:
            parser.error("--read needs --out")
        read_dataset(Path(args.read), Path(args.out), args.workers, args.every, args.offset)
        return
    fit = [x for spec in args.fit for x in load_labelled(spec, again)]
    model = default_model()
    if fit:
        model = fit_model([x.inputs or {} for x in fit], [x.correct for x in fit], [x.fallback for x in fit],
                          args.l2, meta={"fitted_on": list(args.fit), "answers": len(fit), "l2": args.l2},
                          drop=args.drop)
        print("| feature | weight (standardised) |\n|---|---|")
        for name, w in sorted(zip(model.features, model.weights), key=lambda fw: -abs(fw[1])):
            print(f"| {name} | {w:+.3f} |")
        print(f"\nbias {model.bias:+.3f}; fallback guesses right: "
              + ", ".join(f"{k} {v:.3f}" for k, v in sorted(model.fallback.items())) + "\n")
        report("fit set (" + ", ".join(args.fit) + ")", fit, model)
        if args.cv:
            report(f"fit set, {args.cv}-fold cross-validation by video", fit, model,
                   cross_validated(fit, args.cv, args.l2, args.drop))
        if args.write:
            MODEL_PATH.write_text(json.dumps(model.to_json(), indent=1) + "\n", encoding="utf-8")
            print(f"wrote {MODEL_PATH}", file=sys.stderr)
    held: list[Labelled] = []
    for spec in args.eval:
        one = load_labelled(spec, again)
        held += one
        report(f"held out: {spec}", one, model)
    if len(args.eval) > 1:
        report("held out, all", held, model)


if __name__ == "__main__":
    main()
