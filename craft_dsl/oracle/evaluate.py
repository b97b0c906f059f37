"""Evaluating a model's predictions against the oracle: per question, per paper category, per module.

For every question of a CRAFT-format dataset (``dataset.json`` with its programs and recorded answers, and
``annotations.json`` with the simulations), the oracle reads what the model predicted and reports:

* the **program**'s outcome (syntax error, type error, INVALID, answer), whether it is exactly the
  ground-truth program (same checked nodes, whatever the form), and whether the answer it gives on the true
  simulation is the recorded one (*execution accuracy*);
* whether the predicted **answer** is the recorded one;
* for a **trace**, the first node whose output differs from the oracle's and the agreement per module;
* for an **answer distribution**, whether its mode is right, the log-likelihood of the recorded answer and the
  Brier score.

Rates are over every question of the group (a question without the field counts as wrong), so that a model
cannot score by answering only what it is sure of; the counts say how many questions carried each field.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import CraftError
from ..program import Program
from ..simulation import Simulation
from ..verify.annotations import Annotations, open_annotations
from ..verify.answers import answers_agree, normalise_answer
from ..verify.formats import PathLike, Question, parse_questions, read_questions
from .forms import ProgramCache, detect_form
from .outcome import check_outcome, run_outcome
from .predictions import MISSING, Prediction, collect_predictions
from .report import EvaluationReport, Metrics, QuestionResult
from .traces import compare_trace

__all__ = ["EvaluationReport", "Metrics", "QuestionResult", "evaluate_predictions", "score_distribution"]


def _questions(dataset: PathLike | Sequence[Any]) -> tuple[list[Question], Path | None]:
    if isinstance(dataset, (str, os.PathLike)):
        p = Path(dataset)
        if p.is_dir():
            if not (p / "dataset.json").is_file():
                raise CraftError(f"{p}: directory holds no dataset.json")
            return read_questions(p / "dataset.json"), p
        return read_questions(p), p.parent
    items = list(dataset)
    if items and all(isinstance(q, Question) for q in items):
        return items, None
    return parse_questions(items, "dataset"), None


def _annotations(annotations: Any, folder: Path | None) -> Annotations:
    if annotations is not None:
        return open_annotations(annotations)
    if folder is not None and (folder / "annotations.json").is_file():
        return open_annotations(folder / "annotations.json")
    raise CraftError("no annotations given: pass annotations.json (or a directory of <id6>.json simulations); "
                     "it is looked up beside dataset.json by default")


def score_distribution(dist: Mapping[str, float], recorded: Any) -> tuple[bool, float, float]:
    """Mode correct, log-likelihood of the recorded answer and Brier score of a distribution ``{answer key:
    probability}``, scored as :class:`craft_dsl.perception.AnswerDistribution` scores (natural log with
    probabilities floored at its ``LOG_FLOOR``; Brier: sum over answers of (p - [answer is recorded])^2)."""
    from ..perception.distribution import AnswerDistribution

    distribution = AnswerDistribution(dict(dist), {k: k for k in dist}, "given", 0)
    truth = normalise_answer(recorded)
    return (normalise_answer(distribution.mode) == truth, distribution.log_likelihood(recorded),
            distribution.brier(recorded))


def evaluate_predictions(
    dataset: PathLike | Sequence[Any],
    predictions: PathLike | Mapping[Any, Any] | Sequence[Any] | Iterable[Prediction],
    annotations: PathLike | Mapping[str, Any] | Annotations | None = None,
    *,
    split: Iterable[tuple[int, int]] | None = None,
    token_order: str = "prefix",
    progress: Callable[[int], None] | None = None,
) -> EvaluationReport:
    """Evaluate predictions (answers, programs in any form, traces, answer distributions) against the oracle.

    ``dataset``: ``dataset.json``, a folder holding it (and ``annotations.json``), its parsed list, or
    :class:`~craft_dsl.verify.Question` records. ``annotations``: ``annotations.json``, a folder of ``<id6>.json``
    simulations, a mapping or an :class:`~craft_dsl.verify.Annotations` (default: beside ``dataset.json``).
    ``predictions``: a ``.json``/``.jsonl`` path or parsed predictions (see :mod:`craft_dsl.oracle.predictions`).
    ``split``: the keys to evaluate (others are counted in ``outside_split``). ``token_order``: how lists of
    strings without ``program_format`` are read. Bad input raises :class:`~craft_dsl.errors.CraftError` naming
    the file, record and field; nothing a program does at run time does.
    """
    if token_order not in ("prefix", "postfix"):
        raise CraftError(f"token order must be 'prefix' or 'postfix', not {token_order!r}")
    questions, folder = _questions(dataset)
    preds = collect_predictions(predictions)
    known = {q.key for q in questions}
    unknown = [p for k, p in preds.items() if k not in known]
    if unknown:
        shown = ", ".join(f"{p.key[0]}_{p.key[1]}" for p in unknown[:5])
        raise CraftError(f"{unknown[0].where}: {len(unknown)} prediction(s) name questions the dataset does not "
                         f"have ({shown}{' ...' if len(unknown) > 5 else ''})")
    selected = set(split) if split is not None else None
    report = EvaluationReport()
    for p in preds.values():
        for name in p.unknown_fields:
            report.unknown_fields[name] = report.unknown_fields.get(name, 0) + 1
    needs_sim = any(p.program is not MISSING or p.trace is not MISSING for p in preds.values())
    store = _annotations(annotations, folder) if needs_sim else None
    cache = ProgramCache()
    by_video: dict[tuple[int, str], list[Question]] = {}
    for q in questions:
        if selected is not None and q.key not in selected:
            report.outside_split += 1
            continue
        by_video.setdefault((q.video_index, q.video), []).append(q)
    for (video_index, video), group in by_video.items():
        sims: list[Simulation] = []

        def sim_of(video: str = video, video_index: int = video_index, sims: list[Simulation] = sims) -> Simulation:
            if not sims:
                assert store is not None
                key = store.resolve(video, video_index)
                if key is None:
                    raise CraftError(f"{store.name}: no simulation for video {video!r} (video_index {video_index})")
                sims.append(store.simulation(key))
            return sims[0]

        for q in group:
            report.add(_evaluate_one(q, preds.get(q.key), sim_of, cache, token_order))
        if progress is not None:
            progress(len(group))
    return report


def _evaluate_one(q: Question, pred: Prediction | None, sim_of: Callable[[], Simulation], cache: ProgramCache,
                  token_order: str) -> QuestionResult:
    result = QuestionResult(q.key, q.template_id, predicted=pred is not None)
    if pred is None:
        return result
    checked: Program | None = None
    if pred.program is not MISSING:
        where = f"{pred.where}, field 'program'"
        try:
            form = pred.program_format or detect_form(pred.program, token_order)
        except CraftError as err:
            raise CraftError(f"{where}: {err}") from None
        if q.program is None:
            raise CraftError(f"{q.where}: the record has no program to compare with (dataset_minimal.json records "
                             "cannot be evaluated; use dataset.json)")
        try:
            truth = cache.get(list(q.program), "nodes")
        except CraftError as err:
            raise CraftError(f"{q.where}, field 'program': cannot read the ground-truth program: {err}") from None
        outcome, checked = check_outcome(pred.program, form, cache)  # type: ignore[arg-type]
        if checked is not None:
            outcome = run_outcome(checked, sim_of(), form)  # type: ignore[arg-type]
        assert outcome is not None
        result.outcome = outcome
        result.exact_match = checked is not None and checked.key == truth.key
        result.execution_correct = outcome.kind == "answer" and answers_agree(outcome.answer, q.answer)
    if pred.answer is not MISSING:
        result.answer_correct = answers_agree(pred.answer, q.answer)
    if pred.trace is not MISSING:
        if pred.program is not MISSING and checked is None:
            result.trace_skipped = "the predicted program does not check, so its trace has no nodes to compare"
        else:
            target = checked if checked is not None else _truth(q, cache)
            result.trace = compare_trace(target, sim_of(), pred.trace, f"{pred.where}, field 'trace'")
    if pred.distribution is not None:
        result.mode_correct, result.log_likelihood, result.brier = score_distribution(pred.distribution, q.answer)
    return result


def _truth(q: Question, cache: ProgramCache) -> Program:
    if q.program is None:
        raise CraftError(f"{q.where}: the record has no program, so a trace cannot be compared")
    return cache.get(list(q.program), "nodes")
