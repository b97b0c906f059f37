"""A reader of the canonical program text for tests: which modules and overloads a program uses, its inlined
form, and other spellings of the same program. It reads only ``str(program)`` and the registry, so the tests
that use it do not depend on the Program's internals."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

from craft_dsl import REGISTRY, DslType, Program
from craft_dsl.types import SIDE_INPUT_TYPES

_TOKEN = re.compile(r'\s*(?:(?P<var>Var\b)|(?P<name>[A-Za-z_]\w*)|(?P<int>-?\d+)|"(?P<word>[^"]*)"|(?P<punct>[(),=]))')


@dataclass(frozen=True)
class Node:
    """One node of a canonical program: a call, an integer or quoted literal, or a Var reference."""

    kind: str  # "call", "int", "word" or "ref"
    value: str
    args: tuple[Node, ...] = ()


@dataclass(frozen=True)
class Text:
    bindings: tuple[tuple[str, Node], ...]
    body: Node


def read(text: str) -> Text:
    """The bindings and body of a program's canonical text."""
    tokens: list[tuple[str, str]] = []
    pos = 0
    text = text.strip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        assert m is not None and m.end() > pos, f"cannot read {text[pos:pos + 20]!r}"
        kind = next(k for k, v in m.groupdict().items() if v is not None)
        tokens.append((kind, m.group(kind)))
        pos = m.end()
    at = 0

    def take(kind: str, value: str | None = None) -> str:
        nonlocal at
        k, v = tokens[at]
        assert k == kind and (value is None or v == value), (tokens[at], kind, value)
        at += 1
        return v

    def expr() -> Node:
        nonlocal at
        kind, value = tokens[at]
        at += 1
        if kind in ("int", "word"):
            return Node(kind, value)
        assert kind == "name", (kind, value)
        if at < len(tokens) and tokens[at] == ("punct", "("):
            at += 1
            args: list[Node] = []
            while tokens[at] != ("punct", ")"):
                if args:
                    take("punct", ",")
                args.append(expr())
            at += 1
            return Node("call", value, tuple(args))
        return Node("ref", value)

    bindings = []
    while tokens[at][0] == "var":
        at += 1
        name = take("name")
        take("punct", "=")
        bindings.append((name, expr()))
    body = expr()
    assert at == len(tokens), tokens[at:]
    return Text(tuple(bindings), body)


def overloads_used(program: Program) -> set[tuple[str, int]]:
    """(module, overload index) of every call of the program, found from the argument types."""
    text = read(str(program))
    env: dict[str, DslType] = {}
    used: set[tuple[str, int]] = set()

    def type_of(node: Node, expected: DslType | None) -> DslType:
        if node.kind == "int":
            return DslType.INTEGER
        if node.kind == "word":
            assert expected in SIDE_INPUT_TYPES, node
            return expected
        if node.kind == "ref":
            return env[node.value]
        spec = REGISTRY[node.value]
        n_inputs = len(spec.overloads[0].inputs)
        candidates = [{ov.inputs[i] for ov in spec.overloads} for i in range(n_inputs)]
        found = tuple(type_of(a, next(iter(c)) if len(c) == 1 else None)
                      for a, c in zip(node.args[:n_inputs], candidates))
        (index,) = [k for k, ov in enumerate(spec.overloads) if ov.inputs == found]
        used.add((spec.name, index))
        return spec.overloads[index].output

    for name, expr in text.bindings:
        env[name] = type_of(expr, None)
    assert type_of(text.body, None) is program.type
    return used


def format_node(node: Node) -> str:
    if node.kind == "call":
        return f"{node.value}({', '.join(format_node(a) for a in node.args)})"
    return f'"{node.value}"' if node.kind == "word" else node.value


def inlined(program: Program) -> Program:
    """The same program with every Var reference replaced by its expression."""
    text = read(str(program))
    env: dict[str, Node] = {}

    def inline(node: Node) -> Node:
        if node.kind == "ref":
            return env[node.value]
        if node.kind == "call":
            return Node("call", node.value, tuple(inline(a) for a in node.args))
        return node

    for name, expr in text.bindings:
        env[name] = inline(expr)
    return Program.parse(format_node(inline(text.body)))


def respelled(program: Program, choose: Callable[[list[str]], str]) -> str:
    """Another text of the same program: each module name, value, letter case, quote and Unique chosen by
    ``choose`` among the spellings the language accepts (original names, synonyms, typographic quotes, the
    implicit Unique of an object set where one Object is expected)."""
    from craft_dsl.vocabulary import VALUE_ALIASES

    synonyms: dict[str, list[str]] = {}
    for alias, value in VALUE_ALIASES.items():
        synonyms.setdefault(value, [value]).append(alias)
    text = read(str(program))

    def word(value: str) -> str:
        spelled = choose(synonyms.get(value, [value]))
        spelled = choose([spelled, spelled.upper(), spelled.title()])
        return choose(['"{}"', "\u201c{}\u201d"]).format(spelled)

    def spell(node: Node, under_call: bool) -> str:
        if node.kind == "word":
            return word(node.value)
        if node.kind != "call":
            return node.value
        if node.value == "Unique" and under_call and choose(["explicit", "implicit"]) == "implicit":
            return spell(node.args[0], True)  # the checker puts Unique back
        spec = REGISTRY[node.value]
        name = choose([spec.name, *spec.aliases])
        return f"{name}(" + choose([", ", ",", " , "]).join(spell(a, True) for a in node.args) + ")"

    lines = [f"Var {name} = {spell(expr, False)}" for name, expr in text.bindings]
    return "\n".join([*lines, spell(text.body, False)])
