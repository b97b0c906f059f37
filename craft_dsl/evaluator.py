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

from .ir import RawNode
from .registry import IMPLS, MAY_INVALIDATE, REGISTRY, Impl
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
    """A compiled program: constant slots, then one instruction per needed module node in dependency order.

    Built from checked nodes in any dependency order and the answer's node ``root``; nodes the answer does not
    need are skipped. A node that receives INVALID is INVALID without being called (so which nodes run does
    not depend on the order the nodes were written in); the inputs are tested only where INVALID can arrive.

    Execution is tiered, because a program scored once must be cheap and a program run often must be fast:
    the first run interprets the nodes, later runs use one specialised instruction per node, and from
    :data:`COMPILE_AFTER_RUNS` runs on the program is one generated Python function.
    """

    __slots__ = ("nodes", "root", "constants", "order", "steps", "result_type", "runs", "_fast")

    def __init__(self, nodes: Sequence[RawNode], root: int | None = None) -> None:
        self.nodes = nodes
        self.root = len(nodes) - 1 if root is None else root
        self.result_type = nodes[self.root][3]
        self.runs = 0
        self.steps: tuple[tuple[Thunk, int, tuple[int, ...]], ...] | None = None
        self._fast: Callable[[Simulation], Any] | None = None
        # Built on the second run (a program scored once never needs them): the constant slots, and the
        # needed module nodes in order, each with the inputs to test for INVALID.
        self.constants: list[Any] = []
        self.order: list[tuple[int, tuple[int, ...]]] | None = None

    def _needed(self) -> list[bool]:
        """Which nodes the answer depends on (the root and, transitively, its inputs)."""
        nodes, root = self.nodes, self.root
        needed = [False] * (root + 1)
        needed[root] = True
        for i in range(root, -1, -1):
            if needed[i]:
                for j in nodes[i][1]:
                    needed[j] = True
        return needed

    def _prepare(self) -> list[tuple[int, tuple[int, ...]]]:
        nodes = self.nodes
        needed = self._needed()
        constants: list[Any] = [None] * len(nodes)
        order: list[tuple[int, tuple[int, ...]]] = []
        may_invalid = [False] * len(nodes)
        for i, is_needed in enumerate(needed):
            if not is_needed:
                continue
            module, inputs, values = nodes[i][:3]
            if module is None:
                constants[i] = values[0]
                continue
            check: tuple[int, ...] = ()
            for j in inputs:
                if may_invalid[j]:
                    check += (j,)
            may_invalid[i] = bool(check) or module in MAY_INVALIDATE
            order.append((i, check))
        self.constants = constants
        self.order = order
        return order

    def run(self, sim: Simulation) -> Any:
        if self._fast is not None:
            return self._fast(sim)
        self.runs += 1
        if self.runs == 1:
            return self._interpret(sim)
        if self.runs >= COMPILE_AFTER_RUNS:
            self._fast = self.compile()
        steps = self.steps
        if steps is None:
            nodes = self.nodes
            order = self.order if self.order is not None else self._prepare()
            steps = self.steps = tuple([
                (_thunk(IMPLS[nodes[i][0]], nodes[i][1], nodes[i][2]), i, check)  # type: ignore[index]
                for i, check in order])
        slots = self.constants[:]
        for fn, out, check in steps:
            if check:
                for i in check:
                    if slots[i] is INVALID:
                        slots[out] = INVALID
                        break
                else:
                    slots[out] = fn(sim, slots)
            else:
                slots[out] = fn(sim, slots)
        return slots[self.root]

    def _interpret(self, sim: Simulation) -> Any:
        """One run straight from the nodes, without building instructions or constant slots (the cheapest way
        to run a program once). Every input is tested for INVALID, which gives the same answers as testing only
        the inputs that can be INVALID."""
        nodes, root = self.nodes, self.root
        # The needed nodes, found from the root down (as in _needed), collected so that the run visits only them.
        slots: list[Any] = [False] * (root + 1)
        slots[root] = True
        order: list[int] = []
        for i in range(root, -1, -1):
            if slots[i]:
                order.append(i)
                for j in nodes[i][1]:
                    slots[j] = True
        invalid = INVALID
        impls = IMPLS
        for i in reversed(order):  # slots[i] holds a flag until node i's value replaces it
            module, inputs, values, _type, _overload = nodes[i]
            if module is None:
                slots[i] = values[0]
                continue
            n = len(inputs)
            if n == 1:
                a = slots[inputs[0]]
                if a is invalid:
                    slots[i] = invalid
                elif values:
                    slots[i] = impls[module](sim, a, *values)
                else:
                    slots[i] = impls[module](sim, a)
            elif n == 2:
                a, b = slots[inputs[0]], slots[inputs[1]]
                slots[i] = invalid if a is invalid or b is invalid else impls[module](sim, a, b, *values)
            elif n == 0:
                slots[i] = impls[module](sim, *values) if values else impls[module](sim)
            else:
                args = [slots[j] for j in inputs]
                for a in args:
                    if a is invalid:
                        slots[i] = invalid
                        break
                else:
                    slots[i] = impls[module](sim, *args, *values)
        return slots[root]

    def compile(self) -> Callable[[Simulation], Any]:
        """The program as one Python function (no per-node dispatch); costs about as much as a few hundred
        runs of the plan, so :meth:`run` switches to it only for programs run often."""
        names: dict[str, Any] = {"INVALID": INVALID}
        lines = ["def run(sim):"]
        order = self.order if self.order is not None else self._prepare()
        for i, check in order:
            module, inputs, values = self.nodes[i][:3]
            spec = REGISTRY[module]  # type: ignore[index]
            names[f"f{i}"] = spec.impl
            args = ["sim", *(f"c{j}" if self.nodes[j][0] is None else f"s{j}" for j in inputs)]
            names.update({f"c{j}": self.nodes[j][2][0] for j in inputs if self.nodes[j][0] is None})
            for k, value in enumerate(values):
                names[f"v{i}_{k}"] = value
                args.append(f"v{i}_{k}")
            call = f"f{i}({', '.join(args)})"
            if check:
                invalid = " or ".join(f"s{j} is INVALID" for j in check)
                lines.append(f"    s{i} = INVALID if {invalid} else {call}")
            else:
                lines.append(f"    s{i} = {call}")
        lines.append(f"    return s{self.root}" if self.nodes[self.root][0] else f"    return c{self.root}")
        names[f"c{self.root}"] = self.constants[self.root]
        namespace: dict[str, Any] = {}
        exec(compile("\n".join(lines), "<craft_dsl plan>", "exec"), names, namespace)
        fn: Callable[[Simulation], Any] = namespace["run"]
        return fn

    def values(self, sim: Simulation) -> list[Any]:
        """The value of every node (None for nodes the answer does not need), in node order; nodes with an
        INVALID input are INVALID."""
        order = self.order if self.order is not None else self._prepare()
        slots = self.constants[:]
        for out, _check in order:
            module, inputs, values = self.nodes[out][:3]
            slots[out] = INVALID if any(slots[i] is INVALID for i in inputs) else \
                IMPLS[module](sim, *[slots[i] for i in inputs], *values)  # type: ignore[index]
        return slots
