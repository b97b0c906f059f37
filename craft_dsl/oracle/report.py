"""The plain-text form of an :class:`~craft_dsl.oracle.evaluate.EvaluationReport`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..templates import templates
from ..verify.categories import category_of
from ..verify.scoring import label_width

if TYPE_CHECKING:
    from .evaluate import EvaluationReport, Metrics, QuestionResult

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
