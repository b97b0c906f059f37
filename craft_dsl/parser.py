"""Text form -> checked program: a fast reader for the common case, the grammar for everything else."""

from __future__ import annotations

import re

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


def fast_check(text: str) -> CheckedProgram | None:
    """The checked program of binding-free text, or None where the full parser must decide."""
    toks = _FAST_TOKEN.findall(text)
    if not toks or "Var" in toks:
        return None
    builder = ProgramBuilder()
    sources: list[int] = []
    frames: list[tuple[ModuleSpec, list[int], list[Value], int]] = []
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
                spec = NAMES.get(tok)
                if spec is None:
                    return None
                sources.append(-1)
                frames.append((spec, [], [], len(sources) - 1))
                i += 2
                if toks[i] != ")":
                    continue
                i += 1
                node: int | None = _close(builder, frames.pop(), sources)
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
                spec, ids, sides, _source = frames[-1]
                k = len(ids) + len(sides)
                if k < spec.n_inputs and not sides:
                    ids.append(node if node is not None else builder.input_literal(spec, k, value, None))
                elif k < spec.arity and node is None and isinstance(value, str):
                    sides.append(value)
                else:
                    return None
                tok = toks[i]
                i += 1
                if tok == ",":
                    break
                if tok != ")":
                    return None
                node = _close(builder, frames.pop(), sources)
    except (IndexError, ValueError, ProgramError):
        return None


def _close(builder: ProgramBuilder, frame: tuple[ModuleSpec, list[int], list[Value], int], sources: list[int]) -> int:
    spec, ids, sides, source = frame
    if len(ids) != spec.n_inputs or len(sides) != len(spec.side_inputs):
        raise ParseError("arity")  # caught by fast_check: the full path reports it
    node = builder.call(spec, ids, sides)
    sources[source] = node
    return node


def check_text(text: str) -> CheckedProgram:
    """Parse and check program text (fast path first, the grammar for everything else)."""
    return fast_check(text) or check_tree(parse_tree(text))
