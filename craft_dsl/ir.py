"""The checked form of a program: a flat, hash-consed list of typed nodes.

Every way of writing a program (text, node list, token sequence) is checked into the same representation:
a tuple of :class:`Node` in dependency order, the last node being the answer. A node is either a module call
(canonical name, the indexes of its input nodes, its side-input values) or a literal (an integer, or a
colour/shape/size written where a value of that type is expected). Equal sub-expressions are one node.

The numbering is canonical: nodes are numbered in the post-order of the inlined expression (inputs left to
right, each node at its first completion), and only nodes the answer depends on are kept. Two programs that
mean the same expression (whatever their ``Var`` bindings, node order or form) have equal node tuples, which
is what :attr:`craft_dsl.Program.key` compares.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from .syntax import Call, Expr, Literal
from .types import DslType

Value = str | int


class Node(NamedTuple):
    """One node: a call of ``module`` (canonical name) or, when ``module`` is None, a literal ``values[0]``."""

    module: str | None
    inputs: tuple[int, ...]
    values: tuple[Value, ...]
    type: DslType
    #: Index of the resolved overload in the module's registry entry (0 for literals).
    overload: int = 0


#: A node as the checker builds it: a plain tuple with :class:`Node`'s fields (a NamedTuple instance costs several
#: times more to create, and a fresh program builds one per call); :func:`canonical_order` makes ``Node`` values.
RawNode = tuple[str | None, tuple[int, ...], tuple[Value, ...], DslType, int]


def canonical_order(nodes: Sequence[RawNode], root: int) -> tuple[tuple[Node, ...], list[int]]:
    """Renumber ``nodes`` (any dependency order, possibly with unused nodes) canonically from ``root``.

    Returns the canonical node tuple and ``new_index`` (old index -> new index, -1 for dropped nodes).
    Iterative, so programs of any depth are fine; nodes already in canonical order are returned as they are.
    """
    new_index = [-1] * len(nodes)
    order: list[int] = []
    stack = [root]
    while stack:
        i = stack[-1]
        if new_index[i] >= 0:
            stack.pop()
            continue
        for child in nodes[i][1]:
            if new_index[child] < 0:
                # Children are visited left to right: push them reversed, revisit the parent afterwards.
                stack.extend(reversed([c for c in nodes[i][1] if new_index[c] < 0]))
                break
        else:
            stack.pop()
            new_index[i] = len(order)
            order.append(i)
    if len(order) == len(nodes) and order[-1] == len(nodes) - 1 and all(
            i == k for k, i in enumerate(order)):
        return tuple([Node._make(node) for node in nodes]), new_index
    out = []
    for i in order:
        module, inputs, values, typ, overload = nodes[i]
        out.append(Node(module, tuple([new_index[j] for j in inputs]) if inputs else inputs, values, typ, overload))
    return tuple(out), new_index


def literal_text(value: Value) -> str:
    return f'"{value}"' if isinstance(value, str) else str(value)


def node_texts(nodes: Sequence[Node]) -> list[str]:
    """The canonical one-line text of every node's (inlined) expression."""
    texts: list[str] = []
    for node in nodes:
        if node.module is None:
            texts.append(literal_text(node.values[0]))
        else:
            args = [texts[i] for i in node.inputs] + [literal_text(v) for v in node.values]
            texts.append(f"{node.module}({', '.join(args)})")
    return texts


def to_exprs(nodes: Sequence[Node]) -> list[Expr]:
    """The syntax expression of every node (shared nodes share one object)."""
    exprs: list[Expr] = []
    for node in nodes:
        if node.module is None:
            exprs.append(Literal(node.values[0]))
        else:
            args: tuple[Expr, ...] = tuple(exprs[i] for i in node.inputs) + tuple(Literal(v) for v in node.values)
            exprs.append(Call(node.module, args))
    return exprs
