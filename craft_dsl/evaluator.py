"""Compiling a checked program into a flat plan and running it over a simulation.

Shared sub-expressions (a ``Var`` used twice, or the same call written twice) compile to one slot and
are evaluated once per run. Only what the final expression needs is evaluated (an unused binding costs
nothing, and no counterfactual is simulated unless asked for). INVALID propagates: a module that
receives INVALID returns INVALID without being called.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .registry import REGISTRY, Impl
from .simulation import Simulation
from .syntax import Call, Expr, Literal, Ref, Tree, format_expr
from .types import INVALID, DslType

#: Modules that may return INVALID on valid input.
_MAY_INVALIDATE = frozenset({"Unique", "FilterFirst", "FilterLast", "EventPartner"})


@dataclass(frozen=True)
class Step:
    """One instruction: ``slots[out] = impl(sim, *slots[inputs])``."""

    impl: Impl
    inputs: tuple[int, ...]
    out: int
    check_invalid: bool


@dataclass(frozen=True)
class TraceEntry:
    """The value of one node of a program run."""

    slot: int
    expression: str
    type: DslType
    value: Any


class Plan:
    """A compiled program: constant slots, then instructions in dependency order."""

    def __init__(self, tree: Tree, types: dict[Expr, DslType]) -> None:
        self.constants: list[Any] = []
        self.steps: list[Step] = []
        self.texts: list[str] = []
        self.slot_types: list[DslType | None] = []
        self._memo: dict[tuple[Any, ...], int] = {}
        self._may_invalid: set[int] = set()
        self._bindings = {b.name: b.expr for b in tree.bindings}
        self._types = types
        self.result = self._emit(tree.body)
        self.result_type = self.slot_types[self.result]

    def _new_slot(self, text: str, typ: DslType | None, value: Any = None) -> int:
        self.constants.append(value)
        self.texts.append(text)
        self.slot_types.append(typ)
        return len(self.constants) - 1

    def _emit(self, expr: Expr) -> int:
        if isinstance(expr, Ref):
            return self._emit(self._bindings[expr.name])
        if isinstance(expr, Literal):
            key: tuple[Any, ...] = ("literal", expr.value)
            if key not in self._memo:
                typ = DslType.INTEGER if isinstance(expr.value, int) else None
                self._memo[key] = self._new_slot(format_expr(expr), typ, expr.value)
            return self._memo[key]
        assert isinstance(expr, Call)
        inputs = tuple(self._emit(a) for a in expr.args)
        key = ("call", expr.module, inputs)
        if key in self._memo:
            return self._memo[key]
        text = f"{expr.module}({', '.join(self.texts[i] for i in inputs)})"
        out = self._new_slot(text, self._types.get(expr))
        check = any(i in self._may_invalid for i in inputs)
        if check or expr.module in _MAY_INVALIDATE:
            self._may_invalid.add(out)
        self.steps.append(Step(REGISTRY[expr.module].impl, inputs, out, check))
        self._memo[key] = out
        return out

    def run(self, sim: Simulation) -> Any:
        slots = list(self.constants)
        for step in self.steps:
            if step.check_invalid:
                args = [slots[i] for i in step.inputs]
                if any(a is INVALID for a in args):
                    slots[step.out] = INVALID
                    continue
                slots[step.out] = step.impl(sim, *args)
            else:
                slots[step.out] = step.impl(sim, *[slots[i] for i in step.inputs])
        return slots[self.result]

    def trace(self, sim: Simulation) -> list[TraceEntry]:
        slots = list(self.constants)
        entries = []
        for step in self.steps:
            args = [slots[i] for i in step.inputs]
            value = INVALID if any(a is INVALID for a in args) else step.impl(sim, *args)
            slots[step.out] = value
            typ = self.slot_types[step.out]
            assert typ is not None
            entries.append(TraceEntry(step.out, self.texts[step.out], typ, value))
        return entries
