"""Running checked programs (:mod:`craft_dsl.ir` nodes) over a simulation: the one evaluation path.

Every way a program is run goes through this module: :meth:`Program.run <craft_dsl.program.Program.run>` and
:meth:`~craft_dsl.program.Program.values` through a :class:`Plan`, and :func:`~craft_dsl.oracle.run_batch` (whose
batch node table holds the same raw nodes) through :func:`operation` and :func:`run_operations` directly.

Each node becomes an :data:`Operation`: its implementation from the registry and its call's shape (a literal, or
a module with no input, one input with or without one side value, two inputs, or any other arity), so that the
common calls are made with their arguments written out. Shared sub-expressions are one node, so they are evaluated
once per run; only what the answer needs is run, so an unused binding costs nothing and no counterfactual is
simulated unless asked for. INVALID propagates: a module that receives INVALID returns INVALID without being called.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, MutableMapping, Sequence
from dataclasses import dataclass
from typing import Any

from .errors import CounterfactualUnavailable, EvaluationError
from .ir import RawNode
from .registry import IMPLS, MAY_INVALIDATE, REGISTRY
from .simulation import Simulation
from .types import INVALID, DslType

#: A plan run this many times is compiled into one Python function (see :meth:`Plan.compile`).
COMPILE_AFTER_RUNS = 16

#: The shapes of a node's call (the first item of its :data:`Operation`).
LITERAL, NO_INPUT, ONE, ONE_SIDE, TWO, OTHER = range(6)
#: One node, ready to run: (shape, implementation, first input, second input, value), where the value is a
#: literal's value, the side value of a ONE_SIDE call, the side values of a NO_INPUT call, and ``(inputs, side
#: values)`` of an OTHER call.
Operation = tuple[int, Any, int, int, Any]
#: The operation a plan holds for a node its answer does not need (never run).
_NOT_NEEDED: Operation = (LITERAL, None, 0, 0, None)
#: Node values by node index: a list (one program) or a dict (a batch's large node table, few nodes needed).
Slots = MutableMapping[int, Any] | list[Any]


def operation(node: RawNode) -> Operation:
    """The operation that computes ``node``'s value from its inputs' slots."""
    module, inputs, values = node[0], node[1], node[2]
    if module is None:
        return (LITERAL, None, 0, 0, values[0])
    impl = IMPLS[module]
    n = len(inputs)
    if n == 1:
        if not values:
            return (ONE, impl, inputs[0], 0, None)
        if len(values) == 1:
            return (ONE_SIDE, impl, inputs[0], 0, values[0])
    elif n == 0:
        return (NO_INPUT, impl, 0, 0, values)
    elif n == 2 and not values:
        return (TWO, impl, inputs[0], inputs[1], None)
    return (OTHER, impl, 0, 0, (inputs, values))


def run_operations(ops: Sequence[Operation], order: Iterable[int], sim: Simulation, slots: Slots,
                   failure_is_invalid: bool = False) -> None:
    """Compute the nodes ``order`` (indices into ``ops``, each after its inputs) into ``slots``. A node with an
    INVALID input is INVALID without being called. A module that raises :class:`CounterfactualUnavailable` or
    :class:`EvaluationError` (a counterfactual the simulation cannot give, a state index out of range) raises
    here, or, with ``failure_is_invalid``, makes its node INVALID (a batch: the other programs run on)."""
    invalid = INVALID
    for g in order:
        shape, impl, a, b, v = ops[g]
        try:
            if shape == ONE:
                x = slots[a]
                slots[g] = invalid if x is invalid else impl(sim, x)
            elif shape == ONE_SIDE:
                x = slots[a]
                slots[g] = invalid if x is invalid else impl(sim, x, v)
            elif shape == LITERAL:
                slots[g] = v
            elif shape == TWO:
                x, y = slots[a], slots[b]
                slots[g] = invalid if x is invalid or y is invalid else impl(sim, x, y)
            elif shape == NO_INPUT:
                slots[g] = impl(sim, *v) if v else impl(sim)
            else:
                inputs, values = v
                args = [slots[j] for j in inputs]
                slots[g] = invalid if any(x is invalid for x in args) else impl(sim, *args, *values)
        except (CounterfactualUnavailable, EvaluationError):
            if not failure_is_invalid:
                raise
            slots[g] = invalid


def needed_nodes(nodes: Sequence[RawNode], root: int) -> list[int]:
    """The nodes ``root`` needs, itself included, in node order (an input comes before the node using it)."""
    flags = [False] * (root + 1)
    flags[root] = True
    for i in range(root, -1, -1):
        if flags[i]:
            for j in nodes[i][1]:
                flags[j] = True
    return [i for i, flag in enumerate(flags) if flag]


@dataclass(frozen=True)
class TraceEntry:
    """The value of one node of a program run (``slot`` is the node's index in the checked program)."""

    slot: int
    expression: str
    type: DslType
    value: Any


class Plan:
    """A program ready to run: the operations of the nodes its answer needs, in dependency order.

    Built from checked nodes in any dependency order and the answer's node ``root``; nodes the answer does not
    need are skipped. A program scored once must be cheap and a program run often must be fast: runs go through
    :func:`run_operations`, and from :data:`COMPILE_AFTER_RUNS` runs on the plan is one generated Python function
    of the same calls (no per-node dispatch, and inputs tested for INVALID only where INVALID can arrive).
    """

    __slots__ = ("nodes", "root", "result_type", "runs", "order", "ops", "_fast")

    def __init__(self, nodes: Sequence[RawNode], root: int | None = None) -> None:
        self.nodes = nodes
        self.root = len(nodes) - 1 if root is None else root
        self.result_type = nodes[self.root][3]
        self.runs = 0
        #: Built on the first run: the needed nodes in order, and each node's operation (where not needed, one
        #: that is never run).
        self.order: list[int] | None = None
        self.ops: list[Operation] = []
        self._fast: Callable[[Simulation], Any] | None = None

    def _prepare(self) -> list[int]:
        nodes = self.nodes
        order = needed_nodes(nodes, self.root)
        ops: list[Operation] = [_NOT_NEEDED] * len(nodes)
        make = operation
        for i in order:
            ops[i] = make(nodes[i])
        self.ops = ops
        self.order = order
        return order

    def run(self, sim: Simulation) -> Any:
        if self._fast is not None:
            return self._fast(sim)
        self.runs += 1
        if self.runs >= COMPILE_AFTER_RUNS:
            self._fast = self.compile()
            return self._fast(sim)
        return self.values(sim)[self.root]

    def values(self, sim: Simulation) -> list[Any]:
        """The value of every node (None for nodes the answer does not need), in node order; nodes with an
        INVALID input are INVALID."""
        order = self.order if self.order is not None else self._prepare()
        slots: list[Any] = [None] * len(self.nodes)
        run_operations(self.ops, order, sim, slots)
        return slots

    def compile(self) -> Callable[[Simulation], Any]:
        """The program as one Python function (no per-node dispatch); costs about as much as a few hundred
        runs of the plan, so :meth:`run` switches to it only for programs run often."""
        nodes = self.nodes
        order = self.order if self.order is not None else self._prepare()
        may_invalid = [False] * len(nodes)
        names: dict[str, Any] = {"INVALID": INVALID}
        lines = ["def run(sim):"]
        for i in order:
            module, inputs, values = nodes[i][:3]
            if module is None:
                names[f"c{i}"] = values[0]
                continue
            check = [j for j in inputs if may_invalid[j]]
            may_invalid[i] = bool(check) or module in MAY_INVALIDATE
            names[f"f{i}"] = REGISTRY[module].impl
            args = ["sim", *(f"c{j}" if nodes[j][0] is None else f"s{j}" for j in inputs)]
            for k, value in enumerate(values):
                names[f"v{i}_{k}"] = value
                args.append(f"v{i}_{k}")
            call = f"f{i}({', '.join(args)})"
            if check:
                invalid = " or ".join(f"s{j} is INVALID" for j in check)
                lines.append(f"    s{i} = INVALID if {invalid} else {call}")
            else:
                lines.append(f"    s{i} = {call}")
        lines.append(f"    return s{self.root}" if nodes[self.root][0] else f"    return c{self.root}")
        namespace: dict[str, Any] = {}
        exec(compile("\n".join(lines), "<craft_dsl plan>", "exec"), names, namespace)
        fn: Callable[[Simulation], Any] = namespace["run"]
        return fn
