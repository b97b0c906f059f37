"""Hypothesis strategies for hostile input: program text (valid, near-valid, garbage, deep, huge numbers), JSON
documents and texts, mutations of valid files, and the check every fuzz test makes of what was raised.

Private to the fuzz tests (the public strategies of craft_dsl are another module); written for breadth of
hostility rather than for shrinking to the prettiest example.
"""

from __future__ import annotations

import codecs
import copy
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from craft_dsl import CraftError
from craft_dsl.checker import VOCABULARY
from craft_dsl.registry import MODULES
from craft_dsl.types import DslType

#: The longest message an error may have: a message quotes the input, it must not echo a whole file.
MAX_MESSAGE = 2000


def expect_only_craft_errors(action: Callable[[], Any], *must_name: str) -> Any:
    """Run ``action``; a CraftError is the only exception allowed (anything else fails the test). A CraftError
    must say something short on one line that names each of ``must_name`` (the file, say). Returns the result
    or the error."""
    try:
        return action()
    except CraftError as err:
        message = str(err)
        assert message.strip(), f"{type(err).__name__} without a message"
        assert len(message) <= MAX_MESSAGE, f"{type(err).__name__} message of {len(message)} characters"
        assert "\n" not in message or type(err).__name__ == "SceneFileError", f"multi-line message: {message!r}"
        for name in must_name:
            assert name in message, f"{message!r} does not name {name!r}"
        return err


# -- scalars and JSON --------------------------------------------------------------------------------------------

HUGE_DIGITS = st.integers(min_value=19, max_value=6000)


def huge_integers() -> st.SearchStrategy[int]:
    """Integers just beyond 64 bits up to 6,000 digits (Python's text conversion stops at 4,300)."""
    return st.one_of(st.sampled_from([2**63, -(2**63) - 1, 2**64]),
                     st.builds(lambda n, sign: sign * 10**n - sign, HUGE_DIGITS, st.sampled_from([1, -1])))


def hostile_scalars() -> st.SearchStrategy[Any]:
    return st.one_of(
        st.none(), st.booleans(), st.integers(-(2**70), 2**70), huge_integers(),
        st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([math.nan, math.inf, -math.inf, -0.0, 1e308]),
        st.text(max_size=30), st.sampled_from(["", " ", "red", "Red", "cube", "99999999999999999999999", "1e999",
                                               "NaN", "-1", "0", "\u0000", "\ud800", "\u202e", "ünï", "a" * 5000]),
    )


def json_values(max_leaves: int = 20) -> st.SearchStrategy[Any]:
    return st.recursive(hostile_scalars(),
                        lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                st.dictionaries(st.text(max_size=8), inner, max_size=4)),
                        max_leaves=max_leaves)


def deep_json(max_depth: int = 3000) -> st.SearchStrategy[str]:
    """Text of JSON nested up to ``max_depth`` levels (lists, objects or both)."""
    def build(depth: int, kind: str) -> str:
        if kind == "list":
            return "[" * depth + "1" + "]" * depth
        if kind == "object":
            return '{"a": ' * depth + "1" + "}" * depth
        return '[{"a": ' * (depth // 2) + "1" + "}]" * (depth // 2)
    return st.builds(build, st.integers(0, max_depth), st.sampled_from(["list", "object", "mixed"]))


@st.composite
def json_texts(draw: st.DrawFn, value: Any = None) -> str:
    """JSON text, often broken: a hostile document, then text mutations (repeated keys, NaN, huge numbers,
    deep nesting, truncation, stray characters)."""
    doc = value if value is not None else draw(json_values())
    try:
        text = json.dumps(doc, ensure_ascii=draw(st.booleans()))
    except ValueError:  # an integer beyond Python's text conversion
        text = "0"
    for _ in range(draw(st.integers(0, 3))):
        text = draw(text_mutations(text))
    return text


@st.composite
def text_mutations(draw: st.DrawFn, text: str) -> str:
    """One change to a text: truncate, delete, insert, duplicate, nest, or splice in a hostile token."""
    n = len(text)
    at = draw(st.integers(0, n))
    kind = draw(st.sampled_from(["truncate", "delete", "insert", "token", "duplicate", "nest", "swap"]))
    if kind == "truncate":
        return text[:at]
    if kind == "delete":
        return text[:at] + text[at + draw(st.integers(1, 5)):]
    if kind == "insert":
        return text[:at] + draw(st.text(min_size=1, max_size=3)) + text[at:]
    if kind == "token":
        token = draw(st.sampled_from(['NaN', 'Infinity', '-Infinity', '1e999', '-0', '00', '"\\ud800"', '{', '}', '[',
                                      ']', ',', ':', '"a": 1, "a": 2', '"x":', 'true', 'null']))
        if draw(st.booleans()):
            token = draw(st.sampled_from(["", "-"])) + "9" * draw(HUGE_DIGITS)
        return text[:at] + token + text[at:]
    if kind == "duplicate":
        end = draw(st.integers(at, min(n, at + 40)))
        return text[:end] + text[at:end] + text[end:]
    if kind == "nest":
        depth = draw(st.integers(1, 2000))
        return "[" * depth + text + "]" * depth
    other = draw(st.integers(0, n))
    lo, hi = sorted((at, other))
    return text[:lo] + text[hi:] + text[lo:hi]


ENCODINGS = ("utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-32", "latin-1", "cp1252")


@st.composite
def file_bytes(draw: st.DrawFn, text: str) -> bytes:
    """``text`` as the bytes of a file: UTF-8 mostly, else another encoding, a byte-level change or garbage."""
    kind = draw(st.sampled_from(["utf-8", "utf-8", "encoding", "bytes", "garbage"]))
    if kind == "garbage":
        return draw(st.binary(max_size=200))
    if kind == "encoding":
        return text.encode(draw(st.sampled_from(ENCODINGS)), errors="replace")
    data = text.encode("utf-8", errors="surrogatepass")
    if kind == "bytes" and data:
        at = draw(st.integers(0, len(data) - 1))
        data = data[:at] + draw(st.binary(min_size=1, max_size=4)) + data[at + 1:]
    if draw(st.integers(0, 9)) == 0:
        data = codecs.BOM_UTF8 + data
    return data


# -- mutations of valid documents --------------------------------------------------------------------------------


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i))
    return out


@st.composite
def mutated(draw: st.DrawFn, doc: Any, max_changes: int = 3) -> Any:
    """A copy of ``doc`` with 1..max_changes changes at random places: a value replaced by a hostile one (or by
    a deep one), a key removed, renamed or given twice (as a numeric twin), an item dropped or repeated."""
    doc = copy.deepcopy(doc)
    for _ in range(draw(st.integers(1, max_changes))):
        paths = _paths(doc)
        path = draw(st.sampled_from(paths))
        if not path:
            continue
        parent = doc
        for p in path[:-1]:
            parent = parent[p]
        last = path[-1]
        kind = draw(st.sampled_from(["value", "value", "type", "remove", "repeat", "deep", "rename"]))
        if kind == "value":
            parent[last] = draw(hostile_scalars())
        elif kind == "type":
            parent[last] = draw(json_values(max_leaves=4))
        elif kind == "deep":
            parent[last] = json.loads(draw(deep_json(150)))
        elif kind == "remove":
            del parent[last]
        elif kind == "repeat" and isinstance(parent, list):
            parent.insert(last, copy.deepcopy(parent[last]))
        elif kind == "rename" and isinstance(parent, dict):
            parent[draw(st.sampled_from([str(last).upper(), f"{last} ", "", "9" * 30, f"0{last}"]))] = parent.pop(last)
    return doc


def write(path: Path, data: bytes | str) -> Path:
    path.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8", errors="surrogatepass"))
    return path


# -- programs -----------------------------------------------------------------------------------------------------

_PRODUCERS: dict[DslType, list[tuple[str, tuple[DslType, ...], tuple[DslType, ...]]]] = {}
for _spec in MODULES:
    for _ov in _spec.overloads:
        _PRODUCERS.setdefault(_ov.output, []).append((_spec.name, _ov.inputs, _spec.side_inputs))
_LEAVES = {DslType.OBJECT_SET: "SceneAtStart()", DslType.EVENT_SET: "Events()", DslType.INTEGER: "StartSceneStep()",
           DslType.OBJECT: 'FilterShape(SceneAtStart(), "cube")', DslType.EVENT: "FilterFirst(Events())",
           DslType.BOOL: "Exist(Events())", DslType.COLOR: '"red"', DslType.SHAPE: '"cube"', DslType.SIZE: '"small"',
           DslType.EVENT_SET_LIST: "GetCounterfactEventsList(SceneAtStart())",
           DslType.OBJECT_SET_LIST: "FilterObjectsFromEventsList(GetCounterfactEventsList(SceneAtStart()))",
           DslType.BOOL_LIST: "ExistList(GetCounterfactEventsList(SceneAtStart()))"}


@st.composite
def typed_programs(draw: st.DrawFn, typ: DslType | None = None, depth: int = 5) -> str:
    """Text of a well-typed expression of ``typ`` (any answer type by default), built from the registry; quotes,
    spacing and integer literals vary."""
    if typ is None:
        typ = draw(st.sampled_from([DslType.INTEGER, DslType.BOOL, DslType.COLOR, DslType.SHAPE, DslType.SIZE,
                                    DslType.OBJECT_SET, DslType.EVENT_SET]))
    return draw(_expr(typ, depth, top=True))


@st.composite
def _expr(draw: st.DrawFn, typ: DslType, depth: int, top: bool = False) -> str:
    if typ in (DslType.COLOR, DslType.SHAPE, DslType.SIZE) and not top and draw(st.integers(0, 3)) == 0:
        q = draw(st.sampled_from(['"', "\u201c"]))
        return f"{q}{draw(st.sampled_from(VOCABULARY[typ]))}{q}"
    if typ == DslType.INTEGER and not top and draw(st.integers(0, 4)) == 0:  # a lone value is not a program
        return str(draw(st.integers(-3, 12)))
    producers = _PRODUCERS.get(typ, [])
    if depth <= 0 or not producers:
        if typ in _LEAVES:
            return _LEAVES[typ]
        depth = 1
    name, inputs, sides = draw(st.sampled_from(producers))
    if depth <= 0 and inputs:
        return _LEAVES.get(typ, "SceneAtStart()")
    args = [draw(_expr(t, depth - 1)) for t in inputs]
    args += [f'"{draw(st.sampled_from(VOCABULARY[s]))}"' for s in sides]
    sep = draw(st.sampled_from([", ", ",", " , ", ",\n  "]))
    return f"{name}({sep.join(args)})"


@st.composite
def program_texts(draw: st.DrawFn) -> str:
    """Valid programs, sometimes with Var bindings and comments."""
    body = draw(typed_programs())
    if draw(st.booleans()):
        inner = draw(typed_programs(DslType.OBJECT_SET, depth=3))
        body = body.replace("SceneAtStart()", "X", 1)
        return f"# a program\nVar X = {inner}\n{body}" if "X" in body else body
    return body


@st.composite
def near_valid_programs(draw: st.DrawFn) -> str:
    text = draw(program_texts())
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["text", "name", "value", "paren"]))
        if kind == "text":
            text = draw(text_mutations(text))
        elif kind == "name":
            text = text.replace(draw(st.sampled_from([m.name for m in MODULES])),
                                draw(st.sampled_from(["Filtercolor", "filter_color", "X", "Var", "", "9"])), 1)
        elif kind == "value":
            text = text.replace('"', draw(st.sampled_from(['"pink', "'", '"\u201d', ""])), 1)
        else:
            text = text.replace(")", draw(st.sampled_from(["", "))", ")(", ",)"])), 1)
    return text


def garbage_programs() -> st.SearchStrategy[str]:
    words = st.sampled_from([m.name for m in MODULES] + ["(", ")", ",", '"', "Var", "=", "#", "\n", "red", "0", "-"])
    return st.one_of(st.text(max_size=80), st.lists(words, max_size=40).map(" ".join),
                     st.lists(words, max_size=40).map("".join))


@st.composite
def deep_programs(draw: st.DrawFn, max_depth: int = 3000) -> str:
    """A chain of object filters up to ``max_depth`` deep around a valid leaf, sometimes broken at one level."""
    depth = draw(st.integers(1, max_depth) if draw(st.integers(0, 9)) == 0 else st.integers(1, 300))
    wrappers = [("FilterColor(", ', "red")'), ("FilterShape(", ", \u201ccube\u201d)"), ("FilterDynamic(", ")"),
                ("Union(SceneAtStart(), ", ")"), ("FilterMoving(", ", 0)")]
    chosen = draw(st.lists(st.integers(0, len(wrappers) - 1), min_size=1, max_size=8))
    opens = "".join(wrappers[chosen[k % len(chosen)]][0] for k in range(depth))
    closes = "".join(wrappers[chosen[k % len(chosen)]][1] for k in reversed(range(depth)))
    text = f"Count({opens}SceneAtStart(){closes})"
    if draw(st.booleans()):
        text = draw(text_mutations(text))
    return text


@st.composite
def huge_number_programs(draw: st.DrawFn) -> str:
    number = draw(st.sampled_from(["", "-"])) + "9" * draw(st.integers(20, 6000))
    template = draw(st.sampled_from(["EqualInteger(Count(SceneAtStart()), {n})", "FilterMoving(SceneAtStart(), {n})",
                                     "GetCounterfactEvents({n})", "Var X = {n}\nCount(X)", "{n}",
                                     "LessThan({n}, {n})"]))
    return template.format(n=number)


def token_lists() -> st.SearchStrategy[list[str]]:
    vocab = [m.name for m in MODULES] + [f"{m.name}[red]" for m in MODULES[:8]] + ["red", "cube", "small", "0",
                                                                                    "-1", "Unique", "[", "]"]
    tokens = st.one_of(st.sampled_from(vocab), st.text(max_size=6), HUGE_DIGITS.map(lambda n: "9" * n))
    return st.lists(tokens, max_size=30)
