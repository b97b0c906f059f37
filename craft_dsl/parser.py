"""Text form -> syntax tree, with errors that point at line and column."""

from __future__ import annotations

import re
from functools import lru_cache
from typing import Any, cast

from lark import Lark, Token, Transformer, v_args
from lark import Tree as LarkTree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from .checker import CheckedProgram, ProgramBuilder, check_tree
from .errors import ParseError, ProgramError
from .ir import Value
from .registry import NAMES, ModuleSpec
from .resources import data_dir
from .syntax import Binding, Call, Expr, Literal, Ref, Tree
from .types import integer_literal

_QUOTES = '"\u201c\u201d'


def _pos(tok: Token) -> tuple[int, int]:
    """(line, column) of a token; positions of syntax nodes are those of their first token."""
    return (tok.line or 0, tok.column or 0)


@v_args(tree=True)
class _ToSyntax(Transformer):
    def start(self, t: LarkTree) -> Tree:
        *bindings, body = cast(list[Any], t.children)
        return Tree(tuple(bindings), body)

    def binding(self, t: LarkTree) -> Binding:
        _var, name, expr = cast(list[Any], t.children)
        return Binding(str(name), expr, _pos(name))

    def call(self, t: LarkTree) -> Call:
        name, *args = cast(list[Any], t.children)
        return Call(str(name), tuple(a for a in args if a is not None), _pos(name))

    def string(self, t: LarkTree) -> Literal:
        (tok,) = cast(list[Any], t.children)
        return Literal(str(tok).strip(_QUOTES), _pos(tok))

    def integer(self, t: LarkTree) -> Literal:
        (tok,) = cast(list[Any], t.children)
        try:
            return Literal(integer_literal(str(tok)), _pos(tok))
        except ValueError as err:
            raise ParseError(str(err), *_pos(tok)) from None

    def ref(self, t: LarkTree) -> Ref:
        (tok,) = cast(list[Any], t.children)
        return Ref(str(tok), _pos(tok))


@lru_cache(maxsize=1)
def _parser() -> Lark:
    grammar = (data_dir("grammar") / "craft.lark").read_text(encoding="utf-8")
    # The transformer runs inside the LALR parser: no intermediate parse tree is built.
    return Lark(grammar, parser="lalr", maybe_placeholders=False, transformer=_ToSyntax())


_EXPECTED_NAMES = {
    "NAME": "a module or Var name", "LPAR": "'('", "RPAR": "')'", "COMMA": "','", "EQUAL": "'='",
    "STRING": "a quoted value", "INT": "an integer", "VAR": "'Var'", "$END": "end of program",
}


def _expected(err: UnexpectedInput) -> str:
    raw = getattr(err, "expected", None) or getattr(err, "allowed", None) or ()
    names = sorted({_EXPECTED_NAMES.get(e, e) for e in raw})
    return ", ".join(names) if names else "something else"


def parse_tree(text: str) -> Tree:
    """Parse program text into a syntax tree (no name or type checks yet)."""
    if not text.strip() or all(not ln.strip() or ln.strip().startswith("#") for ln in text.splitlines()):
        raise ParseError("the program is empty: write an expression such as Count(SceneAtStart())", 1, 1)
    try:
        tree = _parser().parse(text)
    except UnexpectedCharacters as err:
        ch = text[err.pos_in_stream] if err.pos_in_stream is not None else "?"
        if ch == ")":
            msg = "unexpected ')': it closes no open parenthesis (one ')' too many?)"
        else:
            msg = f"unexpected character {ch!r}; expected {_expected(err)}"
        raise ParseError(msg, err.line, err.column) from None
    except UnexpectedToken as err:
        tok = err.token
        if tok.type == "$END":
            raise ParseError(
                f"the program ends too early; expected {_expected(err)} (an unclosed '('?)",
                *_end_position(text),
            ) from None
        before = text[: tok.start_pos].rstrip() if tok.start_pos is not None else ""
        if tok.type == "RPAR" and before.endswith(","):
            msg = "unexpected ')' after ',': a trailing comma needs an argument after it (remove the ',')"
        elif tok.type == "RPAR" and "RPAR" not in (err.expected or ()):
            msg = "unexpected ')': it closes no open parenthesis (one ')' too many?)"
        elif tok.type == "NAME" and "RPAR" in (err.expected or ()):
            msg = f"unexpected {str(tok)!r}; expected ',' or ')' (a missing comma?)"
        else:
            msg = f"unexpected {str(tok)!r}; expected {_expected(err)}"
        raise ParseError(msg, tok.line, tok.column) from None
    except UnexpectedEOF as err:
        raise ParseError(f"the program ends too early; expected {_expected(err)}", *_end_position(text)) from None
    assert isinstance(tree, Tree)
    return tree


def _end_position(text: str) -> tuple[int, int]:
    lines = text.rstrip().splitlines() or [""]
    return len(lines), len(lines[-1]) + 1


def parse_expr(text: str) -> Expr:
    """Parse a single expression (no bindings)."""
    tree = parse_tree(text)
    if tree.bindings:
        b = tree.bindings[0]
        line, col = b.pos or (1, 1)
        raise ParseError("expected a single expression, found a Var binding", line, col)
    return tree.body


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
