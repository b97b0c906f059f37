"""CLEVR/CRAFT node lists <-> checked programs.

A node list is a JSON list; node k has ``type`` (module name), ``inputs`` (indexes of earlier nodes)
and ``side_inputs`` or ``value_inputs`` (literal values, or template placeholders such as ``<Z>``).
The last node is the answer. Nodes the answer does not depend on (the templates' unused
``start_scene`` node 0) are dropped. Export writes the original names and argument order.
Errors name the node (``node 3``) as well as what is wrong.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, NoReturn

from .checker import _RESOLUTIONS, _VALUES, CheckedProgram, ProgramBuilder, arity_error, resolve_module
from .errors import NodeListError, ProgramError
from .files import describe
from .ir import Node, RawNode, node_texts
from .registry import NAMES, REGISTRY, ModuleSpec
from .types import DslType

_EMPTY: tuple[()] = ()


def _side_values(node: Mapping[str, Any], k: int, params: Mapping[str, str] | None) -> list[Any]:
    raw = node.get("side_inputs")
    if raw is None:
        raw = node.get("value_inputs", _EMPTY)
    if not isinstance(raw, (list, tuple)):
        raise NodeListError(f"side_inputs/value_inputs must be a list, found {type(raw).__name__}",
                            location=f"node {k}", index=k)
    values: list[Any] = []
    for v in raw:
        if isinstance(v, str) and v.startswith("<") and v.endswith(">"):
            if params is None or v not in params:
                bound = ", ".join(params or ()) or "none"
                raise NodeListError(
                    f"{node.get('type')}: placeholder {v} is not bound; pass params={{{v!r}: ...}} (bound: {bound})",
                    location=f"node {k}", index=k,
                )
            v = params[v]
        if not isinstance(v, (str, int)) or isinstance(v, bool):
            raise NodeListError(f"side input {describe(v)} must be a string", location=f"node {k}", index=k)
        values.append(v)
    return values


def check_nodes(nodes: Sequence[Mapping[str, Any]], params: Mapping[str, str] | None = None) -> CheckedProgram:
    """Check a node list (original or canonical names and orders) into canonical nodes."""
    if type(nodes) is list and nodes:  # (a list passes the test below; an ABC isinstance costs ~0.5 us)
        checked = _check_common(nodes)
        if checked is not None:
            return checked
    elif not isinstance(nodes, Sequence) or isinstance(nodes, (str, bytes)) or not nodes:
        raise NodeListError("a node list must be a non-empty list of nodes")
    return _check_general(nodes, params)


def _check_general(nodes: Sequence[Mapping[str, Any]], params: Mapping[str, str] | None) -> CheckedProgram:
    """Any node list, node by node through :class:`ProgramBuilder`; the source of every error."""
    builder = ProgramBuilder()
    call = builder.call
    shape_of = _SHAPES.get
    built: list[int] = []
    for k, node in enumerate(nodes):
        try:
            name = node["type"]
            inputs = node.get("inputs", _EMPTY)
            shape = shape_of(name)
        except (TypeError, KeyError, AttributeError):
            raise NodeListError(f"must be an object with a 'type' field, found {describe(node)}",
                                location=f"node {k}", index=k) from None
        if shape is None:
            _unknown_module(name, k)
        spec, n_inputs, reorder, n_sides = shape
        # The common shapes first (one valid input, or none); everything else, errors included, below.
        if n_inputs == 1 and type(inputs) is list and len(inputs) == 1 and type(i := inputs[0]) is int \
                and 0 <= i < k:
            args = [built[i]]
        elif n_inputs == 0 and type(inputs) is list and not inputs:
            args = []
        else:
            args = []
            try:
                for i in inputs:
                    if type(i) is not int or not 0 <= i < k:
                        _bad_inputs(name, inputs, k)
                    args.append(built[i])
            except TypeError:
                _bad_inputs(name, inputs, k)
            if len(args) != n_inputs:
                raise NodeListError(f"{name}: {spec.name} takes {n_inputs} input node(s), found {len(args)}",
                                    location=f"node {k}", index=k)
        if reorder is not None:
            args = [args[j] for j in reorder]
        if n_sides or len(node) > 2:
            sides = node.get("value_inputs") or node.get("side_inputs") or _EMPTY
            if sides or n_sides:
                if params is not None or type(sides) is not list or not _plain_values(sides):
                    sides = _side_values(node, k, params)
                if len(sides) != n_sides:
                    raise arity_error(spec, len(args) + len(sides), ("node", k))
        else:
            sides = _EMPTY
        built.append(call(spec, args, sides, ("node", k)))
    return builder.finish(built[-1], built)


def _check_common(nodes: list[Any]) -> CheckedProgram | None:
    """The common exact shape in one pass: every node a dict of ``type``, ``inputs`` (a list of valid indexes)
    and ``value_inputs`` or ``side_inputs`` (a list of vocabulary words), and ``_output`` at most, with input
    types whose overload is already resolved. None where anything else is met, for :func:`check_nodes`'s
    general reading, which gives the same program for such lists or the exact error."""
    common: Callable[[Any], _Common | None] = _COMMON.get  # any hashable "type" may be looked up
    resolutions = _RESOLUTIONS
    raw: list[RawNode] = []
    index: dict[RawNode, int] = {}
    built: list[int] = []
    for k, node in enumerate(nodes):
        if type(node) is not dict:
            return None
        size = len(node)
        if size != 3 and (size != 4 or "_output" not in node):
            return None
        try:
            entry = common(node.get("type"))  # a str subclass finds what the general reading's lookup finds
        except TypeError:  # an unhashable "type"
            return None
        if entry is None:
            return None
        inputs = node.get("inputs")
        sides = node.get("value_inputs")
        if sides is None:
            sides = node.get("side_inputs")
        if type(inputs) is not list or type(sides) is not list:
            return None
        module, n_inputs, swap, side_words = entry
        if len(inputs) != n_inputs:
            return None
        if n_inputs == 1:
            i = inputs[0]
            if type(i) is not int or not 0 <= i < k:
                return None
            args: tuple[int, ...] = (built[i],)
            res = resolutions.get((module, raw[args[0]][3]))
        elif n_inputs == 2:
            i, j = inputs
            if type(i) is not int or not 0 <= i < k or type(j) is not int or not 0 <= j < k:
                return None
            args = (built[j], built[i]) if swap else (built[i], built[j])
            res = resolutions.get((module, raw[args[0]][3], raw[args[1]][3]))
        else:
            args = ()
            res = resolutions.get((module,))
        if res is None:
            return None
        if side_words is None:
            if sides:
                return None
            values: tuple[str, ...] = ()
        else:
            if len(sides) != 1 or type(value := sides[0]) is not str:
                return None
            found = side_words.get(value)
            if found is None:
                return None
            values = (found,)
        overload, output, wrap = res
        if wrap:
            ids = list(args)
            for w in wrap:
                unique: RawNode = ("Unique", (ids[w],), (), _OBJECT, 0)
                ids[w] = found_id = index.setdefault(unique, len(raw))
                if found_id == len(raw):
                    raw.append(unique)
            args = tuple(ids)
        new: RawNode = (module, args, values, output, overload)
        found_id = index.setdefault(new, len(raw))  # one hash of the node, where get-then-set takes two
        if found_id == len(raw):
            raw.append(new)
        built.append(found_id)
    return CheckedProgram(raw, built[-1], None, {}, tuple(built))


def _plain_values(sides: list[Any]) -> bool:
    """Whether every side input is a string that is not a placeholder (what needs no further reading)."""
    for v in sides:  # a loop, not all(<generator>): this runs for every node with side inputs
        if type(v) is not str or v[:1] == "<":
            break
    else:
        return True
    return False


def _inverse(order: tuple[int, ...]) -> tuple[int, ...]:
    """Original positions -> ours: ``ours[order[p]] = original[p]``."""
    out = [0] * len(order)
    for original_pos, ours in enumerate(order):
        out[ours] = original_pos
    return tuple(out)


#: Per accepted module name: (spec, number of inputs, how to reorder the inputs of an original name or None,
#: number of side inputs); one lookup per node instead of several attribute reads.
_SHAPES: dict[str, tuple[ModuleSpec, int, tuple[int, ...] | None, int]] = {
    name: (spec, spec.n_inputs,
           _inverse(spec.original_order) if spec.original_order is not None and name != spec.name else None,
           len(spec.side_inputs))
    for name, spec in NAMES.items()
}


_OBJECT = DslType.OBJECT
_Common = tuple[str, int, bool, dict[str, str] | None]
#: Per accepted module name, for :func:`_check_common`: (canonical name, number of inputs, whether the two inputs
#: of an original name are swapped, the accepted spellings of its one side input or None where it has none).
#: Modules of other shapes (none today) are left to the general reading.
_COMMON: dict[str, _Common] = {
    name: (spec.name, n_inputs, reorder == (1, 0), _VALUES[spec.side_inputs[0]] if n_sides else None)
    for name, (spec, n_inputs, reorder, n_sides) in _SHAPES.items()
    if n_inputs <= 2 and n_sides <= 1 and reorder in (None, (0, 1), (1, 0))
}


def _unknown_module(name: Any, k: int) -> NoReturn:
    if not isinstance(name, str):
        raise NodeListError(f"'type' must be a string, found {describe(name)}", location=f"node {k}", index=k)
    try:
        resolve_module(name, ("node", k))
    except ProgramError as err:
        raise NodeListError(err.message, location=f"node {k}", index=k) from None
    raise AssertionError("resolve_module accepted an unknown name")  # pragma: no cover


def _bad_inputs(name: Any, inputs: Any, k: int) -> NoReturn:
    if not isinstance(inputs, (list, tuple)) or not all(type(i) is int for i in inputs):
        raise NodeListError(f"{name}: 'inputs' must be a list of node indexes, found {describe(inputs)}",
                            location=f"node {k}", index=k)
    bad = next(i for i in inputs if not 0 <= i < k)
    raise NodeListError(f"{name}: input {describe(bad)} does not name an earlier node (allowed 0..{k - 1})",
                        location=f"node {k}", index=k)


def nodes_from_checked(nodes: Sequence[Node]) -> list[dict[str, Any]]:
    """The node list of checked nodes (original names and argument order); each node also has ``_text``
    (its expression) and ``_node`` (its index in ``nodes``) for the caller."""
    out: list[dict[str, Any]] = []
    position: dict[int, int] = {}
    texts = node_texts(nodes)
    for i, node in enumerate(nodes):
        if node.module is None:
            continue
        spec = REGISTRY[node.module]
        for j in node.inputs:
            if nodes[j].module is None:
                raise NodeListError(
                    f"{spec.name}: the literal {texts[j]} has no node-list form; the original format only "
                    "allows literal colours, shapes and sizes as side inputs"
                )
        overload = spec.overloads[node.overload]
        if overload.original is None:
            raise NodeListError(f"{spec.name} has no equivalent in the original engine")
        inputs = [position[j] for j in node.inputs]
        if spec.original_order is not None:
            inputs = [inputs[j] for j in spec.original_order]
        position[i] = len(out)
        out.append({"type": overload.original, "inputs": inputs, "value_inputs": list(node.values),
                    "_text": texts[i], "_node": i})
    if not out or nodes[-1].module is None:
        raise NodeListError("a program whose answer is a literal has no node-list form")
    return out
