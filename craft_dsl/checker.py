"""Static checking: resolve module names and overloads, validate side inputs, insert Unique.

Every program form is checked by one :class:`ProgramBuilder`, call by call: it resolves the module and the
overload that fits the input types, inserts an explicit ``Unique`` wherever an object set stands where one
Object is expected (the paper's convention), canonicalises side-input values, and hash-conses the result
into the nodes of :mod:`craft_dsl.ir`. :func:`check_tree` walks a syntax tree (the text form) through it,
iteratively, so programs of any depth check. Errors name the module, the argument, the expected and found
type, and where the problem is.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from .errors import ProgramError, SideInputError, TypeCheckError, UnknownModuleError
from .ir import Node, RawNode, Value, canonical_order
from .registry import UNSUPPORTED_ORIGINAL, ModuleSpec, lookup, suggest
from .syntax import Binding, Call, Expr, Literal, Position, Ref, Tree
from .types import SIDE_INPUT_TYPES, DslType
from .vocabulary import COLORS, SHAPES, SIZES, VALUE_ALIASES

VOCABULARY: dict[DslType, tuple[str, ...]] = {
    DslType.COLOR: COLORS, DslType.SHAPE: SHAPES, DslType.SIZE: SIZES,
}
#: Where a problem is: (line, column) in text, or (form, index) such as ("token", 4) or ("node", 7).
Where = Position | tuple[str, int] | None

_OBJECT, _OBJECT_SET = DslType.OBJECT, DslType.OBJECT_SET
#: Exact spellings accepted as side-input values, per type (the canonical words and the aliases).
VALUES: dict[DslType, dict[str, str]] = {
    t: {**{a: c for a, c in VALUE_ALIASES.items() if c in words}, **{w: w for w in words}}
    for t, words in VOCABULARY.items()
}
_VALUES = VALUES


def where(pos: Where) -> dict[str, Any]:
    """Keyword arguments of a :class:`ProgramError` for a position."""
    if pos is None:
        return {}
    a, b = pos
    if isinstance(a, str):
        return {"location": f"{a} {b}", "index": b}
    return {"line": a, "column": b}


def canonical_or_none(value: str, expected: DslType) -> str | None:
    """A side-input value ("Small", "Yellow", "block") in the vocabulary's words, or None where it is not one."""
    table = VALUES[expected]
    found = table.get(value)
    return found if found is not None else table.get(value.strip().lower())


def canonical_value(value: str, expected: DslType, module: str, index: int, pos: Where) -> str:
    """Normalise a side-input value ("Small", "Yellow", "block") to the vocabulary, or raise."""
    found = canonical_or_none(value, expected)
    if found is not None:
        return found
    raise SideInputError(
        f"{module}: argument {index} {value!r} is not a {expected}; allowed: {', '.join(VOCABULARY[expected])}",
        **where(pos),
    )


def resolve_module(name: str, pos: Where) -> ModuleSpec:
    """The registry entry of a canonical or original name, or an error naming the nearest ones."""
    spec = lookup(name)
    if spec is not None:
        return spec
    if name in UNSUPPORTED_ORIGINAL:
        raise UnknownModuleError(
            f"module {name!r} of the original engine is not supported: {UNSUPPORTED_ORIGINAL[name]}", **where(pos)
        )
    near = suggest(name)
    hint = f"; did you mean {' or '.join(near)}?" if near else "; run `craft-dsl modules` for the list"
    raise UnknownModuleError(f"unknown module {name!r}{hint}", **where(pos))


def arity_error(spec: ModuleSpec, found: int, pos: Where) -> TypeCheckError:
    return TypeCheckError(
        f"{spec.name} takes {spec.arity} argument{'s' if spec.arity != 1 else ''} "
        f"({spec.signature_text()}), found {found}",
        module=spec.name, **where(pos),
    )


#: How a call checks, per (module name, *input types): (overload index, output type, inputs to wrap in Unique).
#: The key is flat (no nested tuple of types) so that building it costs one tuple on the hot path.
Resolution = tuple[int, DslType, tuple[int, ...]]
RESOLUTIONS: dict[tuple[Any, ...], Resolution] = {}
_RESOLUTIONS = RESOLUTIONS
#: The (module name, *input types) that no overload accepts.
_NO_OVERLOAD: set[tuple[Any, ...]] = set()


def resolve_overload(spec: ModuleSpec, types: tuple[DslType, ...]) -> Resolution | None:
    """Exact matches first, then matches that need Unique around an object set (cached per input types in
    :data:`RESOLUTIONS`); None where no overload fits."""
    for allow_unique in (False, True):
        for k, ov in enumerate(spec.overloads):
            wrap = []
            for i, (got, want) in enumerate(zip(types, ov.inputs)):
                if got == want:
                    continue
                if allow_unique and want == _OBJECT and got == _OBJECT_SET:
                    wrap.append(i)
                    continue
                break
            else:
                found = (k, ov.output, tuple(wrap))
                key = (spec.name, *types)
                RESOLUTIONS[key] = found
                return found
    return None


_resolve_overload = resolve_overload
_INPUT_TYPES: dict[tuple[str, int], frozenset[DslType]] = {}


def literal_type(spec: ModuleSpec, index: int, value: Value) -> DslType | None:
    """The type of the literal :meth:`ProgramBuilder.input_literal` makes of ``value`` as input ``index`` of
    ``spec``, or None where it raises."""
    if isinstance(value, int):
        return DslType.INTEGER
    expected = _INPUT_TYPES.get((spec.name, index))
    if expected is None:
        expected = _INPUT_TYPES[(spec.name, index)] = frozenset(ov.inputs[index] for ov in spec.overloads)
    if len(expected) != 1:
        return None
    (typ,) = expected
    return typ if typ in SIDE_INPUT_TYPES and canonical_or_none(value, typ) is not None else None


class ProgramBuilder:
    """Checks calls one at a time and hash-conses them into raw nodes (plain tuples of :class:`~craft_dsl.ir.Node`'s
    fields)."""

    def __init__(self) -> None:
        self.nodes: list[RawNode] = []
        self._index: dict[RawNode, int] = {}

    def add(self, node: RawNode) -> int:
        """The index of ``node`` in :attr:`nodes`, added if it is not there yet (no check)."""
        nodes = self.nodes
        found = self._index.setdefault(node, len(nodes))  # one hash of the node, where get-then-set takes two
        if found == len(nodes):
            nodes.append(node)
        return found

    _add = add

    def literal(self, value: Value, typ: DslType) -> int:
        """A literal node (an integer, or a canonical colour/shape/size)."""
        return self._add((None, (), (value,), typ, 0))

    def input_literal(self, spec: ModuleSpec, index: int, value: Value, pos: Where) -> int:
        """A literal written in an input position: an integer, or a quoted value where a Color/Shape/Size is
        expected (``EqualColor(QueryColor(x), "red")``)."""
        if isinstance(value, int):
            return self.literal(value, DslType.INTEGER)
        expected = {ov.inputs[index] for ov in spec.overloads}
        if len(expected) == 1 and next(iter(expected)) in SIDE_INPUT_TYPES:
            (typ,) = expected
            return self.literal(canonical_value(value, typ, spec.name, index + 1, pos), typ)
        want = " or ".join(sorted(str(t) for t in expected))
        raise TypeCheckError(
            f"{spec.name}: argument {index + 1} expects {want}, found a quoted value {value!r} "
            "(quoted values are colours, shapes and sizes)",
            module=spec.name, argument=index + 1, expected=tuple(sorted(str(t) for t in expected)),
            found="quoted value", **where(pos),
        )

    def try_call(self, spec: ModuleSpec, inputs: Sequence[int], sides: Sequence[Value]) -> int | None:
        """What :meth:`call` gives, or None where it raises: found without raising, with the same resolution,
        value tables and node. The caller has checked the numbers of inputs and side inputs."""
        nodes = self.nodes
        name = spec.name
        n = len(inputs)
        if n == 1:
            key: tuple[Any, ...] = (name, nodes[inputs[0]][3])
        elif n == 2:
            key = (name, nodes[inputs[0]][3], nodes[inputs[1]][3])
        elif n == 0:
            key = (name,)
        else:
            key = (name, *[nodes[i][3] for i in inputs])
        res = RESOLUTIONS.get(key)
        if res is None:
            if key in _NO_OVERLOAD:
                return None
            res = resolve_overload(spec, key[1:])
            if res is None:
                _NO_OVERLOAD.add(key)
                return None
        values: tuple[Value, ...] = ()
        if sides:
            if len(sides) == 1:
                value = sides[0]
                found = canonical_or_none(value, spec.side_inputs[0]) if isinstance(value, str) else None
                if found is None:
                    return None
                values = (found,)
            else:
                checked: list[Value] = []
                for value, expected in zip(sides, spec.side_inputs):
                    found = canonical_or_none(value, expected) if isinstance(value, str) else None
                    if found is None:
                        return None
                    checked.append(found)
                values = tuple(checked)
        overload, output, wrap = res
        if wrap:
            ids = list(inputs)
            for k in wrap:
                ids[k] = self.add(("Unique", (ids[k],), (), _OBJECT, 0))
            inputs = ids
        node: RawNode = (name, tuple(inputs), values, output, overload)
        found_id = self._index.setdefault(node, len(nodes))
        if found_id == len(nodes):
            nodes.append(node)
        return found_id

    def call(self, spec: ModuleSpec, inputs: Sequence[int], sides: Sequence[Value],
             pos: Where = None, input_pos: Sequence[Where] = (), side_pos: Sequence[Where] = ()) -> int:
        """Check one call of ``spec`` on input nodes and side-input values; return its node index, or raise
        the error :meth:`try_call` finds (the first in argument order).

        The caller has checked the number of inputs and side inputs.
        """
        found = self.try_call(spec, inputs, sides)
        if found is not None:
            return found
        types = tuple([self.nodes[i][3] for i in inputs])
        if resolve_overload(spec, types) is None:
            raise self._overload_error(spec, types, pos, input_pos)
        n = len(inputs)
        for k, (value, expected) in enumerate(zip(sides, spec.side_inputs)):
            self._side_value(spec, n + k + 1, value, expected, side_pos[k] if k < len(side_pos) else pos)
        raise AssertionError("try_call refused a call that checks")  # pragma: no cover

    @staticmethod
    def _side_value(spec: ModuleSpec, argument: int, value: Value, expected: DslType, pos: Where) -> str:
        if not isinstance(value, str):
            raise TypeCheckError(
                f"{spec.name}: argument {argument} must be a quoted {expected} value such as "
                f'"{VOCABULARY[expected][0]}", found an integer',
                module=spec.name, argument=argument, expected=(str(expected),), found="integer", **where(pos),
            )
        return canonical_value(value, expected, spec.name, argument, pos)

    def _overload_error(self, spec: ModuleSpec, types: tuple[DslType, ...], pos: Where,
                        input_pos: Sequence[Where]) -> TypeCheckError:
        for i, found in enumerate(types):
            expected = {ov.inputs[i] for ov in spec.overloads}
            if found in expected or (_OBJECT in expected and found == _OBJECT_SET):
                continue
            allowed = tuple(sorted(str(t) for t in expected))
            at = input_pos[i] if i < len(input_pos) and input_pos[i] is not None else pos
            return TypeCheckError(
                f"{spec.name}: argument {i + 1} expects {' or '.join(allowed)}, found {found}",
                module=spec.name, argument=i + 1, expected=allowed, found=str(found), **where(at),
            )
        return TypeCheckError(
            f"{spec.name}: no signature fits the argument types "
            f"({', '.join(str(t) for t in types)}); signatures: {spec.signature_text()}",
            module=spec.name, found=", ".join(str(t) for t in types), **where(pos),
        )

    def finish(self, root: int, sources: Sequence[int] = (), tree: Tree | None = None,
               binding_types: dict[str, DslType] | None = None) -> CheckedProgram:
        """The checked program whose answer is node ``root`` (``sources``: the node of each source call)."""
        return CheckedProgram(self.nodes, root, tree, binding_types or {}, tuple(sources))


class CheckedProgram:
    """A checked program, and what its source form needs to be shown again.

    ``raw`` holds the nodes in the order they were checked (a dependency order; nodes the answer does not
    need may be among them) and ``root`` is the answer's node: enough to run the program. The canonical
    :attr:`nodes` (see :mod:`craft_dsl.ir`) are computed when first asked for. ``tree`` is the checked syntax
    tree (canonical names and values, explicit Unique) for text programs, None for other forms.
    """

    __slots__ = ("raw", "root", "tree", "binding_types", "raw_sources", "_canonical")

    def __init__(self, raw: Sequence[RawNode], root: int, tree: Tree | None, binding_types: dict[str, DslType],
                 raw_sources: tuple[int, ...]) -> None:
        self.raw = raw
        self.root = root
        self.tree = tree
        self.binding_types = binding_types
        self.raw_sources = raw_sources
        self._canonical: tuple[tuple[Node, ...], list[int]] | None = None

    def _canonical_form(self) -> tuple[tuple[Node, ...], list[int]]:
        if self._canonical is None:
            self._canonical = canonical_order(self.raw, self.root)
        return self._canonical

    @property
    def type(self) -> DslType:
        return self.raw[self.root][3]

    @property
    def nodes(self) -> tuple[Node, ...]:
        """The canonical nodes (the last one is the answer)."""
        return self._canonical_form()[0]

    @property
    def order(self) -> list[int]:
        """The raw index of every canonical node."""
        nodes, new_index = self._canonical_form()
        out = [0] * len(nodes)
        for raw_index, k in enumerate(new_index):
            if k >= 0:
                out[k] = raw_index
        return out

    @property
    def source_nodes(self) -> tuple[int | None, ...]:
        """For the k-th call of the source form, its canonical node (None where the answer does not need it)."""
        new_index = self._canonical_form()[1]
        return tuple([new_index[i] if new_index[i] >= 0 else None for i in self.raw_sources])


class _Frame:
    __slots__ = ("call", "spec", "n_inputs", "next", "ids", "exprs", "source")

    def __init__(self, call: Call, spec: ModuleSpec, source: int) -> None:
        self.call = call
        self.spec = spec
        self.n_inputs = len(spec.overloads[0].inputs)
        self.next = 0
        self.ids: list[int] = []
        self.exprs: list[Expr] = []
        self.source = source


def check_tree(tree: Tree) -> CheckedProgram:
    """Type-check a syntax tree; raise a ProgramError subclass on the first problem."""
    builder = ProgramBuilder()
    env: dict[str, tuple[int, DslType]] = {}
    sources: list[int] = []
    bindings: list[Binding] = []
    for b in tree.bindings:
        if b.name in env:
            raise ProgramError(f"Var {b.name} is bound twice; use another name", **where(b.pos))
        nid, expr = _check_expr(builder, b.expr, env, sources)
        env[b.name] = (nid, builder.nodes[nid][3])
        bindings.append(Binding(b.name, expr, b.pos))
    root, body = _check_expr(builder, tree.body, env, sources)
    if builder.nodes[root][0] is None:
        raise ProgramError("a program must call a module; a lone value is not a program (in every form)",
                           **where(getattr(tree.body, "pos", None)))
    return builder.finish(root, sources, Tree(tuple(bindings), body), {k: t for k, (_, t) in env.items()})


def _ref(env: dict[str, tuple[int, DslType]], ref: Ref) -> int:
    if ref.name not in env:
        defined = ", ".join(env) or "none"
        extra = f"; to call module {ref.name} write {ref.name}(...)" if lookup(ref.name) is not None else ""
        raise ProgramError(f"unknown variable {ref.name!r} (defined so far: {defined}){extra}", **where(ref.pos))
    return env[ref.name][0]


def _open(call: Call, sources: list[int]) -> _Frame:
    spec = resolve_module(call.module, call.pos)
    if len(call.args) != spec.arity:
        raise arity_error(spec, len(call.args), call.pos)
    sources.append(-1)
    return _Frame(call, spec, len(sources) - 1)


def _check_expr(builder: ProgramBuilder, expr: Expr, env: dict[str, tuple[int, DslType]],
                sources: list[int]) -> tuple[int, Expr]:
    """Check one expression (iteratively); return its node index and its checked syntax."""
    if isinstance(expr, Ref):
        return _ref(env, expr), expr
    if isinstance(expr, Literal):
        if isinstance(expr.value, int):
            return builder.literal(expr.value, DslType.INTEGER), expr
        raise TypeCheckError(
            f"a quoted value ({expr.value!r}) can only be a side input of a filter, such as "
            'FilterColor(SceneAtStart(), "red")',
            found="quoted value", **where(expr.pos),
        )
    stack = [_open(expr, sources)]
    while True:
        frame = stack[-1]
        if frame.next < frame.n_inputs:
            arg = frame.call.args[frame.next]
            if isinstance(arg, Call):
                stack.append(_open(arg, sources))
                continue
            checked: Expr
            if isinstance(arg, Ref):
                nid, checked = _ref(env, arg), arg
            else:
                nid = builder.input_literal(frame.spec, frame.next, arg.value, arg.pos)
                lit = builder.nodes[nid][2][0]
                checked = arg if lit == arg.value else Literal(lit, arg.pos)
            frame.ids.append(nid)
            frame.exprs.append(checked)
            frame.next += 1
            continue
        call, spec = frame.call, frame.spec
        side_args = call.args[frame.n_inputs:]
        for k, arg in enumerate(side_args, start=frame.n_inputs + 1):
            if not isinstance(arg, Literal):
                expected = spec.side_inputs[k - frame.n_inputs - 1]
                raise TypeCheckError(
                    f"{spec.name}: argument {k} must be a quoted {expected} value such as "
                    f'"{VOCABULARY[expected][0]}", found an expression',
                    module=spec.name, argument=k, expected=(str(expected),), found="expression",
                    **where(arg.pos or call.pos),
                )
        nid = builder.call(
            spec, frame.ids, [a.value for a in side_args if isinstance(a, Literal)], call.pos,
            [a.pos for a in call.args[:frame.n_inputs]], [a.pos or call.pos for a in side_args],
        )
        _module, node_inputs, node_values = builder.nodes[nid][:3]
        args = [
            expr_k if node_inputs[k] == frame.ids[k] else Call("Unique", (expr_k,), expr_k.pos)
            for k, expr_k in enumerate(frame.exprs)
        ]
        args += [Literal(v, a.pos) for v, a in zip(node_values, side_args)]
        checked_call = Call(spec.name, tuple(args), call.pos)
        sources[frame.source] = nid
        stack.pop()
        if not stack:
            return nid, checked_call
        parent = stack[-1]
        parent.ids.append(nid)
        parent.exprs.append(checked_call)
        parent.next += 1
