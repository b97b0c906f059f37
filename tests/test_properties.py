"""Property tests (hypothesis) on random well-typed programs generated from the module registry.

The strategy :func:`expressions` builds a random, depth-bounded expression tree of a requested type from
MODULES' overloads and side-input vocabularies (with random letter case and the accepted synonyms, Vars
referring to earlier bindings, and ObjectSet expressions standing where one Object is expected, for the
checker to wrap in Unique). Laws checked:

1. parse(str(p)) == p and the printed form is stable;
2. set laws of Intersect / Union / Difference, and ascending results;
3. soundness of the type checker: a run returns INVALID or a value of the declared type (every node of
   the trace too), and raises nothing but CounterfactualUnavailable / EvaluationError;
4. Program.from_nodes(p.to_nodes()) == p for programs without integer literals;
5. the last trace entry's value is run()'s answer.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import (
    INVALID,
    MODULES,
    CounterfactualUnavailable,
    DslType,
    EvaluationError,
    Event,
    Program,
    Simulation,
    parse,
)
from craft_dsl.checker import VOCABULARY
from craft_dsl.parser import parse_expr
from craft_dsl.program import to_json
from craft_dsl.registry import ModuleSpec, Overload
from craft_dsl.syntax import Binding, Call, Expr, Literal, Ref, Tree
from craft_dsl.vocabulary import COLORS, SHAPES, SIZES, STATIC_COLOR, STATIC_SHAPES, VALUE_ALIASES
from tests.conftest import E1_PATH, make_sim

T = DslType
SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# -- the program generator -------------------------------------------------------------------------------

Production = tuple[ModuleSpec, Overload]
PRODUCERS: dict[DslType, list[Production]] = {}
for _spec in MODULES:
    for _ov in _spec.overloads:
        PRODUCERS.setdefault(_ov.output, []).append((_spec, _ov))

COUNTERFACTUAL = frozenset({"GetCounterfactEvents", "GetCounterfactEventsList"})


def _min_depths() -> dict[DslType, int]:
    """Smallest tree depth that yields each type (a call without inputs has depth 0)."""
    depth: dict[DslType, int] = {}
    changed = True
    while changed:
        changed = False
        for out, prods in PRODUCERS.items():
            for _, ov in prods:
                if all(t in depth for t in ov.inputs):
                    d = 1 + max((depth[t] for t in ov.inputs), default=-1)
                    if d < depth.get(out, 10**9):
                        depth[out] = d
                        changed = True
    return depth


MIN_DEPTH = _min_depths()
GENERATED_TYPES = sorted(MIN_DEPTH, key=str)
SYNONYMS: dict[DslType, list[str]] = {
    typ: list(VOCABULARY[typ]) + [a for a, v in VALUE_ALIASES.items() if v in VOCABULARY[typ]] for typ in VOCABULARY
}


@dataclass(frozen=True)
class Options:
    literals: bool = True  # integer literals where an Integer is expected
    counterfactuals: bool = True
    unique_insertion: bool = True  # ObjectSet expressions where one Object is expected
    integers: bool = True  # Integer-valued calls other than StartSceneStep / EndSceneStep


def _feasible(ov: Overload, depth: int) -> bool:
    return not ov.inputs or all(MIN_DEPTH[t] <= depth - 1 for t in ov.inputs)


@st.composite
def expressions(draw: st.DrawFn, typ: DslType, depth: int, env: tuple[tuple[str, DslType], ...] = (),
                opts: Options = Options(), top: bool = False) -> Expr:
    """A random well-typed expression of type ``typ`` (depth-bounded)."""
    # at the top of a program or binding, an ObjectSet would not become an Object: no implicit Unique there
    insert_unique = opts.unique_insertion and typ is T.OBJECT and not top
    refs = [name for name, t in env if t == typ or (insert_unique and t is T.OBJECT_SET)]
    prods = [(s, ov) for s, ov in PRODUCERS.get(typ, [])
             if _feasible(ov, depth) and (opts.counterfactuals or s.name not in COUNTERFACTUAL)
             and (opts.integers or typ is not T.INTEGER or s.name in ("StartSceneStep", "EndSceneStep"))]
    kinds = ["call"] * 3 if prods else []
    if refs:
        kinds.append("ref")
    if typ is T.INTEGER and opts.literals and not top:
        kinds.append("literal")
    if insert_unique and MIN_DEPTH[T.OBJECT_SET] <= depth:
        kinds.append("set")
    kind = draw(st.sampled_from(kinds))
    if kind == "ref":
        return Ref(draw(st.sampled_from(refs)))
    if kind == "literal":
        return Literal(draw(st.integers(-3, 3)))
    if kind == "set":  # the paper's convention: the checker inserts Unique
        return draw(expressions(T.OBJECT_SET, depth, env, opts))
    spec, ov = draw(st.sampled_from(prods))
    args: list[Expr] = [draw(expressions(t, depth - 1, env, opts)) for t in ov.inputs]
    for side in spec.side_inputs:
        word = draw(st.sampled_from(SYNONYMS[side]))
        case: Callable[[str], str] = draw(st.sampled_from([str.lower, str.upper, str.title]))
        args.append(Literal(case(word)))
    return Call(draw(st.sampled_from([spec.name, *spec.aliases])), tuple(args))


@st.composite
def trees(draw: st.DrawFn, typ: DslType | None = None, depth: int = 4, bindings: bool = True,
          opts: Options = Options()) -> Tree:
    """A random program: up to two Var bindings, then a final call (never a bare literal)."""
    env: list[tuple[str, DslType]] = []
    binds: list[Binding] = []
    for k in range(draw(st.integers(0, 2)) if bindings else 0):
        btype = draw(st.sampled_from(GENERATED_TYPES))
        depth_k = draw(st.integers(MIN_DEPTH[btype], max(MIN_DEPTH[btype], depth - 1)))
        binds.append(Binding(f"V{k}", draw(expressions(btype, depth_k, tuple(env), opts, top=True))))
        env.append((f"V{k}", btype))
    typ = typ if typ is not None else draw(st.sampled_from(GENERATED_TYPES))
    body = draw(expressions(typ, max(depth, MIN_DEPTH[typ]), tuple(env), opts, top=True))
    return Tree(tuple(binds), body)


def programs(**kw: Any) -> st.SearchStrategy[Program]:
    return trees(**kw).map(Program)


# -- random simulations --------------------------------------------------------------------------------------

VELOCITIES = [0.0, 0.0005, 0.001, -0.001, 0.0011, -0.0011, -0.002, 1.5, -3.0]
STATIC_EXTRAS = ["platform", "ramp", "static_ball", "wall_l", "wall_r"]
EVENT_TYPES = ["Collision", "Collision", "TouchStart", "TouchEnd", "EnterBasket"]


@st.composite
def simulations(draw: st.DrawFn) -> Simulation:
    """A random hand-made scene with ties, re-entries, static partners and a counterfactual per dynamic object."""
    triples = draw(st.lists(st.tuples(st.sampled_from(SIZES), st.sampled_from(COLORS), st.sampled_from(SHAPES)),
                            max_size=4, unique=True))
    statics = ["ground", "basket", *draw(st.lists(st.sampled_from(STATIC_EXTRAS), max_size=2, unique=True))]
    ids = draw(st.permutations(list(range(len(triples) + len(statics)))))
    velocity = st.tuples(st.sampled_from(VELOCITIES), st.sampled_from(VELOCITIES))
    objects: list[tuple[Any, ...]] = []
    for oid, (size, color, shape) in zip(ids, triples):
        objects.append((oid, f"{size} {color} {shape}", draw(velocity), draw(velocity)))
    for oid, shape in zip(ids[len(triples):], statics):
        objects.append((oid, shape))
    dynamic = list(ids[:len(triples)])
    basket = ids[len(triples) + 1]
    everyone = list(ids)

    def events(pool: list[int], n_max: int) -> list[tuple[Any, ...]]:
        out: list[tuple[Any, ...]] = []
        movers = [o for o in dynamic if o in pool]
        for _ in range(draw(st.integers(0, n_max))):
            step = draw(st.sampled_from([0, 10, 10, 20, 30, 40]))  # few steps: many ties
            etype = draw(st.sampled_from(EVENT_TYPES))
            if etype == "EnterBasket":
                if not movers:
                    continue
                out.append((step, etype, basket, draw(st.sampled_from(movers))))
            else:
                a, b = draw(st.lists(st.sampled_from(pool), min_size=2, max_size=2, unique=True))
                out.append((step, etype, a, b))
        return out

    factual = events(everyone, 8)
    counterfactuals = {}
    for removed in dynamic:
        rest = [o for o in everyone if o != removed]
        kept = [e for e in factual if removed not in e[2:] and draw(st.booleans())]
        counterfactuals[removed] = sorted(kept + events(rest, 3), key=lambda e: e[0])
    return make_sim(objects, factual, counterfactuals)


E1: Simulation | None = None


def e1() -> Simulation:
    global E1
    if E1 is None:
        from craft_dsl import load_simulation

        E1 = load_simulation(E1_PATH)
    return E1


# -- value conformance ------------------------------------------------------------------------------------------


def _ascending_ids(value: Any, sim: Simulation) -> bool:
    return (isinstance(value, tuple) and all(type(o) is int and sim.has_object(o) for o in value)
            and all(a < b for a, b in zip(value, value[1:])))


def _event_set(value: Any) -> bool:
    return (isinstance(value, tuple) and all(isinstance(e, Event) for e in value)
            and [(e.step, e.id) for e in value] == sorted((e.step, e.id) for e in value)
            and len({e.id for e in value}) == len(value))


def conforms(value: Any, typ: DslType, sim: Simulation) -> bool:
    """Whether ``value`` is INVALID or a value of DSL type ``typ`` over ``sim``."""
    if value is INVALID:
        return True
    checks: dict[DslType, Callable[[Any], bool]] = {
        T.BOOL: lambda v: type(v) is bool,
        T.INTEGER: lambda v: type(v) is int,
        T.COLOR: lambda v: v in COLORS or v == STATIC_COLOR,
        T.SHAPE: lambda v: v in SHAPES or v in STATIC_SHAPES,
        T.SIZE: lambda v: v in SIZES,
        T.OBJECT: lambda v: type(v) is int and sim.has_object(v),
        T.OBJECT_SET: lambda v: _ascending_ids(v, sim),
        T.EVENT: lambda v: isinstance(v, Event),
        T.EVENT_SET: _event_set,
        T.OBJECT_SET_LIST: lambda v: isinstance(v, tuple) and all(_ascending_ids(s, sim) for s in v),
        T.EVENT_SET_LIST: lambda v: isinstance(v, tuple) and all(_event_set(s) for s in v),
        T.BOOL_LIST: lambda v: isinstance(v, tuple) and all(type(b) is bool for b in v),
    }
    return checks[typ](value)


ALLOWED_ERRORS = (CounterfactualUnavailable, EvaluationError)


def _same(a: Any, b: Any) -> bool:
    return a is b if a is INVALID or b is INVALID else bool(a == b)


def _check_run(p: Program, sim: Simulation) -> None:
    try:
        answer = p.run(sim)
    except ALLOWED_ERRORS:
        with pytest.raises(ALLOWED_ERRORS):
            p.trace(sim)
        return
    assert conforms(answer, p.type, sim), (str(p), answer)
    trace = p.trace(sim)
    for entry in trace:
        assert conforms(entry.value, entry.type, sim), (entry.expression, entry.type, entry.value)
    body = _inline(p.tree).body
    if isinstance(body, Literal):  # e.g. "Var V0 = 3  V0": a constant, no node is evaluated
        assert answer == body.value
        return
    assert trace, str(p)
    assert _same(trace[-1].value, answer), (str(p), trace[-1].value, answer)
    assert trace[-1].type == p.type


# -- 1. round trip of the text form --------------------------------------------------------------------------


def test_generator_covers_every_module() -> None:
    produced = {spec.name for prods in PRODUCERS.values() for spec, _ in prods}
    assert produced == {m.name for m in MODULES}
    assert set(GENERATED_TYPES) == set(PRODUCERS)


@SETTINGS
@given(programs())
def test_text_round_trip(p: Program) -> None:
    text = str(p)
    q = parse(text)
    assert q == p
    assert str(q) == text
    assert q.type == p.type
    assert hash(q) == hash(p)


# -- 2. set laws ----------------------------------------------------------------------------------------------

# no counterfactuals (static objects have none) and only valid state indexes: every operand evaluates
SET_OPTS = Options(literals=False, counterfactuals=False, integers=False)


@SETTINGS
@given(simulations(), st.data())
def test_set_laws(sim: Simulation, data: st.DataObject) -> None:
    sets = [data.draw(expressions(T.OBJECT_SET, data.draw(st.integers(0, 3)), (), SET_OPTS)) for _ in range(3)]
    binds = tuple(Binding(n, e) for n, e in zip("ABC", sets))

    def value(body: str) -> Any:
        p = Program(Tree(binds, parse_expr(body)))
        return p.run(sim)

    a, b, c = value("A"), value("B"), value("C")
    for v in (a, b, c):
        assert conforms(v, T.OBJECT_SET, sim)

    operand = {"A": a, "B": b, "C": c}

    def law(left: str, right: str, operands: tuple[Any, ...], expected: Any = None) -> None:
        values = []
        for side in (left, right):
            v = value(side)
            names = set(re.findall(r"\b[ABC]\b", side))
            if any(operand[n] is INVALID for n in names):
                assert v is INVALID, (side, v)  # INVALID in, INVALID out
            else:
                assert _ascending_ids(v, sim), (side, v)
            values.append(v)
        if all(o is not INVALID for o in operands):
            assert values[0] == values[1], (left, right, values)
            if expected is not None:
                assert values[0] == expected, (left, values[0], expected)

    def ascending(s: set[int]) -> tuple[int, ...]:
        return tuple(sorted(s))

    valid = a is not INVALID and b is not INVALID and c is not INVALID
    law("Intersect(A, B)", "Intersect(B, A)", (a, b), ascending(set(a) & set(b)) if valid else None)
    law("Union(A, B)", "Union(B, A)", (a, b), ascending(set(a) | set(b)) if valid else None)
    law("Difference(A, B)", "Difference(A, Intersect(A, B))", (a, b), ascending(set(a) - set(b)) if valid else None)
    law("Intersect(Intersect(A, B), C)", "Intersect(A, Intersect(B, C))", (a, b, c))
    law("Union(Union(A, B), C)", "Union(A, Union(B, C))", (a, b, c))
    law("Difference(A, A)", "Difference(A, Union(A, A))", (a,), ())
    law("Intersect(A, Difference(B, A))", "Difference(Intersect(B, A), A)", (a, b), ())
    law("Union(Difference(A, B), Intersect(A, B))", "A", (a, b), a if valid else None)
    law("Union(A, A)", "Intersect(A, A)", (a,), a if valid else None)
    law("Intersect(A, Union(B, C))", "Union(Intersect(A, B), Intersect(A, C))", (a, b, c))


# -- 3. soundness of the type checker (and 5. trace) --------------------------------------------------------------


@SETTINGS
@given(programs())
def test_well_typed_programs_run_soundly_on_e1(p: Program) -> None:
    _check_run(p, e1())


@SETTINGS
@given(simulations(), st.data())
def test_well_typed_programs_run_soundly_on_random_scenes(sim: Simulation, data: st.DataObject) -> None:
    p = data.draw(programs())
    _check_run(p, sim)


@settings(max_examples=100, deadline=None)
@given(st.sampled_from([t for t in GENERATED_TYPES if t is not T.BOOL]), st.data())
def test_programs_of_each_declared_type(typ: DslType, data: st.DataObject) -> None:
    p = data.draw(programs(typ=typ, depth=3))
    assert p.type is typ
    _check_run(p, e1())


# -- 4. node lists ----------------------------------------------------------------------------------------------

NODE_OPTS = Options(literals=False)


def _inline(tree: Tree) -> Tree:
    env = {b.name: b.expr for b in tree.bindings}

    def go(e: Expr) -> Expr:
        if isinstance(e, Ref):
            return go(env[e.name])
        if isinstance(e, Call):
            return Call(e.module, tuple(go(a) for a in e.args))
        return e

    return Tree((), go(tree.body))


@SETTINGS
@given(programs(bindings=False, opts=NODE_OPTS))
def test_node_list_round_trip(p: Program) -> None:
    nodes = p.to_nodes()
    assert Program.from_nodes(nodes) == p
    # every node names an original module and only earlier nodes
    for k, node in enumerate(nodes):
        assert node["type"][0].islower()
        assert all(0 <= i < k for i in node["inputs"])


@SETTINGS
@given(programs(opts=NODE_OPTS))
def test_node_list_of_a_program_with_bindings_is_its_inlined_form(p: Program) -> None:
    assert Program.from_nodes(p.to_nodes()) == Program(_inline(p.tree))


@settings(max_examples=60, deadline=None)
@given(programs(bindings=False, opts=NODE_OPTS))
def test_node_outputs_end_with_the_answer(p: Program) -> None:
    sim = e1()
    try:
        answer = p.run(sim)
    except ALLOWED_ERRORS:
        return
    nodes = p.to_nodes(outputs=sim)
    assert nodes[-1]["_output"] == to_json(answer, original=True)
