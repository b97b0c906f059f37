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
#: An open call of :func:`scan_calls`: its shape, its arguments so far (what the hooks give for each argument),
#: and its index in reading order.
Frame = tuple[ModuleSpec, int, int, list[Any], int]


class GiveUp(Exception):
    """Raised by a hook of :func:`scan_calls`: the text is left to the grammar."""


def scan_calls(text: str, state: Any, close: Callable[[Any, Frame], Any],
               input_value: Callable[[Any, ModuleSpec, int, Value], Any],
               side_value: Callable[[Any, ModuleSpec, int, str], Any] | None = None) -> tuple[Any, list[Any]] | None:
    """The fast path's scanner and reader of calls, shared by :func:`fast_check` and the batch text reader:
    ``(root, items)`` for binding-free text, None where it gives up (anything the grammar must decide).

    Each call is handed to ``close(state, frame)`` when its closing parenthesis is read, its arguments already
    in the frame: what ``close`` gave for each call argument, ``input_value(state, spec, k, value)`` for a
    quoted value (a str) or an integer in input position ``k``, ``side_value(state, spec, k, value)`` (or the
    value itself where ``side_value`` is None) for a quoted value in side-input position ``k``. ``root`` is what
    ``close`` gave for the outermost call, ``items`` what it gave for each call in reading order. A hook gives
    up by raising :class:`GiveUp` (or a ProgramError); the number of arguments is for ``close`` to check.
    """
    toks = _FAST_TOKEN.findall(text)
    if not toks or "Var" in toks:
        return None
    shape_of = _SHAPES.get
    items: list[Any] = []
    # One frame per open call.
    frames: list[Frame] = []
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
                frame: Frame = (*shape, [], len(items))
                items.append(None)
                i += 2
                if toks[i] != ")":
                    frames.append(frame)
                    continue
                i += 1
                item = items[frame[4]] = close(state, frame)
                is_call = True
            elif first == '"':
                value = tok[1:-1]
                is_call = False
                i += 1
            elif first in _INT_START and tok != "-":
                value = integer_literal(tok)
                is_call = False
                i += 1
            else:
                return None
            while True:  # deliver the argument to the call it belongs to
                if not frames:
                    if i != n or not is_call:
                        return None
                    return item, items
                spec, n_inputs, arity, args, _index = frames[-1]
                k = len(args)
                if k < n_inputs:
                    args.append(item if is_call else input_value(state, spec, k, value))
                elif k < arity and not is_call and isinstance(value, str):
                    args.append(value if side_value is None else side_value(state, spec, k, value))
                else:
                    return None
                tok = toks[i]
                i += 1
                if tok == ",":
                    break
                if tok != ")":
                    return None
                frame = frames.pop()
                item = items[frame[4]] = close(state, frame)
                is_call = True
    except (IndexError, ValueError, ProgramError, GiveUp):
        return None


def fast_check(text: str) -> CheckedProgram | None:
    """The checked program of binding-free text, or None where the full parser must decide."""
    builder = ProgramBuilder()
    found = scan_calls(text, builder, _close, _input_literal)
    if found is None:
        return None
    root, sources = found
    return builder.finish(root, sources)


def _close(builder: ProgramBuilder, frame: Frame) -> int:
    spec, n_inputs, arity, args, _index = frame
    if len(args) != arity:
        raise ParseError("arity")  # scan_calls gives up: the full path reports it
    return builder.call(spec, args[:n_inputs], args[n_inputs:]) if arity > n_inputs else builder.call(spec, args, ())


def _input_literal(builder: ProgramBuilder, spec: ModuleSpec, k: int, value: Value) -> int:
    return builder.input_literal(spec, k, value, None)


def check_text(text: str) -> CheckedProgram:
    """Parse and check program text (fast path first, the grammar for everything else)."""
    return fast_check(text) or check_tree(parse_tree(text))
