"""Text form -> checked program: a fast reader for the common case, the grammar for everything else."""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

from .checker import CheckedProgram, ProgramBuilder, check_tree
from .errors import ParseError, ProgramError
from .ir import Value
from .registry import NAMES, ModuleSpec
from .syntax import Expr, Tree
from .types import integer_literal


def parse_tree(text: str) -> Tree:
    """Parse program text into a syntax tree (no name or type checks yet), with the grammar."""
    from .lark_parser import parse_tree as parse_with_grammar  # Lark loads on first use

    return parse_with_grammar(text)


def parse_expr(text: str) -> Expr:
    """Parse a single expression (no bindings)."""
    from .lark_parser import parse_expr as parse_expr_with_grammar

    return parse_expr_with_grammar(text)


# -- the fast path ------------------------------------------------------------------------------------------
#
# Scoring model outputs parses many small programs, and building them with the LALR parser costs far more than
# running them. Programs without ``Var`` bindings, comments or typographic quotes (what models emit) are read by
# a scanner and an iterative reader that feed the checker directly. It accepts a subset of the grammar and gives
# up (returns None) on anything else, including every error, so that the grammar above stays the definition of
# the language and the source of every error message; the tests check both paths agree.

_FAST_TOKEN = re.compile(
    r"[A-Za-z_][A-Za-z0-9_]*|\"[^\"\u201c\u201d\n]*\"|-?[0-9]+|[(),]|[^ \t\f\r\n\u00a0\u2000-\u200b\u3000]"
)


_NAME_START = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_")
_INT_START = frozenset("-0123456789")


#: Per module name: (spec, number of inputs, number of arguments with the side inputs).
_SHAPES: dict[str, tuple[ModuleSpec, int, int]] = {
    name: (spec, spec.n_inputs, spec.arity) for name, spec in NAMES.items()
}
#: An open call: its shape, its arguments so far (input node ids, then side-input values), its reading-order index.
_Frame = tuple[ModuleSpec, int, int, list[Any], int]


def fast_check(text: str) -> CheckedProgram | None:
    """The checked program of binding-free text, or None where the full parser must decide."""
    toks = _FAST_TOKEN.findall(text)
    if not toks or "Var" in toks:
        return None
    builder = ProgramBuilder()
    call = builder.call
    shape_of = _SHAPES.get
    sources: list[int] = []
    # One frame per open call: its shape, its arguments so far (input node ids, then side-input values) and
    # the index of the call in reading order.
    frames: list[_Frame] = []
    n = len(toks)
    i = 0
    try:
        while True:
            tok = toks[i]
            first = tok[0]
            value: Value
            if first in _NAME_START:
                if toks[i + 1] != "(":
                    return None
                shape = shape_of(tok)
                if shape is None:
                    return None
                frame: _Frame = (*shape, [], len(sources))
                sources.append(-1)
                i += 2
                if toks[i] != ")":
                    frames.append(frame)
                    continue
                i += 1
                node: int | None = _close(call, frame, sources)
                value = 0
            elif first == '"':
                node, value = None, tok[1:-1]
                i += 1
            elif first in _INT_START and tok != "-":
                node, value = None, integer_literal(tok)
                i += 1
            else:
                return None
            while True:  # deliver the value to the call it is an argument of
                if not frames:
                    if i != n or node is None:
                        return None
                    return builder.finish(node, sources)
                spec, n_inputs, arity, args, _source = frames[-1]
                k = len(args)
                if k < n_inputs:
                    args.append(node if node is not None else builder.input_literal(spec, k, value, None))
                elif k < arity and node is None and isinstance(value, str):
                    args.append(value)
                else:
                    return None
                tok = toks[i]
                i += 1
                if tok == ",":
                    break
                if tok != ")":
                    return None
                node = _close(call, frames.pop(), sources)
    except (IndexError, ValueError, ProgramError):
        return None


def _close(call: Callable[..., int], frame: _Frame, sources: list[int]) -> int:
    spec, n_inputs, arity, args, source = frame
    if len(args) != arity:
        raise ParseError("arity")  # caught by fast_check: the full path reports it
    node = sources[source] = call(spec, args[:n_inputs], args[n_inputs:]) if arity > n_inputs else call(spec, args, ())
    return node


def check_text(text: str) -> CheckedProgram:
    """Parse and check program text (fast path first, the grammar for everything else)."""
    return fast_check(text) or check_tree(parse_tree(text))
