"""The oracle for model predictions: predicted programs in any form, their outcome, traces, and scores.

* :mod:`.forms`: the forms a predicted program comes in; :class:`ProgramCache`;
* :mod:`.outcome`: one outcome per program (syntax error, type error, INVALID, answer);
* :mod:`.batch`: :func:`run_batch`, the outcomes of a whole batch of programs with the shared work done once;
* :mod:`.traces`: a model's intermediate outputs against the oracle's;
* :mod:`.predictions`: predictions files (answers, programs, traces, answer distributions);
* :mod:`.evaluate`: :func:`evaluate_predictions` and its :class:`EvaluationReport`; :mod:`.report` prints it.
"""

from __future__ import annotations

from .batch import BatchResult, run_batch
from .evaluate import EvaluationReport, Metrics, QuestionResult, evaluate_predictions, score_distribution
from .forms import FORMS, ProgramCache, ProgramForm, detect_form, read_program
from .outcome import OUTCOMES, ProgramOutcome, check_outcome, explain_invalid, program_outcome, run_outcome
from .predictions import MISSING, Prediction, collect_predictions, read_predictions
from .traces import Divergence, TraceComparison, TraceError, compare_trace, values_agree

__all__ = [
    "FORMS", "MISSING", "OUTCOMES", "BatchResult", "Divergence", "EvaluationReport", "Metrics", "Prediction",
    "ProgramCache", "ProgramForm", "ProgramOutcome", "QuestionResult", "TraceComparison", "TraceError",
    "check_outcome", "collect_predictions", "compare_trace", "detect_form", "evaluate_predictions", "explain_invalid",
    "program_outcome", "read_predictions", "read_program", "run_batch", "run_outcome", "score_distribution",
    "values_agree",
]
