"""CLEVR/CRAFT node lists <-> syntax trees.

A node list is a JSON list; node k has ``type`` (module name), ``inputs`` (indexes of earlier nodes)
and ``side_inputs`` or ``value_inputs`` (literal values, or template placeholders such as ``<Z>``).
The last node is the answer. Nodes the answer does not depend on (the templates' unused
``start_scene`` node 0) are dropped. Export writes the original names and argument order.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from .checker import resolve_module
from .errors import NodeListError, ProgramError
from .registry import REGISTRY
from .syntax import Call, Expr, Literal, Ref, Tree, format_expr
from .types import DslType


def _side_values(node: Mapping[str, Any], k: int, params: Mapping[str, str]) -> list[str | int]:
    raw = node.get("side_inputs")
    if raw is None:
        raw = node.get("value_inputs", [])
    if not isinstance(raw, list):
        raise NodeListError(f"node {k}: side_inputs/value_inputs must be a list, found {type(raw).__name__}")
    values: list[str | int] = []
    for v in raw:
        if isinstance(v, str) and v.startswith("<") and v.endswith(">"):
            if v not in params:
                raise NodeListError(
                    f"node {k} ({node.get('type')}): placeholder {v} is not bound; pass params={{{v!r}: ...}}"
                    f" (bound: {', '.join(params) or 'none'})"
                )
            v = params[v]
        if not isinstance(v, (str, int)) or isinstance(v, bool):
            raise NodeListError(f"node {k}: side input {v!r} must be a string")
        values.append(v)
    return values


def tree_from_nodes(nodes: Sequence[Mapping[str, Any]], params: Mapping[str, str] | None = None) -> Tree:
    """Build the syntax tree of a node list (names and orders mapped to the canonical ones)."""
    params = dict(params or {})
    if not isinstance(nodes, Sequence) or isinstance(nodes, (str, bytes)) or not nodes:
        raise NodeListError("a node list must be a non-empty list of nodes")
    built: list[Expr] = []
    for k, node in enumerate(nodes):
        if not isinstance(node, Mapping) or "type" not in node:
            raise NodeListError(f"node {k}: must be an object with a 'type' field, found {node!r}")
        name = node["type"]
        if not isinstance(name, str):
            raise NodeListError(f"node {k}: 'type' must be a string, found {name!r}")
        try:
            spec = resolve_module(name, None)
        except ProgramError as err:
            raise NodeListError(f"node {k}: {err.message}") from None
        inputs = node.get("inputs", [])
        if not isinstance(inputs, list) or not all(isinstance(i, int) and not isinstance(i, bool) for i in inputs):
            raise NodeListError(f"node {k} ({name}): 'inputs' must be a list of node indexes, found {inputs!r}")
        for i in inputs:
            if not 0 <= i < k:
                raise NodeListError(
                    f"node {k} ({name}): input {i} does not name an earlier node (allowed 0..{k - 1})"
                )
        n_inputs = len(spec.overloads[0].inputs)
        if len(inputs) != n_inputs:
            raise NodeListError(
                f"node {k} ({name}): {spec.name} takes {n_inputs} input node(s), found {len(inputs)}"
            )
        args = [built[i] for i in inputs]
        if spec.original_order is not None and name != spec.name:
            reordered: list[Expr] = [args[0]] * n_inputs
            for original_pos, ours in enumerate(spec.original_order):
                reordered[ours] = args[original_pos]
            args = reordered
        sides = [Literal(v) for v in _side_values(node, k, params)]
        built.append(Call(name, tuple(args) + tuple(sides)))
    return Tree((), built[-1])


def nodes_from_tree(tree: Tree) -> list[dict[str, Any]]:
    """Node list of a checked tree; each node also has ``_text`` (its expression) for the caller."""
    bindings = {b.name: b.expr for b in tree.bindings}
    nodes: list[dict[str, Any]] = []
    memo: dict[Expr, int] = {}

    def inline(expr: Expr) -> Expr:
        if isinstance(expr, Ref):
            return inline(bindings[expr.name])
        if isinstance(expr, Call):
            return Call(expr.module, tuple(inline(a) for a in expr.args))
        return Literal(expr.value)

    def emit(expr: Expr) -> int:
        assert isinstance(expr, Call)
        if expr in memo:
            return memo[expr]
        spec = REGISTRY[expr.module]
        n_inputs = len(spec.overloads[0].inputs)
        arg_types = []
        inputs = []
        for a in expr.args[:n_inputs]:
            if isinstance(a, Literal):
                raise NodeListError(
                    f"{spec.name}: the literal {format_expr(a)} has no node-list form; the original format "
                    "only allows literal colours, shapes and sizes"
                )
            inputs.append(emit(a))
            arg_types.append(nodes[inputs[-1]]["_type"])
        overload = next(ov for ov in spec.overloads if list(ov.inputs) == arg_types)
        if overload.original is None:
            raise NodeListError(f"{spec.name} has no equivalent in the original engine")
        if spec.original_order is not None:
            inputs = [inputs[i] for i in spec.original_order]
        sides = [a.value for a in expr.args[n_inputs:] if isinstance(a, Literal)]
        nodes.append({
            "type": overload.original,
            "inputs": inputs,
            "value_inputs": sides,
            "_type": overload.output,
            "_text": format_expr(expr),
        })
        memo[expr] = len(nodes) - 1
        return memo[expr]

    body = inline(tree.body)
    if not isinstance(body, Call):
        raise NodeListError("a program whose answer is a literal has no node-list form")
    emit(body)
    for node in nodes:
        t = node.pop("_type")
        assert isinstance(t, DslType)
    return nodes
