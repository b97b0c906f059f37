"""Running checked programs (:mod:`craft_dsl.ir` nodes) over a simulation.

A :class:`Plan` is the node list turned into instructions: literal nodes become constant slots, module nodes
become ``slots[i] = impl(sim, *slots[inputs], *side_values)`` in node order. Shared sub-expressions are one
node, so they are evaluated once per run; only what the answer needs is a node at all, so an unused binding
costs nothing and no counterfactual is simulated unless asked for. INVALID propagates: a module that
receives INVALID returns INVALID without being called. Whether a module can produce INVALID is read from its
registry entry, and the check is made only where INVALID can arrive.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from .ir import Node, node_texts
from .registry import REGISTRY, Impl
from .simulation import Simulation
from .types import INVALID, DslType

#: A plan run this many times is compiled into one Python function (see :meth:`Plan.compile`).
COMPILE_AFTER_RUNS = 16
#: One instruction: ``fn(sim, slots)`` computes a node's value from the slots of its inputs.
Thunk = Callable[[Simulation, list[Any]], Any]


def _thunk(impl: Impl, inputs: tuple[int, ...], values: tuple[Any, ...]) -> Thunk:
    """The instruction of one node, specialised by its number of inputs and side inputs (a call with the
    arguments written out is several times cheaper than one that builds and unpacks an argument list)."""
    if not values:
        if not inputs:
            return lambda sim, s: impl(sim)
        if len(inputs) == 1:
            (a,) = inputs
            return lambda sim, s: impl(sim, s[a])
        if len(inputs) == 2:
            a, b = inputs
            return lambda sim, s: impl(sim, s[a], s[b])
    elif len(inputs) == 1 and len(values) == 1:
        (a,), (v,) = inputs, values
        return lambda sim, s: impl(sim, s[a], v)
    return lambda sim, s: impl(sim, *[s[i] for i in inputs], *values)


@dataclass(frozen=True)
class TraceEntry:
    """The value of one node of a program run (``slot`` is the node's index in the checked program)."""

    slot: int
    expression: str
    type: DslType
    value: Any


class Plan:
    """A compiled program: constant slots, then one instruction per module node in dependency order.

    Every node of a checked program is needed by the answer, and every module returns INVALID when it receives
    INVALID, so the answer is INVALID as soon as any node is: :meth:`run` stops there.
    """

    __slots__ = ("nodes", "constants", "steps", "result_type", "runs", "_fast")

    def __init__(self, nodes: Sequence[Node]) -> None:
        self.nodes = nodes
        constants: list[Any] = [None] * len(nodes)
        steps: list[tuple[Thunk, int, bool]] = []
        for i, node in enumerate(nodes):
            if node.module is None:
                constants[i] = node.values[0]
                continue
            spec = REGISTRY[node.module]
            steps.append((_thunk(spec.impl, node.inputs, node.values), i, spec.may_invalidate))
        self.constants = constants
        self.steps = tuple(steps)
        self.result_type = nodes[-1].type
        self.runs = 0
        self._fast: Callable[[Simulation], Any] | None = None

    def run(self, sim: Simulation) -> Any:
        if self._fast is not None:
            return self._fast(sim)
        self.runs += 1
        if self.runs >= COMPILE_AFTER_RUNS:
            self._fast = self.compile()
        slots = self.constants[:]
        value = None
        for fn, out, may_invalidate in self.steps:
            value = fn(sim, slots)
            if may_invalidate and value is INVALID:
                return INVALID
            slots[out] = value
        return value

    def compile(self) -> Callable[[Simulation], Any]:
        """The program as one Python function (no per-node dispatch); costs about as much as a few hundred
        runs of the plan, so :meth:`run` switches to it only for programs run often."""
        names: dict[str, Any] = {"INVALID": INVALID}
        lines = ["def run(sim):"]
        for i, node in enumerate(self.nodes):
            if node.module is None:
                names[f"c{i}"] = node.values[0]
                continue
            spec = REGISTRY[node.module]
            names[f"f{i}"] = spec.impl
            args = ["sim", *(f"c{j}" if self.nodes[j].module is None else f"s{j}" for j in node.inputs)]
            for k, value in enumerate(node.values):
                names[f"v{i}_{k}"] = value
                args.append(f"v{i}_{k}")
            lines.append(f"    s{i} = f{i}({', '.join(args)})")
            if spec.may_invalidate:
                lines.append(f"    if s{i} is INVALID: return INVALID")
        lines.append(f"    return s{len(self.nodes) - 1}")
        namespace: dict[str, Any] = {}
        exec(compile("\n".join(lines), "<craft_dsl plan>", "exec"), names, namespace)
        fn: Callable[[Simulation], Any] = namespace["run"]
        return fn

    def values(self, sim: Simulation) -> list[Any]:
        """The value of every node (literals included), in node order; nodes after an INVALID input are INVALID."""
        slots = self.constants[:]
        for fn, out, _may in self.steps:
            node = self.nodes[out]
            slots[out] = INVALID if any(slots[i] is INVALID for i in node.inputs) else fn(sim, slots)
        return slots

    def trace(self, sim: Simulation) -> list[TraceEntry]:
        values = self.values(sim)
        texts = node_texts(self.nodes)
        return [TraceEntry(i, texts[i], node.type, values[i])
                for i, node in enumerate(self.nodes) if node.module is not None]
