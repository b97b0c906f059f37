"""The oracle's report: per-question results, metrics per group, and the plain-text form."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..templates import templates
from ..verify.categories import CATEGORIES, FAMILIES, category_of, family_of
from ..verify.scoring import label_width
from .outcome import OUTCOMES, ProgramOutcome
from .traces import TraceComparison


@dataclass
class QuestionResult:
    """Everything the oracle found for one question."""

    key: tuple[int, int]
    template_id: str
    predicted: bool = False
    outcome: ProgramOutcome | None = None
    exact_match: bool | None = None
    execution_correct: bool | None = None
    answer_correct: bool | None = None
    trace: TraceComparison | None = None
    #: Why a given trace was not compared (its program did not check).
    trace_skipped: str | None = None
    mode_correct: bool | None = None
    log_likelihood: float | None = None
    brier: float | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"key": f"{self.key[0]}_{self.key[1]}", "template_id": self.template_id,
                               "predicted": self.predicted}
        if self.outcome is not None:
            out["program"] = self.outcome.to_json()
            out["exact_match"] = self.exact_match
            out["execution_correct"] = self.execution_correct
        if self.answer_correct is not None:
            out["answer_correct"] = self.answer_correct
        if self.trace is not None:
            out["trace"] = self.trace.to_json()
        if self.trace_skipped:
            out["trace_skipped"] = self.trace_skipped
        if self.mode_correct is not None:
            out["distribution"] = {"mode_correct": self.mode_correct, "log_likelihood": self.log_likelihood,
                                   "brier": self.brier}
        return out


@dataclass
class Metrics:
    """Counts over a group of questions; rates are read from them (over all questions of the group)."""

    questions: int = 0
    predicted: int = 0
    programs: int = 0
    outcomes: dict[str, int] = field(default_factory=lambda: dict.fromkeys(OUTCOMES, 0))
    exact_match: int = 0
    execution_correct: int = 0
    answers: int = 0
    answer_correct: int = 0
    traces: int = 0
    trace_nodes: int = 0
    trace_agreed: int = 0
    traces_fully_agreeing: int = 0
    distributions: int = 0
    mode_correct: int = 0
    log_likelihood: float = 0.0
    brier: float = 0.0

    def add(self, r: QuestionResult) -> None:
        self.questions += 1
        self.predicted += r.predicted
        if r.outcome is not None:
            self.programs += 1
            self.outcomes[r.outcome.kind] += 1
            self.exact_match += bool(r.exact_match)
            self.execution_correct += bool(r.execution_correct)
        if r.answer_correct is not None:
            self.answers += 1
            self.answer_correct += r.answer_correct
        if r.trace is not None:
            self.traces += 1
            self.trace_nodes += r.trace.compared
            self.trace_agreed += r.trace.agreed
            self.traces_fully_agreeing += r.trace.first_divergence is None
        if r.mode_correct is not None:
            self.distributions += 1
            self.mode_correct += r.mode_correct
            self.log_likelihood += r.log_likelihood or 0.0
            self.brier += r.brier or 0.0

    def _pct(self, n: int, of: int | None = None) -> float | None:
        of = self.questions if of is None else of
        return 100.0 * n / of if of else None

    @property
    def validity(self) -> float | None:
        """Share of questions whose predicted program parses and type-checks."""
        return self._pct(self.outcomes["invalid"] + self.outcomes["answer"])

    @property
    def exact_match_rate(self) -> float | None:
        return self._pct(self.exact_match)

    @property
    def execution_accuracy(self) -> float | None:
        return self._pct(self.execution_correct)

    @property
    def answer_accuracy(self) -> float | None:
        return self._pct(self.answer_correct)

    @property
    def trace_agreement(self) -> float | None:
        """Share of the compared trace nodes whose output agrees with the oracle's."""
        return self._pct(self.trace_agreed, self.trace_nodes)

    @property
    def mode_accuracy(self) -> float | None:
        """Share of the questions with an answer distribution whose mode is the recorded answer."""
        return self._pct(self.mode_correct, self.distributions)

    @property
    def mean_log_likelihood(self) -> float | None:
        return self.log_likelihood / self.distributions if self.distributions else None

    @property
    def mean_brier(self) -> float | None:
        return self.brier / self.distributions if self.distributions else None

    def to_json(self) -> dict[str, Any]:
        return {
            "questions": self.questions, "predicted": self.predicted, "programs": self.programs,
            "outcomes": dict(self.outcomes), "exact_match": self.exact_match,
            "execution_correct": self.execution_correct, "answers": self.answers,
            "answer_correct": self.answer_correct, "traces": self.traces, "trace_nodes": self.trace_nodes,
            "trace_agreed": self.trace_agreed, "traces_fully_agreeing": self.traces_fully_agreeing,
            "distributions": self.distributions, "mode_correct": self.mode_correct,
            "rates": {"program_validity": self.validity, "exact_match": self.exact_match_rate,
                      "execution_accuracy": self.execution_accuracy, "answer_accuracy": self.answer_accuracy,
                      "trace_agreement": self.trace_agreement, "mode_accuracy": self.mode_accuracy,
                      "mean_log_likelihood": self.mean_log_likelihood, "mean_brier": self.mean_brier},
        }


@dataclass
class EvaluationReport:
    """The result of :func:`evaluate_predictions`."""

    results: list[QuestionResult] = field(default_factory=list)
    overall: Metrics = field(default_factory=Metrics)
    per_family: dict[str, Metrics] = field(default_factory=lambda: {f: Metrics() for f in FAMILIES})
    per_category: dict[str, Metrics] = field(default_factory=dict)
    per_template: dict[str, Metrics] = field(default_factory=dict)
    #: Trace agreement per module: name -> [nodes compared, nodes agreeing].
    per_module: dict[str, list[int]] = field(default_factory=dict)
    #: Fields of prediction records that are not read, with the number of records carrying each.
    unknown_fields: dict[str, int] = field(default_factory=dict)
    outside_split: int = 0

    def add(self, r: QuestionResult) -> None:
        self.results.append(r)
        for m in (self.overall, self.per_family[family_of(r.template_id)],
                  self.per_category.setdefault(category_of(r.template_id), Metrics()),
                  self.per_template.setdefault(r.template_id, Metrics())):
            m.add(r)
        if r.trace is not None:
            for module, (compared, agreed) in r.trace.per_module.items():
                counts = self.per_module.setdefault(module, [0, 0])
                counts[0] += compared
                counts[1] += agreed

    def groups(self) -> list[tuple[str, Metrics]]:
        """Overall, the paper's columns and its sub-categories, in table order (groups without questions left out)."""
        out = [("All", self.overall)] + [(f, self.per_family[f]) for f in FAMILIES if self.per_family[f].questions]
        return out + [(c, self.per_category[c]) for c in CATEGORIES if c in self.per_category]

    def to_json(self, per_question: bool = False) -> dict[str, Any]:
        out: dict[str, Any] = {
            "overall": self.overall.to_json(),
            "groups": {name: m.to_json() for name, m in self.groups()},
            "per_template": {t: self.per_template[t].to_json() for t in templates() if t in self.per_template},
            "per_module": {m: {"compared": c, "agreed": a, "agreement": 100.0 * a / c if c else None}
                           for m, (c, a) in sorted(self.per_module.items())},
            "unknown_fields": dict(self.unknown_fields), "outside_split": self.outside_split,
        }
        if per_question:
            out["questions"] = [r.to_json() for r in self.results]
        return out

    def format(self, per_template: bool = False, failures: int = 10) -> str:
        """A plain-text report: overview, the per-category table, trace agreement per module, first failures."""
        return format_report(self, per_template, failures)


_COLUMNS = (("valid %", "validity"), ("exact %", "exact_match_rate"), ("exec %", "execution_accuracy"),
            ("answer %", "answer_accuracy"), ("trace %", "trace_agreement"))


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def _row(name: str, m: Metrics, shown: list[tuple[str, str]], width: int = 24) -> str:
    return f"{name:<{width}} {m.questions:>9}" + "".join(f"{_pct(getattr(m, attr)):>10}" for _, attr in shown)


def _failure(r: QuestionResult) -> str | None:
    head = f"{r.key[0]}_{r.key[1]} {r.template_id}:"
    o = r.outcome
    if o is not None and o.kind in ("syntax_error", "type_error"):
        return f"{head} {o.kind.replace('_', ' ')} at {o.location or 'the program'}: {o.message}"
    if o is not None and o.kind == "invalid":
        return f"{head} INVALID on the true simulation: {o.message}"
    if o is not None and not r.execution_correct:
        return f"{head} the program answers {o.answer!r}, not the recorded answer" + \
            ("" if r.exact_match else " (not the ground-truth program)")
    if r.trace is not None and r.trace.first_divergence is not None:
        d = r.trace.first_divergence
        text = d.expression if len(d.expression) <= 80 else d.expression[:77] + "..."
        return f"{head} trace differs first at node {d.node} {text}: oracle {d.expected!r}, model {d.found!r}"
    return None


def format_report(report: EvaluationReport, per_template: bool, failures: int) -> str:
    m = report.overall
    lines = [f"evaluated {m.questions} questions: {m.predicted} predicted; {m.programs} with a program, "
             f"{m.answers} with an answer, {m.traces} with a trace, {m.distributions} with an answer distribution"]
    if report.outside_split:
        lines.append(f"{report.outside_split} question(s) outside the selected split were not evaluated")
    for name, n in sorted(report.unknown_fields.items()):
        lines.append(f"note: field {name!r} of {n} prediction record(s) is not read (fields: answer, program, "
                     "program_format, trace, answer_distribution)")
    if m.programs:
        o = m.outcomes
        lines.append(f"programs: {o['syntax_error']} syntax errors, {o['type_error']} type errors, "
                     f"{o['invalid']} INVALID on the true simulation, {o['answer']} answered; "
                     f"{m.exact_match} exactly the ground-truth program")
    shown = [(label, attr) for label, attr in _COLUMNS
             if (attr not in ("validity", "exact_match_rate", "execution_accuracy") or m.programs)
             and (attr != "answer_accuracy" or m.answers) and (attr != "trace_agreement" or m.traces)]
    groups = report.groups()
    w = label_width("group", [name for name, _ in groups], 24)
    lines += ["", "rates over all questions of a group (trace %: over the compared nodes)",
              f"{'group':<{w}} {'questions':>9}" + "".join(f"{label:>10}" for label, _ in shown)]
    lines += [_row(name, g, shown, w) for name, g in groups]
    if per_template:
        rows = [(f"{t} {category_of(t)}", report.per_template[t]) for t in templates() if t in report.per_template]
        w = label_width("template", [name for name, _ in rows], 24)
        lines += ["", f"{'template':<{w}} {'questions':>9}" + "".join(f"{label:>10}" for label, _ in shown)]
        lines += [_row(name, m, shown, w) for name, m in rows]
    if m.distributions:
        lines += ["", f"answer distributions ({m.distributions} questions): mode accuracy {_pct(m.mode_accuracy)} %, "
                      f"mean log-likelihood of the recorded answer {m.mean_log_likelihood:.4f}, "
                      f"mean Brier score {m.mean_brier:.4f}"]
    if report.per_module:
        w = label_width("trace: module", list(report.per_module), 30)
        lines += ["", f"{'trace: module':<{w}} {'compared':>9} {'agree %':>9}"]
        for module, (compared, agreed) in sorted(report.per_module.items()):
            lines.append(f"{module:<{w}} {compared:>9} {_pct(100.0 * agreed / compared if compared else None):>9}")
    found = [f for f in (_failure(r) for r in report.results) if f]
    if found and failures:
        lines += ["", f"first problems ({min(failures, len(found))} of {len(found)}):"]
        lines += [f"  {f}" for f in found[:failures]]
    return "\n".join(lines)
