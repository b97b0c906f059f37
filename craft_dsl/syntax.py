"""Program syntax trees. Nodes are immutable and hashable; source positions never affect equality."""

from __future__ import annotations

from dataclasses import dataclass, field

Position = tuple[int, int]  # (line, column), 1-based


@dataclass(frozen=True)
class Call:
    """A module application. After type checking ``module`` is the canonical name."""

    module: str
    args: tuple[Expr, ...] = ()
    pos: Position | None = field(default=None, compare=False, hash=False, repr=False)


@dataclass(frozen=True)
class Literal:
    """A side-input or integer literal ("small", "yellow", 3). Strings are stored canonical after checking."""

    value: str | int
    pos: Position | None = field(default=None, compare=False, hash=False, repr=False)


@dataclass(frozen=True)
class Ref:
    """A reference to a ``Var`` binding."""

    name: str
    pos: Position | None = field(default=None, compare=False, hash=False, repr=False)


Expr = Call | Literal | Ref


@dataclass(frozen=True)
class Binding:
    name: str
    expr: Expr
    pos: Position | None = field(default=None, compare=False, hash=False, repr=False)


@dataclass(frozen=True)
class Tree:
    """A whole program: bindings, then the final expression."""

    bindings: tuple[Binding, ...]
    body: Expr


def format_expr(expr: Expr) -> str:
    """Canonical one-line text of an expression (iterative: any depth)."""
    out: list[str] = []
    stack: list[Expr | str] = [expr]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            out.append(item)
        elif isinstance(item, Call):
            stack.append(")")
            for k in range(len(item.args) - 1, -1, -1):
                stack.append(item.args[k])
                if k:
                    stack.append(", ")
            out.append(f"{item.module}(")
        elif isinstance(item, Literal):
            out.append(f'"{item.value}"' if isinstance(item.value, str) else str(item.value))
        else:
            out.append(item.name)
    return "".join(out)


def format_tree(tree: Tree) -> str:
    """Canonical text: one ``Var Name = expr`` line per binding, then the final expression."""
    lines = [f"Var {b.name} = {format_expr(b.expr)}" for b in tree.bindings]
    lines.append(format_expr(tree.body))
    return "\n".join(lines)
