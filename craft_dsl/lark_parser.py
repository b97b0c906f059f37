"""The grammar's parser: text -> syntax tree with Lark (LALR), with errors that point at line and column.

This is the definition of the text form (grammar/craft.lark) and the source of every syntax error message;
:mod:`craft_dsl.parser` reads the common case faster and falls back to it.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, cast

from lark import Lark, Token, Transformer, v_args
from lark import Tree as LarkTree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from .errors import ParseError
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
