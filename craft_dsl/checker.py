"""Static checking: resolve module names and overloads, validate side inputs, insert Unique.

The checker turns a raw syntax tree into a checked one: canonical module names, canonical side-input
values, and an explicit ``Unique(...)`` wherever an object-set expression stands where one Object is
expected (the paper's convention). Errors name the module, the argument, the expected and found type.
"""

from __future__ import annotations

from dataclasses import dataclass

from .errors import ProgramError, SideInputError, TypeCheckError, UnknownModuleError
from .registry import UNSUPPORTED_ORIGINAL, ModuleSpec, Overload, lookup, suggest
from .syntax import Binding, Call, Expr, Literal, Position, Ref, Tree
from .types import SIDE_INPUT_TYPES, DslType
from .vocabulary import COLORS, SHAPES, SIZES, VALUE_ALIASES

VOCABULARY: dict[DslType, tuple[str, ...]] = {
    DslType.COLOR: COLORS, DslType.SHAPE: SHAPES, DslType.SIZE: SIZES,
}


@dataclass(frozen=True)
class CheckedTree:
    """A checked program: the canonical tree, the type of every binding and of the result."""

    tree: Tree
    binding_types: dict[str, DslType]
    type: DslType
    #: Output type of every call of the checked tree.
    call_types: dict[Expr, DslType]


def _where(pos: Position | None) -> tuple[int | None, int | None]:
    return (pos[0], pos[1]) if pos else (None, None)


def canonical_value(value: str, expected: DslType, module: str, index: int, pos: Position | None) -> str:
    """Normalise a side-input value ("Small", "Yellow", "block") to the vocabulary, or raise."""
    allowed = VOCABULARY[expected]
    word = value.strip().lower()
    word = VALUE_ALIASES.get(word, word)
    if word in allowed:
        return word
    raise SideInputError(
        f"{module}: argument {index} {value!r} is not a {expected}; allowed: {', '.join(allowed)}",
        *_where(pos),
    )


def resolve_module(name: str, pos: Position | None) -> ModuleSpec:
    spec = lookup(name)
    if spec is not None:
        return spec
    if name in UNSUPPORTED_ORIGINAL:
        raise UnknownModuleError(
            f"module {name!r} of the original engine is not supported: {UNSUPPORTED_ORIGINAL[name]}",
            *_where(pos),
        )
    near = suggest(name)
    hint = f"; did you mean {' or '.join(near)}?" if near else "; run `craft-dsl modules` for the list"
    raise UnknownModuleError(f"unknown module {name!r}{hint}", *_where(pos))


class _Checker:
    def __init__(self) -> None:
        self.env: dict[str, DslType] = {}
        self.call_types: dict[Expr, DslType] = {}

    def check_tree(self, tree: Tree) -> CheckedTree:
        bindings = []
        for b in tree.bindings:
            if b.name in self.env:
                raise ProgramError(f"Var {b.name} is bound twice; use another name", *_where(b.pos))
            expr, typ = self.check(b.expr)
            self.env[b.name] = typ
            bindings.append(Binding(b.name, expr, b.pos))
        body, typ = self.check(tree.body)
        return CheckedTree(Tree(tuple(bindings), body), dict(self.env), typ, self.call_types)

    def check(self, expr: Expr) -> tuple[Expr, DslType]:
        if isinstance(expr, Ref):
            if expr.name not in self.env:
                defined = ", ".join(self.env) or "none"
                extra = ""
                if lookup(expr.name) is not None:
                    extra = f"; to call module {expr.name} write {expr.name}(...)"
                raise ProgramError(
                    f"unknown variable {expr.name!r} (defined so far: {defined}){extra}", *_where(expr.pos)
                )
            return expr, self.env[expr.name]
        if isinstance(expr, Literal):
            if isinstance(expr.value, int):
                return expr, DslType.INTEGER
            raise TypeCheckError(
                f"a quoted value ({expr.value!r}) can only be a side input of a filter, such as "
                'FilterColor(SceneAtStart(), "red")',
                *_where(expr.pos),
            )
        return self.check_call(expr)

    def check_call(self, call: Call) -> tuple[Expr, DslType]:
        spec = resolve_module(call.module, call.pos)
        n_inputs = len(spec.overloads[0].inputs)
        if len(call.args) != spec.arity:
            raise TypeCheckError(
                f"{spec.name} takes {spec.arity} argument{'s' if spec.arity != 1 else ''} "
                f"({spec.signature_text()}), found {len(call.args)}",
                *_where(call.pos),
            )
        checked = [self.check_input(spec, i, a) for i, a in enumerate(call.args[:n_inputs])]
        overload, args = self._choose_overload(spec, call, checked)
        sides: list[Expr] = []
        for k, (arg, expected) in enumerate(zip(call.args[n_inputs:], spec.side_inputs), start=n_inputs + 1):
            if not isinstance(arg, Literal) or not isinstance(arg.value, str):
                found = "an expression" if not isinstance(arg, Literal) else "an integer"
                raise TypeCheckError(
                    f"{spec.name}: argument {k} must be a quoted {expected} value such as "
                    f'"{VOCABULARY[expected][0]}", found {found}',
                    *_where(arg.pos or call.pos),
                )
            sides.append(Literal(canonical_value(arg.value, expected, spec.name, k, arg.pos), arg.pos))
        for a in args:
            if isinstance(a, Call) and a.module == "Unique":
                self.call_types.setdefault(a, DslType.OBJECT)
        checked_call = Call(spec.name, tuple(args) + tuple(sides), call.pos)
        self.call_types[checked_call] = overload.output
        return checked_call, overload.output

    def check_input(self, spec: ModuleSpec, index: int, arg: Expr) -> tuple[Expr, DslType]:
        """Check one (non-side) input; a quoted value is allowed where a Color, Shape or Size is expected."""
        if not (isinstance(arg, Literal) and isinstance(arg.value, str)):
            return self.check(arg)
        expected = {ov.inputs[index] for ov in spec.overloads}
        if len(expected) == 1 and next(iter(expected)) in SIDE_INPUT_TYPES:
            (typ,) = expected
            return Literal(canonical_value(arg.value, typ, spec.name, index + 1, arg.pos), arg.pos), typ
        want = " or ".join(sorted(str(t) for t in expected))
        raise TypeCheckError(
            f"{spec.name}: argument {index + 1} expects {want}, found a quoted value {arg.value!r} "
            "(quoted values are colours, shapes and sizes)",
            *_where(arg.pos),
        )

    def _choose_overload(
        self, spec: ModuleSpec, call: Call, checked: list[tuple[Expr, DslType]]
    ) -> tuple[Overload, list[Expr]]:
        # Exact matches first, then matches that need Unique around an object set.
        for allow_unique in (False, True):
            for ov in spec.overloads:
                args = _match(ov, checked, allow_unique)
                if args is not None:
                    return ov, args
        # No overload fits: report the first argument that fits none.
        for i, (arg, found) in enumerate(checked):
            expected = {ov.inputs[i] for ov in spec.overloads}
            if found in expected or (DslType.OBJECT in expected and found == DslType.OBJECT_SET):
                continue
            want = " or ".join(sorted(str(t) for t in expected))
            raise TypeCheckError(
                f"{spec.name}: argument {i + 1} expects {want}, found {found}",
                *_where(arg.pos or call.pos),
            )
        raise TypeCheckError(
            f"{spec.name}: no signature fits the argument types "
            f"({', '.join(str(t) for _, t in checked)}); signatures: {spec.signature_text()}",
            *_where(call.pos),
        )


def _match(ov: Overload, checked: list[tuple[Expr, DslType]], allow_unique: bool) -> list[Expr] | None:
    args: list[Expr] = []
    for (arg, found), expected in zip(checked, ov.inputs):
        if found == expected:
            args.append(arg)
        elif allow_unique and expected == DslType.OBJECT and found == DslType.OBJECT_SET:
            args.append(Call("Unique", (arg,), arg.pos))
        else:
            return None
    return args


def check_tree(tree: Tree) -> CheckedTree:
    """Type-check a syntax tree; raise a ProgramError subclass on the first problem."""
    return _Checker().check_tree(tree)

