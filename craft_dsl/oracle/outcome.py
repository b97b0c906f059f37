"""What happens to one predicted program: exactly one outcome out of four.

* ``syntax_error``: the program is not well formed: text that does not parse, an unknown module, variable
  or token, a malformed node list, too few or too many tokens. ``location`` says where (``line 2, column 7``,
  ``token 4``, ``node 3``).
* ``type_error``: well formed but ill typed: an argument of the wrong type or number, a colour/shape/size
  outside the vocabulary, or a program whose result is not an answer (an ObjectSet, say). ``module``,
  ``argument``, ``expected`` and ``found`` say which.
* ``invalid``: it type-checks, but its value on the true simulation is INVALID (``Unique`` of a set that does
  not hold exactly one object, ``FilterFirst`` of no event, ...) or it asks for something the simulation
  cannot give (the counterfactual of a static object); ``reason`` and ``node`` say which node and why.
* ``answer``: it gives an answer (a bool, an int, or a colour/shape/size word).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from ..errors import CounterfactualUnavailable, EvaluationError, ProgramError, SideInputError, TypeCheckError
from ..ir import node_texts
from ..program import Program, to_json
from ..simulation import Simulation
from ..types import INVALID, DslType
from .forms import ProgramCache, ProgramForm, read_program

OutcomeKind = Literal["syntax_error", "type_error", "invalid", "answer"]
OUTCOMES: tuple[str, ...] = ("syntax_error", "type_error", "invalid", "answer")
#: Result types of question programs.
ANSWER_TYPES = frozenset({DslType.BOOL, DslType.INTEGER, DslType.COLOR, DslType.SHAPE, DslType.SIZE})


@dataclass(frozen=True)
class ProgramOutcome:
    """The outcome of one predicted program (see the module docstring)."""

    kind: OutcomeKind
    form: ProgramForm
    #: The checked program (None for syntax and type errors).
    program: Program | None = field(default=None, compare=False, repr=False)
    #: The answer as the dataset writes answers (bool, int, lowercase str), for ``kind == "answer"``.
    answer: Any = None
    #: The error message (syntax and type errors) or why the value is INVALID.
    message: str | None = None
    location: str | None = None
    #: Type errors: the module, argument (1-based), allowed types and found type.
    module: str | None = None
    argument: int | None = None
    expected: tuple[str, ...] | None = None
    found: str | None = None
    #: ``invalid``: the expression of the node that first became INVALID (None if a simulation lookup failed).
    node: str | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"outcome": self.kind, "form": self.form}
        if self.program is not None:
            out["program"] = str(self.program)
        for name in ("answer", "message", "location", "module", "argument", "expected", "found", "node"):
            value = getattr(self, name)
            if value is not None:
                out[name] = list(value) if isinstance(value, tuple) else value
        return out


def check_outcome(program: Any, form: ProgramForm | None = None,
                  cache: ProgramCache | None = None) -> tuple[ProgramOutcome | None, Program | None]:
    """Read and check a predicted program: ``(None, program)`` when it is a well-typed question program,
    ``(outcome, None)`` with a syntax or type error otherwise."""
    from .forms import detect_form

    form = form or detect_form(program)
    try:
        checked = cache.get(program, form) if cache is not None else read_program(program, form)
    except (TypeCheckError, SideInputError) as err:
        return _error("type_error", form, err), None
    except ProgramError as err:
        return _error("syntax_error", form, err), None
    if checked.type not in ANSWER_TYPES:
        allowed = ", ".join(sorted(str(t) for t in ANSWER_TYPES))
        return ProgramOutcome(
            "type_error", form, message=f"the program returns {checked.type}; a question's answer is one of "
            f"{allowed}", expected=tuple(sorted(str(t) for t in ANSWER_TYPES)), found=str(checked.type),
        ), None
    return None, checked


def _error(kind: OutcomeKind, form: ProgramForm, err: ProgramError) -> ProgramOutcome:
    expected = getattr(err, "expected", None)
    return ProgramOutcome(kind, form, message=err.message, location=err.location,
                          module=getattr(err, "module", None), argument=getattr(err, "argument", None),
                          expected=tuple(expected) if expected else None, found=getattr(err, "found", None))


def run_outcome(program: Program, sim: Simulation, form: ProgramForm) -> ProgramOutcome:
    """Run a checked question program on the true simulation: an ``answer`` or ``invalid`` outcome."""
    try:
        value = program.run(sim)
    except (CounterfactualUnavailable, EvaluationError) as err:
        return ProgramOutcome("invalid", form, program, message=str(err))
    if value is INVALID:
        node, reason = explain_invalid(program, sim)
        return ProgramOutcome("invalid", form, program, message=reason, node=node)
    return ProgramOutcome("answer", form, program, answer=to_json(value, original=True))


def program_outcome(program: Any, sim: Simulation, form: ProgramForm | None = None,
                    cache: ProgramCache | None = None) -> ProgramOutcome:
    """The outcome of a predicted program (any form) on the true simulation."""
    outcome, checked = check_outcome(program, form, cache)
    if outcome is not None:
        return outcome
    assert checked is not None
    from .forms import detect_form

    return run_outcome(checked, sim, form or detect_form(program))


def explain_invalid(program: Program, sim: Simulation) -> tuple[str | None, str]:
    """The node that first becomes INVALID (its inputs are valid) and why, e.g. ``Unique: the set holds 3
    objects``."""
    values = program.values(sim)
    nodes = program.nodes
    texts = node_texts(nodes)
    for i, node in enumerate(nodes):
        if values[i] is INVALID and all(values[j] is not INVALID for j in node.inputs):
            args = [values[j] for j in node.inputs]
            return texts[i], _reason(str(node.module), args)
    return None, "the program's value is INVALID"


def _reason(module: str, args: list[Any]) -> str:
    if module == "Unique":
        return f"Unique: the set holds {len(args[0])} objects, not exactly one"
    if module in ("FilterFirst", "FilterLast"):
        return f"{module}: the event set is empty"
    if module == "EventPartner":
        return f"EventPartner: object {args[1]} is not one of the two objects of the event"
    return f"{module} returned INVALID"
