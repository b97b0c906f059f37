"""Programs as flat token sequences, the form sequence-to-sequence semantic parsers emit.

A program is written as its expression tree in **prefix** order (each module before its arguments: the
order NS-VQA-style parsers decode) or **postfix** order (arguments first: the order a stack executor runs).
Every module has a fixed number of arguments, so no brackets are needed. Tokens are:

* a module name: ``Count``, ``FilterColor`` (any original name such as ``filter_color`` is read too; a
  program written with original names takes the original argument order, as node lists do);
* a side-input value: ``red``, ``cube``, ``small`` (after the module's inputs, as in the text form);
* an integer literal: ``0``, ``-1`` (the text form's integer arguments, e.g. of FilterMoving);
* optionally **fused**: ``FilterColor[red]``, a module with its side inputs in one token (CLEVR style).

``Var`` bindings are inlined and the checker's explicit ``Unique`` is written, so the token form of a
program is unique: ``to_tokens`` then ``check_tokens`` gives back an equal program for every program.
Reading is iterative (any depth) and every error names the token: ``token 4: unknown token 'Cnt'``.

The k-th *module token* of a sequence is "node k" of that program (value and integer tokens are not nodes);
model traces refer to nodes this way.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterator, Sequence
from typing import Any, Literal

from .checker import VOCABULARY, CheckedProgram, ProgramBuilder, Where, arity_error
from .errors import ProgramError, TokenError, TypeCheckError
from .ir import Node, Value
from .registry import MODULES, NAMES, REGISTRY, ModuleSpec
from .types import integer_literal
from .vocabulary import VALUE_ALIASES

TokenOrder = Literal["prefix", "postfix"]
NameStyle = Literal["canonical", "original"]
ORDERS: tuple[str, ...] = ("prefix", "postfix")

#: An integer token (``-1``, ``3``): the spelling of an integer literal among the tokens.
INTEGER_TOKEN = re.compile(r"-?\d+\Z")
_FUSED = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\[([^\[\]]*)\]\Z")
#: Integer literal tokens listed in vocabularies (state indexes of FilterMoving/FilterStationary).
VOCABULARY_INTEGERS: tuple[str, ...] = ("0", "-1")


# -- writing ------------------------------------------------------------------------------------------------


def _module_token(node: Node, names: NameStyle, fused: bool) -> str:
    spec = REGISTRY[node.module]  # type: ignore[index]
    if names == "original":
        name = spec.overloads[node.overload].original
        if name is None:
            raise TokenError(f"{spec.name} has no original name; write canonical names")
    else:
        name = spec.name
    if fused and node.values:
        return f"{name}[{','.join(str(v) for v in node.values)}]"
    return name


def _input_order(spec: ModuleSpec, inputs: tuple[int, ...], names: NameStyle) -> tuple[int, ...]:
    if names == "original" and spec.original_order is not None:
        return tuple(inputs[j] for j in spec.original_order)
    return inputs


def to_tokens(nodes: Sequence[Node], order: TokenOrder = "prefix", *, names: NameStyle = "canonical",
              fused: bool = False) -> list[str]:
    """The token sequence of checked nodes (see the module docstring)."""
    if order not in ORDERS:
        raise ValueError(f"token order must be 'prefix' or 'postfix', not {order!r}")
    seqs: list[list[str]] = []
    for node in nodes:
        if node.module is None:
            seqs.append([str(node.values[0])])
            continue
        args: list[str] = []
        for j in _input_order(REGISTRY[node.module], node.inputs, names):
            args += seqs[j]
        if not fused:
            args += [str(v) for v in node.values]
        head = _module_token(node, names, fused)
        seqs.append([head, *args] if order == "prefix" else [*args, head])
    return seqs[-1]


# -- reading ------------------------------------------------------------------------------------------------


class _Token:
    """A classified token: a module (with fused side inputs, if any) or a value (str or int)."""

    __slots__ = ("index", "text", "spec", "name", "fused", "value")

    def __init__(self, index: int, text: str) -> None:
        self.index, self.text, self.name = index, text, text
        self.spec: ModuleSpec | None = NAMES.get(text)
        self.fused: list[str] | None = None
        self.value: Value | None = None
        if self.spec is not None:
            return
        fused = _FUSED.match(text)
        if fused and fused.group(1) in NAMES:
            self.name = fused.group(1)
            self.spec = NAMES[self.name]
            self.fused = [v.strip() for v in fused.group(2).split(",")] if fused.group(2).strip() else []
        elif INTEGER_TOKEN.match(text):
            try:
                self.value = integer_literal(text)
            except ValueError as err:
                raise TokenError(str(err), location=f"token {index}", index=index) from None
        elif _is_value(text):
            self.value = text
        else:
            raise TokenError(_unknown(text), location=f"token {index}", index=index)

    @property
    def where(self) -> Where:
        return ("token", self.index)


_VALUE_WORDS = {w for words in VOCABULARY.values() for w in words} | set(VALUE_ALIASES)


def _is_value(text: str) -> bool:
    return text in _VALUE_WORDS or text.strip().lower() in _VALUE_WORDS


def _unknown(text: str) -> str:
    known = [m.name for m in MODULES] + sorted(_VALUE_WORDS)
    near = difflib.get_close_matches(text, known, n=3, cutoff=0.6)
    lowered = {k.lower(): k for k in NAMES}
    near += [lowered[h] for h in difflib.get_close_matches(text.lower(), list(lowered), n=3, cutoff=0.6)
             if lowered[h] not in near]
    hint = f"; did you mean {' or '.join(dict.fromkeys(near[:3]))}?" if near else \
        "; tokens are module names, colours, shapes, sizes and integers (`craft-dsl vocab` lists them)"
    return f"unknown token {text!r}{hint}"


def _split(tokens: Sequence[str] | str) -> list[str]:
    if isinstance(tokens, str):
        return tokens.split()
    if not all(isinstance(t, str) for t in tokens):
        bad = next(t for t in tokens if not isinstance(t, str))
        raise TokenError(f"tokens must be strings, found {bad!r}")
    return list(tokens)


class _Open:
    """A module token whose arguments are still being read (prefix order)."""

    __slots__ = ("tok", "spec", "n_inputs", "n_args", "ids", "input_pos", "sides", "side_pos", "source")

    def __init__(self, tok: _Token, source: int) -> None:
        spec = tok.spec
        assert spec is not None
        self.tok, self.spec, self.source = tok, spec, source
        self.n_inputs = len(spec.overloads[0].inputs)
        self.n_args = self.n_inputs + (0 if tok.fused is not None else len(spec.side_inputs))
        self.ids: list[int] = []
        self.input_pos: list[Where] = []
        self.sides: list[Value] = list(tok.fused) if tok.fused is not None else []
        self.side_pos: list[Where] = [tok.where] * len(self.sides)

    @property
    def filled(self) -> int:
        return len(self.ids) + (len(self.sides) if self.tok.fused is None else 0)

    def add_value(self, builder: ProgramBuilder, tok: _Token) -> None:
        assert tok.value is not None
        k = len(self.ids)
        if k < self.n_inputs:
            self.ids.append(builder.input_literal(self.spec, k, tok.value, tok.where))
            self.input_pos.append(tok.where)
        else:
            self.sides.append(tok.value)
            self.side_pos.append(tok.where)

    def add_node(self, nid: int, tok: _Token) -> None:
        k = self.filled
        if k >= self.n_inputs:
            expected = self.spec.side_inputs[k - self.n_inputs]
            raise TypeCheckError(
                f"{self.spec.name}: argument {k + 1} must be a {expected} value such as "
                f"{VOCABULARY[expected][0]}, found module {tok.name}",
                module=self.spec.name, argument=k + 1, expected=(str(expected),), found="expression",
                location=f"token {tok.index}", index=tok.index,
            )
        self.ids.append(nid)
        self.input_pos.append(tok.where)

    def build(self, builder: ProgramBuilder) -> int:
        ids, pos = self.ids, self.input_pos
        spec, tok = self.spec, self.tok
        if tok.name != spec.name and spec.original_order is not None:
            ids, pos = list(ids), list(pos)
            for original_pos, ours in enumerate(spec.original_order):
                ids[ours], pos[ours] = self.ids[original_pos], self.input_pos[original_pos]
        if len(self.sides) != len(spec.side_inputs):
            raise arity_error(spec, self.n_inputs + len(self.sides), tok.where)
        return builder.call(spec, ids, self.sides, tok.where, pos, self.side_pos)


def check_tokens(tokens: Sequence[str] | str, order: TokenOrder = "prefix") -> CheckedProgram:
    """Check a token sequence (a list of strings, or one whitespace-separated string) into canonical nodes."""
    if order not in ORDERS:
        raise TokenError(f"token order must be 'prefix' or 'postfix', not {order!r}")
    words = _split(tokens)
    if not words:
        raise TokenError("the token sequence is empty: a program needs at least one module token")
    fast = _fast_read(words, order == "prefix")
    if fast is not None:
        return fast
    builder = ProgramBuilder()
    sources: list[int] = []
    toks = (_Token(k, w) for k, w in enumerate(words))
    root = _read_prefix(builder, toks, sources, len(words)) if order == "prefix" else \
        _read_postfix(builder, toks, sources)
    if builder.nodes[root][0] is None:
        raise TokenError("a program must contain a module; a lone value is not a program")
    return builder.finish(root, sources)


def _read_prefix(builder: ProgramBuilder, toks: Iterator[_Token], sources: list[int], n: int) -> int:
    stack: list[_Open] = []
    root: int | None = None
    for tok in toks:
        if root is not None:
            raise TokenError(f"unexpected token {tok.text!r} after the complete program (it ends at token "
                             f"{tok.index - 1}; one token too many, or a missing argument earlier?)",
                             location=f"token {tok.index}", index=tok.index)
        if tok.spec is None:
            if not stack:
                raise TokenError(f"a prefix program starts with a module, not the value {tok.text!r}",
                                 location=f"token {tok.index}", index=tok.index)
            stack[-1].add_value(builder, tok)
        else:
            sources.append(-1)
            stack.append(_Open(tok, len(sources) - 1))
        while stack and stack[-1].filled == stack[-1].n_args:
            done = stack.pop()
            nid = done.build(builder)
            sources[done.source] = nid
            if stack:
                stack[-1].add_node(nid, done.tok)
            else:
                root = nid
    if root is None:
        top = stack[-1] if stack else None
        what = f"{top.spec.name} (token {top.tok.index}) still needs {top.n_args - top.filled} more argument(s)" \
            if top else "no module"
        raise TokenError(f"the tokens end too early: {what}", location=f"token {n}", index=n)
    return root


def _read_postfix(builder: ProgramBuilder, toks: Iterator[_Token], sources: list[int]) -> int:
    items: list[tuple[_Token, int | None]] = []  # (token, node) with node None for a value token
    last = -1
    for tok in toks:
        last = tok.index
        if tok.spec is None:
            items.append((tok, None))
            continue
        frame = _Open(tok, len(sources))
        sources.append(-1)
        if len(items) < frame.n_args:
            raise TokenError(f"{frame.spec.name} takes {frame.n_args} argument(s) but only {len(items)} "
                             "come before it (postfix order writes the arguments first)",
                             location=f"token {tok.index}", index=tok.index)
        args = items[len(items) - frame.n_args:] if frame.n_args else []
        del items[len(items) - frame.n_args:]
        for arg_tok, nid in args:
            if nid is None:
                frame.add_value(builder, arg_tok)
            else:
                frame.add_node(nid, arg_tok)
        nid = frame.build(builder)
        sources[frame.source] = nid
        items.append((tok, nid))
    if len(items) != 1 or items[0][1] is None:
        if items and items[-1][1] is None:
            raise TokenError(f"a postfix program ends with a module, not the value {items[-1][0].text!r}",
                             location=f"token {last}", index=last)
        raise TokenError(f"the tokens leave {len(items)} separate expressions; a program is one expression "
                         "(a missing module at the end, or extra tokens?)", location=f"token {last}", index=last)
    root = items[0][1]
    assert root is not None
    return root


# -- the fast path -------------------------------------------------------------------------------------------
#
# Well-formed sequences of exact token spellings (what models emit) are read with one table lookup per token;
# anything else (integers, other spellings, every error) goes through the readers above, which decide and word
# the errors. The tests check both ways give the same programs.

#: What an exact token spelling is: a value word (the word itself), or a module as (spec, whether its inputs come
#: in the original name's order, the side inputs fused into the token as ``name[value]`` or None).
TokenKind = tuple[ModuleSpec, bool, tuple[str, ...] | None] | str
_KINDS: dict[str, TokenKind] = {}


def token_kinds() -> dict[str, TokenKind]:
    """Every exact token spelling (module names canonical and original, fused ``name[value]`` tokens, value
    words) and what it is (see :data:`TokenKind`); other spellings are read by the general token reader."""
    if not _KINDS:
        for name, spec in NAMES.items():
            reorder = name != spec.name and spec.original_order is not None
            _KINDS[name] = (spec, reorder, None)
            if spec.side_inputs:
                (side,) = spec.side_inputs
                for value in VOCABULARY[side]:
                    _KINDS[f"{name}[{value}]"] = (spec, reorder, (value,))
        for words in VOCABULARY.values():
            _KINDS.update({w: w for w in words})
    return _KINDS


def _fast_read(words: list[str], prefix: bool) -> CheckedProgram | None:
    kinds = _KINDS or token_kinds()
    builder = ProgramBuilder()
    sources: list[int] = []
    frames: list[list[Any]] = []  # open calls (prefix order), see _open
    items: list[int | str] = []  # finished operands: node indexes or values
    try:
        for word in words:
            kind = kinds.get(word)
            if kind is None:
                return None
            if isinstance(kind, str):
                if not prefix:
                    items.append(kind)
                    continue
                if not frames or not _give(builder, frames[-1], kind):
                    return None
            else:
                sources.append(-1)
                frame = _open(kind, len(sources) - 1)
                if prefix:
                    frames.append(frame)
                else:
                    n_args = frame[5]
                    if len(items) < n_args:
                        return None
                    for arg in items[len(items) - n_args:]:
                        if not _give(builder, frame, arg):
                            return None
                    del items[len(items) - n_args:]
                    items.append(_build(builder, frame, sources))
                    continue
            while frames and frames[-1][6] == frames[-1][5]:
                node = _build(builder, frames.pop(), sources)
                if not frames:
                    items.append(node)
                elif not _give(builder, frames[-1], node):
                    return None
        if frames or len(items) != 1 or not isinstance(items[0], int):
            return None
        return builder.finish(items[0], sources)
    except ProgramError:
        return None


def _open(kind: tuple[ModuleSpec, bool, tuple[str, ...] | None], source: int) -> list[Any]:
    """An open call: [spec, reorder, input nodes, side values, source index, arguments expected, received]."""
    spec, reorder, fused = kind
    n_args = spec.n_inputs + (0 if fused else len(spec.side_inputs))
    return [spec, reorder, [], list(fused) if fused else [], source, n_args, 0]


def _give(builder: ProgramBuilder, frame: list[Any], arg: int | str) -> bool:
    """Add an argument to an open call; False where it does not fit (the full reader words the error)."""
    spec, k, n_args = frame[0], frame[6], frame[5]
    if k >= n_args:
        return False
    if k < spec.n_inputs:
        frame[2].append(arg if isinstance(arg, int) else builder.input_literal(spec, k, arg, None))
    elif isinstance(arg, int):
        return False
    else:
        frame[3].append(arg)
    frame[6] = k + 1
    return True


def _build(builder: ProgramBuilder, frame: list[Any], sources: list[int]) -> int:
    spec, reorder, ids, sides, source = frame[:5]
    if reorder:
        ids = [ids[j] for j in ORIGINAL_TO_OURS[spec.name]]
    node = builder.call(spec, ids, sides)
    sources[source] = node
    return node


#: Per module with an original argument order: ``ours[k] = original[ORIGINAL_TO_OURS[name][k]]``.
ORIGINAL_TO_OURS: dict[str, list[int]] = {}
for _spec in MODULES:
    if _spec.original_order is not None:
        _inverse = [0] * len(_spec.original_order)
        for _original_pos, _ours in enumerate(_spec.original_order):
            _inverse[_ours] = _original_pos
        ORIGINAL_TO_OURS[_spec.name] = _inverse


# -- vocabularies -------------------------------------------------------------------------------------------


def program_vocabulary(names: NameStyle = "canonical", fused: bool = False) -> list[str]:
    """Every token a program can contain: module names (with their side inputs when ``fused``), then colours,
    shapes and sizes (not when fused: they are inside the module tokens), then integer literals."""
    out: list[str] = []
    for spec in MODULES:
        heads = [spec.name] if names == "canonical" else list(dict.fromkeys(
            ov.original for ov in spec.overloads if ov.original is not None))
        for head in heads:
            if fused and spec.side_inputs:
                (side,) = spec.side_inputs
                out += [f"{head}[{v}]" for v in VOCABULARY[side]]
            else:
                out.append(head)
    # Values are tokens in the fused style too: one can stand in an input position (EqualColor's second).
    out += [w for words in VOCABULARY.values() for w in words]
    out += list(VOCABULARY_INTEGERS)
    return list(dict.fromkeys(out))


def describe_error(err: ProgramError) -> dict[str, Any]:
    """A JSON-ready description of a program error (kind, message, where)."""
    kind = type(err).__name__
    out: dict[str, Any] = {"error": kind, "message": err.message, "location": err.location}
    for attr in ("line", "column", "index", "module", "argument", "expected", "found"):
        value = getattr(err, attr, None)
        if value is not None:
            out[attr] = list(value) if isinstance(value, tuple) else value
    return out
