"""Hypothesis strategies for craft_dsl values, for property tests of parsers, executors and models.

>>> from hypothesis import given
>>> from craft_dsl import DslType
>>> from craft_dsl.strategies import programs, simulations
>>> @given(programs(DslType.INTEGER), simulations())
... def test_my_executor(program, sim): ...

* :func:`programs`: well-typed :class:`~craft_dsl.Program` values drawn from the module registry;
* :func:`node_lists`: CLEVR/CRAFT node lists (``Program.to_nodes()``) of well-typed programs;
* :func:`world_specs`: :class:`~craft_dsl.WorldSpec` values of the 20 scene layouts (the seeded sampler);
* :func:`simulations`: small hand-built :class:`~craft_dsl.Simulation` values with counterfactuals
  (hundreds per second), or short live physics runs with ``live=True``;
* :func:`questions`: CRAFT questions (text, template id, parameters, program) rendered by the generator.

Programs are drawn from :data:`craft_dsl.registry.MODULES` and nothing else: a module registered there is
drawn without any change here. Every choice is an index into a list ordered from simple to complex (literals,
then modules without inputs, then modules with fewer inputs), so hypothesis's shrinking of the underlying
choices gives smaller programs of simpler modules. Hypothesis is needed by this module only
(``pip install 'craft-dsl[strategies]'``); the package registers :func:`programs`, :func:`simulations` and
:func:`world_specs` for ``st.from_type`` through hypothesis's entry point (see
:mod:`craft_dsl.hypothesis_hook`).
"""

from __future__ import annotations

try:
    from hypothesis import strategies as st
    from hypothesis.errors import InvalidArgument
except ImportError:  # pragma: no cover - exercised in a subprocess by tests/test_strategies.py
    from .errors import MissingExtraError

    raise MissingExtraError("craft_dsl.strategies", "strategies", "hypothesis") from None

import itertools
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np

from .errors import CounterfactualUnavailable, CraftError
from .program import Program
from .registry import MODULES, lookup
from .scenes import STATIC_ELEMENT_SHAPES, list_scenes, sample_world
from .simulation import Event, ObjectState, SimObject, Simulation
from .types import SIDE_INPUT_TYPES, DslType
from .vocabulary import (
    COLLISION,
    COLLISION_MAX_STEPS,
    COLORS,
    END,
    ENTER_BASKET,
    SHAPES,
    SIZES,
    START,
    STATIC_COLOR,
    STATIC_SIZE,
    TOUCH_END,
    TOUCH_START,
)
from .world import DEFAULT_STEPS, WorldSpec

__all__ = [
    "QuestionRecord",
    "StrategyArgumentError",
    "node_lists",
    "programs",
    "questions",
    "simulations",
    "world_specs",
]

#: The values a side input (and a quoted literal) of each type takes.
VOCABULARY: dict[DslType, tuple[str, ...]] = {DslType.COLOR: COLORS, DslType.SHAPE: SHAPES, DslType.SIZE: SIZES}
#: Integer literals drawn where an Integer is expected (0 and -1 are the start and end state indexes).
INTEGER_LITERALS = st.integers(-3, 3)
#: Largest seed drawn for world specs and question texts.
MAX_SEED = 2**32 - 1


class StrategyArgumentError(CraftError, InvalidArgument):
    """A strategy was called with arguments it cannot honour (the message says what is allowed)."""


# -- the program grammar: productions of the registry ------------------------------------------------------


@dataclass(frozen=True)
class _Production:
    """One overload of one module, with what may stand at each input."""

    module: str
    inputs: tuple[DslType, ...]
    output: DslType
    side_inputs: tuple[DslType, ...]
    #: Per input: "int" (an integer literal may stand there), "word" (a quoted value), or "" (a call only).
    literal_inputs: tuple[str, ...]
    #: Position in the registry (module index, overload index): the tie-breaker of the simple-first order.
    rank: tuple[int, int]


def _literal_kind(spec_inputs: set[DslType]) -> str:
    """What literal the checker accepts at an input whose overloads expect ``spec_inputs``."""
    if spec_inputs == {DslType.INTEGER}:
        return "int"
    if len(spec_inputs) == 1 and next(iter(spec_inputs)) in SIDE_INPUT_TYPES:
        return "word"
    return ""


class _Grammar:
    """The productions of the allowed modules by output type, simple first, and the smallest depth of each.

    Depth counts calls on the longest path from the result to a leaf: ``Events()`` has depth 1,
    ``Count(Events())`` depth 2; a literal argument adds nothing.
    """

    def __init__(self, modules: frozenset[str], literals: bool, node_form: bool) -> None:
        productions: list[_Production] = []
        for m_index, spec in enumerate(MODULES):
            if spec.name not in modules:
                continue
            kinds = tuple(_literal_kind({ov.inputs[i] for ov in spec.overloads}) if literals else ""
                          for i in range(len(spec.overloads[0].inputs)))
            for o_index, ov in enumerate(spec.overloads):
                if node_form and ov.original is None:
                    continue
                productions.append(_Production(spec.name, ov.inputs, ov.output, spec.side_inputs, kinds,
                                               (m_index, o_index)))
        self.call_depth: dict[DslType, int] = {}
        depth_of: dict[_Production, int] = {}
        changed = True
        while changed:  # fixed point: the smallest depth at which each production can be completed
            changed = False
            for p in productions:
                needs = [0 if kind else self.call_depth.get(t) for t, kind in zip(p.inputs, p.literal_inputs)]
                if any(n is None for n in needs):
                    continue
                d = 1 + max((n for n in needs if n is not None), default=0)
                if d < depth_of.get(p, 10**9):
                    depth_of[p] = d
                    changed = True
                if d < self.call_depth.get(p.output, 10**9):
                    self.call_depth[p.output] = d
                    changed = True
        self.depth_of = depth_of
        #: Producible types, simplest first (then in the order DslType declares them).
        self.types: list[DslType] = sorted(self.call_depth, key=lambda t: (self.call_depth[t], list(DslType).index(t)))
        by_type = {t: sorted((p for p in depth_of if p.output is t), key=lambda p: (depth_of[p], len(p.inputs), p.rank))
                   for t in self.types}
        #: Every production. Each type's productions, simplest first (fewer nested calls, then fewer inputs, then
        #: registry order), are spread evenly over the list: the k-th of n stands at k / n of its length. So where
        #: one type is expected, each of its modules takes about as many indices as any other (see choices()), and
        #: a lower index is a simpler module.
        self.order: list[_Production] = sorted(
            (p for ps in by_type.values() for p in ps),
            key=lambda p: (by_type[p.output].index(p) / len(by_type[p.output]), self.types.index(p.output)))
        self._choices: dict[tuple[tuple[DslType, ...], int], tuple[int, tuple[_Production, ...]] | None] = {}

    def choices(self, types: tuple[DslType, ...], budget: int) -> tuple[int, tuple[_Production, ...]] | None:
        """Where an expression of one of ``types`` at most ``budget`` deep is expected: the smallest index into
        :attr:`order` to draw from (the simplest production that fits) and what each index means (that
        production if it fits, else the nearest one before it that fits).

        So the smallest index that gives a production is the production's own index, wherever it stands: once
        hypothesis has lowered every index as far as it goes, it can put an argument in the place of its parent
        (the same index means the same module there), and lowering an index moves to simpler modules.
        None when no production fits (then only a literal can stand there).
        """
        key = (types, budget)
        if key not in self._choices:
            fitting = [k for k, p in enumerate(self.order) if p.output in types and self.depth_of[p] <= budget]
            meaning = tuple(self.order[max((f for f in fitting if f <= k), default=fitting[0])]
                            for k in range(len(self.order))) if fitting else ()
            self._choices[key] = (fitting[0], meaning) if fitting else None
        return self._choices[key]


@lru_cache(maxsize=64)
def _grammar(modules: frozenset[str], literals: bool, node_form: bool) -> _Grammar:
    return _Grammar(modules, literals, node_form)


_ALL_MODULES = frozenset(m.name for m in MODULES)
#: What stands at a position: a literal where one may stand (1 in 5; else a call), a call (3 in 5), or a Var
#: bound earlier and reused (1 in 5; else a call). Drawn at every position, so that every subtree has the same
#: layout of choices; the literal comes first because it is the smallest expression.
_KIND = st.sampled_from(("literal", "call", "call", "reuse", "call"))
#: Whether a call is bound to a Var (1 in 6).
_BIND = st.sampled_from((False, False, False, False, False, True))


@dataclass(frozen=True)
class _Binding:
    name: str
    text: str
    type: DslType
    depth: int


class _ProgramDraw:
    """The state of drawing one program: the Var bindings made so far."""

    def __init__(self, grammar: _Grammar, max_bindings: int) -> None:
        self.grammar = grammar
        self.max_bindings = max_bindings
        self.bindings: list[_Binding] = []

    def expression(self, draw: st.DrawFn, types: tuple[DslType, ...], budget: int,
                   literal: str = "") -> tuple[str, int]:
        """Text and depth of an expression of one of ``types``, at most ``budget`` deep (``literal``: the literal
        that may stand here instead, see :class:`_Production`)."""
        kind = draw(_KIND)
        choices = self.grammar.choices(types, budget)
        if literal and (kind == "literal" or choices is None):
            if literal == "int":
                return str(draw(INTEGER_LITERALS)), 0
            return f'"{draw(st.sampled_from(VOCABULARY[types[0]]))}"', 0
        reusable = [b for b in self.bindings if b.type in types and b.depth <= budget]
        if kind == "reuse" and reusable:
            chosen = reusable[draw(st.integers(0, len(reusable) - 1))]
            return chosen.name, chosen.depth
        assert choices is not None, "the grammar's depths promise a call here"
        first, meaning = choices
        production = meaning[draw(st.integers(first, len(meaning) - 1))]
        text, depth = self.call(draw, production, budget)
        if len(self.bindings) >= self.max_bindings or not draw(_BIND):
            return text, depth
        binding = _Binding(f"V{len(self.bindings)}", text, production.output, depth)
        self.bindings.append(binding)
        return binding.name, depth

    def call(self, draw: st.DrawFn, p: _Production, budget: int) -> tuple[str, int]:
        args: list[str] = []
        depth = 0
        for typ, literal in zip(p.inputs, p.literal_inputs):
            # each argument is a nested draw: hypothesis sees the subtree as one span it can delete, simplify,
            # or put in the place of its parent
            text, d = draw(_expression(self, (typ,), budget - 1, literal))
            args.append(text)
            depth = max(depth, d)
        args.extend(f'"{draw(st.sampled_from(VOCABULARY[t]))}"' for t in p.side_inputs)
        return f"{p.module}({', '.join(args)})", depth + 1

    def program_text(self, draw: st.DrawFn, types: tuple[DslType, ...], max_depth: int) -> str:
        body, _ = draw(_expression(self, types, max_depth, ""))
        lines = [f"Var {b.name} = {b.text}" for b in self.bindings]
        return "\n".join([*lines, body])


@st.composite
def _expression(draw: st.DrawFn, program: _ProgramDraw, types: tuple[DslType, ...], budget: int,
                literal: str) -> tuple[str, int]:
    return program.expression(draw, types, budget, literal)


def _result_types(result_type: DslType | Iterable[DslType] | None, grammar: _Grammar, max_depth: int,
                  what: str) -> list[DslType]:
    if result_type is None:
        wanted = [t for t in grammar.types if grammar.call_depth[t] <= max_depth]
        if not wanted:
            raise StrategyArgumentError(f"{what}: max_depth={max_depth} is too small for any program; "
                                        "use max_depth >= 1")
        return wanted
    wanted = [result_type] if isinstance(result_type, DslType) else list(result_type)
    if not wanted:
        raise StrategyArgumentError(f"{what}: result_type is empty; give a DslType, several, or None (any type)")
    for t in wanted:
        if not isinstance(t, DslType):
            raise StrategyArgumentError(f"{what}: result_type {t!r} is not a DslType; allowed: "
                                        f"{', '.join(str(x) for x in DslType)}")
        if t not in grammar.call_depth:
            raise StrategyArgumentError(f"{what}: no allowed module produces {t}")
        if grammar.call_depth[t] > max_depth:
            raise StrategyArgumentError(f"{what}: a program of type {t} needs max_depth >= {grammar.call_depth[t]}, "
                                        f"got {max_depth}")
    return wanted


def _module_set(modules: Collection[str] | None, what: str) -> frozenset[str]:
    if modules is None:
        return _ALL_MODULES
    if isinstance(modules, str):
        raise StrategyArgumentError(f"{what}: modules must be a collection of module names, not the string "
                                    f"{modules!r}")
    names = set()
    for name in modules:
        spec = lookup(name)
        if spec is None:
            raise StrategyArgumentError(f"{what}: unknown module {name!r}; run `craft-dsl modules` for the list")
        names.add(spec.name)
    return frozenset(names)


def _program_texts(result_type: DslType | Iterable[DslType] | None, max_depth: int, max_bindings: int,
                   literals: bool, modules: Collection[str] | None, node_form: bool,
                   what: str) -> st.SearchStrategy[str]:
    if isinstance(max_depth, bool) or not isinstance(max_depth, int):
        raise StrategyArgumentError(f"{what}: max_depth must be an int, got {max_depth!r}")
    if isinstance(max_bindings, bool) or not isinstance(max_bindings, int) or max_bindings < 0:
        raise StrategyArgumentError(f"{what}: max_bindings must be an int >= 0, got {max_bindings!r}")
    grammar = _grammar(_module_set(modules, what), literals, node_form)
    if not grammar.types:
        raise StrategyArgumentError(f"{what}: no program can be built from modules {sorted(modules or ())}: some "
                                    "module without inputs (SceneAtStart, Events, ...) is needed")
    types = tuple(_result_types(result_type, grammar, max_depth, what))
    return _program_text(grammar, types, max_depth, max_bindings)


@st.composite
def _program_text(draw: st.DrawFn, grammar: _Grammar, types: tuple[DslType, ...], max_depth: int,
                  max_bindings: int) -> str:
    return _ProgramDraw(grammar, max_bindings).program_text(draw, types, max_depth)


def programs(
    result_type: DslType | Iterable[DslType] | None = None,
    max_depth: int = 5,
    *,
    max_bindings: int = 2,
    literals: bool = True,
    modules: Collection[str] | None = None,
) -> st.SearchStrategy[Program]:
    """Well-typed programs, drawn from the module registry.

    Args:
        result_type: the type of the program's answer: a :class:`~craft_dsl.DslType`, several (one is drawn),
            or None for any type a program can have.
        max_depth: the most calls on a path from the answer to a leaf (``Count(Events())`` has depth 2).
        max_bindings: the most ``Var`` bindings; each bound expression is used once or several times.
        literals: draw integer literals where an Integer is expected (-3..3) and quoted values where a
            Color, Shape or Size is expected (``EqualColor(QueryColor(...), "red")``).
        modules: names of the modules that may be used (canonical or original names); None: every module.

    Every module and overload of the registry is reachable, side inputs come from the vocabulary, ``Unique``
    is explicit, and ``str(program)`` is exactly the text that was drawn. Shrinks towards fewer bindings,
    literals and modules without inputs.
    """
    texts = _program_texts(result_type, max_depth, max_bindings, literals, modules, False, "programs()")
    return texts.map(Program.parse)


def node_lists(
    result_type: DslType | Iterable[DslType] | None = None,
    max_depth: int = 5,
    *,
    max_bindings: int = 2,
    modules: Collection[str] | None = None,
) -> st.SearchStrategy[list[dict[str, Any]]]:
    """CLEVR/CRAFT node lists (``Program.to_nodes()``: original ``type`` names, ``inputs``, ``value_inputs``).

    They are the node lists of :func:`programs` that have one: no literals and only overloads with an
    original name. A Var used several times becomes one node that several nodes take as input.
    ``Program.from_nodes(nodes).to_nodes() == nodes``.
    """
    texts = _program_texts(result_type, max_depth, max_bindings, False, modules, True, "node_lists()")
    return texts.map(lambda text: Program.parse(text).to_nodes())


# -- world specs ---------------------------------------------------------------------------------------------


def _scene_ids(scene: int | Iterable[int] | None, what: str) -> list[int]:
    known = list_scenes()
    if scene is None:
        return known
    wanted = [scene] if isinstance(scene, int) else list(scene)
    bad = [s for s in wanted if isinstance(s, bool) or not isinstance(s, int) or s not in known]
    if bad or not wanted:
        raise StrategyArgumentError(f"{what}: scene {scene!r} is not a built-in scene id; allowed: "
                                    f"{', '.join(map(str, known))}, a list of them, or None (drawn)")
    return wanted


def world_specs(scene: int | Iterable[int] | None = None) -> st.SearchStrategy[WorldSpec]:
    """Concrete scenes from the built-in layouts: ``sample_world(scene, seed)`` with the seed drawn.

    ``scene``: a scene id (fixed), several ids (one drawn), or None (any of the 20 layouts).
    """
    scenes = _scene_ids(scene, "world_specs()")
    scene_ids = st.just(scenes[0]) if len(scenes) == 1 else st.sampled_from(scenes)
    return st.builds(sample_world, scene_ids, st.integers(0, MAX_SEED))


# -- simulations ---------------------------------------------------------------------------------------------

#: Velocity components around the 0.001 m/s moving threshold (0.001 itself is not moving), and some large ones.
_VELOCITY_COMPONENTS = (0.0, 0.0005, 0.001, -0.001, 0.0011, -0.0011, 0.002, -0.002, 1.5, -3.0)
_VELOCITY = st.sampled_from([(vx, vy) for vx in _VELOCITY_COMPONENTS for vy in _VELOCITY_COMPONENTS])
_TRIPLE = st.sampled_from(tuple(itertools.product(SIZES, COLORS, SHAPES)))
#: Event steps: few distinct values, so that events often tie.
_EVENT_STEPS = (0, 10, 20, 40, 80, 160, 320, 590)
#: How long a touching contact lasts (longer than a Collision's COLLISION_MAX_STEPS).
_TOUCH_STEPS = st.sampled_from((COLLISION_MAX_STEPS + 1, 40, 100))
_STATIC_ELEMENT = st.sampled_from(STATIC_ELEMENT_SHAPES)
#: How object ids are given: as the simulator does (creation order, N-1 down to 0), the other way, or shuffled.
_ID_LAYOUT = st.sampled_from(("simulator", "reversed", "shuffled"))

#: An episode: the events of one contact (Collision, TouchStart [+ TouchEnd]) or one EnterBasket.
Episode = tuple[tuple[int, str, tuple[int, ...]], ...]


class _DrawnSimulation(Simulation):
    """A Simulation drawn by :func:`simulations`; its repr lists what was drawn, for failure reports."""

    def __repr__(self) -> str:
        def obj(o: SimObject) -> str:
            if not o.dynamic:
                return f"{o.id}: {o.shape}"
            return f"{o.id}: {o.size} {o.color} {o.shape} v={o.start.velocity}->{o.end.velocity}"

        def events(sim: Simulation) -> str:
            return ", ".join(f"{e.id}:{e.type}@{e.step}{list(e.objects) if e.objects else ''}" for e in sim.events)

        cfs = "; ".join(f"without {o}: {events(self.counterfactual(o))}" for o in sorted(self.dynamic_ids))
        return (f"Simulation(objects=[{', '.join(obj(o) for o in self.objects)}], steps={self.steps}, "
                f"events=[{events(self)}], counterfactuals={{{cfs}}})")


@lru_cache(maxsize=16)
def _timing(steps: int) -> tuple[st.SearchStrategy[int], st.SearchStrategy[tuple[str, int]]]:
    """Steps of an event, and (contact type, step) of a contact: Collisions first, then touches."""
    at = [s for s in _EVENT_STEPS if s < steps] or [0]
    return st.sampled_from(at), st.sampled_from([(kind, s) for kind in (COLLISION, TOUCH_START) for s in at])


@st.composite
def _episodes(draw: st.DrawFn, targets: st.SearchStrategy[tuple[str, int, int]], dynamic: frozenset[int],
              steps: int) -> Episode:
    """One episode: a dynamic object touches something (a Collision, or a TouchStart and maybe its TouchEnd), or
    enters the basket (objects [basket, object]); ``targets`` draws (what, dynamic object, other object)."""
    what, mover, other = draw(targets)
    step_of, contact = _timing(steps)
    if what == ENTER_BASKET:
        return ((draw(step_of), ENTER_BASKET, (other, mover)),)
    kind, step = draw(contact)
    if other in dynamic:  # two dynamic objects, in either order
        pair = (other, mover) if draw(st.booleans()) else (mover, other)
    else:  # the static one first, as the simulator reports it
        pair = (other, mover)
    if kind == COLLISION or step + COLLISION_MAX_STEPS + 1 >= steps:  # too late to become a touch
        return ((step, COLLISION, pair),)
    end = step + draw(_TOUCH_STEPS)
    if end >= steps:  # still touching when the video ends
        return ((step, TOUCH_START, pair),)
    return ((step, TOUCH_START, pair), (end, TOUCH_END, pair))


def _episode_strategy(dynamic: Sequence[int], everyone: Sequence[int], ground: int, basket: int,
                      steps: int) -> st.SearchStrategy[Episode]:
    """Episodes of ``dynamic`` objects (one choice draws the object and what it does): contacts with the ground are
    the most frequent (as in CRAFT videos), then entries into the basket, then contacts with the basket or any
    other object."""
    targets: list[tuple[str, int, int]] = []
    for d in dynamic:
        others = [o for o in everyone if o not in (d, ground, basket)]
        targets += [("contact", d, ground), (ENTER_BASKET, d, basket), ("contact", d, ground), ("contact", d, basket),
                    ("contact", d, ground), (ENTER_BASKET, d, basket), ("contact", d, ground)]
        targets += [("contact", d, o) for o in others]
    return _episodes(st.sampled_from(tuple(targets)), frozenset(dynamic), steps)


def _consistent(episodes: Iterable[Episode], steps: int) -> list[Episode]:
    """The episodes, less those that overlap an earlier one of the same objects: two objects do not start a
    contact while they touch, and an object does not enter the basket twice in one step."""
    busy: dict[tuple[bool, frozenset[int]], list[tuple[int, int]]] = {}
    kept = []
    for episode in episodes:
        first_step, kind, objects = episode[0]
        last_step = episode[-1][0] if len(episode) > 1 else (steps if kind == TOUCH_START else first_step)
        key = (kind == ENTER_BASKET, frozenset(objects))
        if any(first_step <= end and start <= last_step for start, end in busy.get(key, ())):
            continue
        busy.setdefault(key, []).append((first_step, last_step))
        kept.append(episode)
    return kept


def _events(episodes: Iterable[Episode], steps: int) -> list[Event]:
    """Start, the episodes' events in step order (ties in drawing order), End; ids 0..n-1 in that order."""
    body = sorted((e for ep in episodes for e in ep), key=lambda e: e[0])
    events = [Event(0, START, -1, ())]
    events.extend(Event(k, etype, step, objs) for k, (step, etype, objs) in enumerate(body, start=1))
    events.append(Event(len(events), END, steps, ()))
    return events


@st.composite
def _drawn_simulations(draw: st.DrawFn, max_dynamic: int, max_static: int, max_events: int,
                       steps: int) -> Simulation:
    n_dynamic = draw(st.integers(1, max_dynamic))
    triples = draw(st.lists(_TRIPLE, min_size=n_dynamic, max_size=n_dynamic, unique=True))
    # creation order, as the simulator builds a scene: walls, ground, basket, other statics, dynamic objects
    statics = (["wall_l", "wall_r"] if draw(st.booleans()) else []) + ["ground", "basket"]
    statics += draw(st.lists(_STATIC_ELEMENT, max_size=max_static))
    n = len(statics) + len(triples)
    layout = draw(_ID_LAYOUT)
    if layout == "simulator":  # uniqueIDs N-1 ... 0: the last dynamic object gets id 0
        ids = list(range(n - 1, -1, -1))
    elif layout == "reversed":
        ids = list(range(n))
    else:
        ids = list(draw(st.permutations(range(n))))
    static_ids, dynamic = ids[:len(statics)], ids[len(statics):]
    objects = [SimObject(oid, shape, STATIC_COLOR, STATIC_SIZE, False) for oid, shape in zip(static_ids, statics)]
    objects += [SimObject(oid, shape, color, size, True, ObjectState(velocity=draw(_VELOCITY)),
                          ObjectState(velocity=draw(_VELOCITY)))
                for oid, (size, color, shape) in zip(dynamic, triples)]
    ground, basket = static_ids[statics.index("ground")], static_ids[statics.index("basket")]
    # at least one episode per dynamic object but one (a scene with one dynamic object may have no event)
    factual = _consistent(draw(st.lists(_episode_strategy(dynamic, ids, ground, basket, steps),
                                        min_size=min(len(dynamic) - 1, max_events), max_size=max_events)), steps)
    counterfactual_events: dict[int, list[Event]] = {}
    for removed in dynamic:
        rest = [o for o in ids if o != removed]
        movers = [o for o in dynamic if o != removed]
        # the factual episodes without the removed object, each kept unless its bit is set (shrinks to all kept)
        candidates = [ep for ep in factual if all(removed not in e[2] for e in ep)]
        dropped = draw(st.integers(0, 2 ** len(candidates) - 1)) if candidates else 0
        kept = [ep for k, ep in enumerate(candidates) if not dropped >> k & 1]
        new = draw(st.lists(_episode_strategy(movers, rest, ground, basket, steps),
                            max_size=max_events // 4)) if movers else []
        counterfactual_events[removed] = _events(_consistent(kept + new, steps), steps)

    def counterfactual(removed: int) -> Simulation:
        if removed not in counterfactual_events:
            shape = next(o.shape for o in objects if o.id == removed)
            raise CounterfactualUnavailable(f"no counterfactual for object {removed} ({shape}): drawn simulations "
                                            "have counterfactuals for dynamic objects only")
        return Simulation([o for o in objects if o.id != removed], counterfactual_events[removed], steps=steps,
                          removed=(removed,), meta={"source": "craft_dsl.strategies.simulations"})

    return _DrawnSimulation(objects, _events(factual, steps), steps=steps, counterfactuals=counterfactual,
                            meta={"source": "craft_dsl.strategies.simulations"})


def _live_simulation(world: WorldSpec, steps: int) -> Simulation:
    from .physics import simulate  # imported only when live runs are drawn

    return simulate(world, steps=steps)


def simulations(
    *,
    live: bool = False,
    max_dynamic: int = 4,
    max_static: int = 2,
    max_events: int = 12,
    steps: int | None = None,
    scene: int | Iterable[int] | None = None,
) -> st.SearchStrategy[Simulation]:
    """Simulations that exercise the DSL.

    By default, small simulations built directly (no physics, hundreds per second):

    * ground and basket, maybe the two walls, up to ``max_static`` platforms, ramps or static balls;
    * 1 to ``max_dynamic`` dynamic objects with unique (size, colour, shape) and start/end velocities around
      the 0.001 m/s moving threshold;
    * between Start and End, up to ``max_events`` episodes of dynamic objects (at least one per dynamic object
      but one): Collisions and TouchStart/TouchEnd pairs, most of them with the ground, never overlapping for
      one pair, and EnterBasket into the basket, at few distinct steps, so that events tie;
    * a counterfactual simulation for every dynamic object: the same objects less that one, the factual
      events that do not involve it (kept or not) and new ones. Asking for the counterfactual of a static
      object raises :class:`~craft_dsl.CounterfactualUnavailable`.

    ``steps`` is the length of the video (default 600).

    With ``live=True``: a live physics run (:func:`craft_dsl.physics.simulate`, the default engine, Box2D) of
    ``steps`` steps (default 240) of a world drawn by :func:`world_specs` (``scene``: as there), with clean
    counterfactuals.
    """
    if steps is not None and (isinstance(steps, bool) or not isinstance(steps, int) or steps < 1):
        raise StrategyArgumentError(f"simulations(): steps must be an int >= 1, got {steps!r}")
    if live:
        return world_specs(scene).map(lambda w: _live_simulation(w, steps if steps is not None else 240))
    if scene is not None:
        raise StrategyArgumentError("simulations(): scene applies to live runs only; pass live=True")
    for name, value, least in (("max_dynamic", max_dynamic, 1), ("max_static", max_static, 0),
                               ("max_events", max_events, 0)):
        if isinstance(value, bool) or not isinstance(value, int) or value < least:
            raise StrategyArgumentError(f"simulations(): {name} must be an int >= {least}, got {value!r}")
    most = len(SIZES) * len(COLORS) * len(SHAPES)
    if max_dynamic > most:
        raise StrategyArgumentError(f"simulations(): max_dynamic={max_dynamic} exceeds the {most} distinct "
                                    "(size, colour, shape) triples")
    return _drawn_simulations(max_dynamic, max_static, max_events, steps if steps is not None else DEFAULT_STEPS)


# -- questions -----------------------------------------------------------------------------------------------


class QuestionRecord(NamedTuple):
    """A CRAFT question as the generator writes it, with the program it asks."""

    text: str
    template_id: str
    #: Placeholder -> value, in binding order (``{"<Z>": "small", "<C>": "red", "<S>": "cube"}``).
    params: dict[str, str]
    program: Program


@lru_cache(maxsize=128)
def _placeholder_vocabularies(template_id: str) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """Each placeholder of a template with the values of the side input it fills."""
    from .templates import templates

    found: dict[str, tuple[str, ...]] = {}
    for node in templates()[template_id].nodes:
        for placeholder in node.get("side_inputs", ()):
            spec = lookup(node["type"])
            assert spec is not None and spec.side_inputs, node
            found.setdefault(placeholder, VOCABULARY[spec.side_inputs[0]])
    return tuple(found.items())


@lru_cache(maxsize=4096)
def _template_program(template_id: str, params: tuple[tuple[str, str], ...]) -> Program:
    from .templates import templates

    return templates()[template_id].program(dict(params))


def questions(template_ids: Iterable[str] | None = None, *, include_dropped: bool = True
              ) -> st.SearchStrategy[QuestionRecord]:
    """CRAFT questions: a template, valid values for its placeholders, and the text the generator writes.

    The text comes from the generator's own rendering (``star_paraphrases`` then ``render_text`` of
    :mod:`craft_dsl.dataset.questions`) with a numpy Generator seeded from a drawn integer: a paraphrase, the
    starred words' synonyms and the values' synonyms are drawn as the generator draws them. ``template_ids``
    restricts the templates (default: all 67); ``include_dropped=False`` leaves out the 19 basket-collision
    templates the paper's dataset drops. The parameters need not describe objects of any particular scene.
    """
    from .dataset.questions import render_text, star_paraphrases
    from .templates import paraphrases, templates

    every = templates()
    ids = list(every) if template_ids is None else list(template_ids)
    unknown = [t for t in ids if t not in every]
    if unknown or not ids:
        raise StrategyArgumentError(f"questions(): unknown template ids {unknown or ids!r}; allowed: "
                                    f"{', '.join(every)}")
    if not include_dropped:
        ids = [t for t in ids if not every[t].dropped]
        if not ids:
            raise StrategyArgumentError("questions(): every template asked for is a dropped one")
    texts = paraphrases()

    @st.composite
    def question(draw: st.DrawFn) -> QuestionRecord:
        template_id = draw(st.sampled_from(ids))
        params = {ph: draw(st.sampled_from(values)) for ph, values in _placeholder_vocabularies(template_id)}
        rng = np.random.default_rng(draw(st.integers(0, MAX_SEED)))
        text = render_text(star_paraphrases(texts[template_id], rng), params, rng)
        return QuestionRecord(text, template_id, params, _template_program(template_id, tuple(params.items())))

    return question()
