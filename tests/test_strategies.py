"""The public hypothesis strategies (craft_dsl.strategies): valid values, coverage of the registry, shrinking,
the entry point behind st.from_type, and soundness of the type checker over drawn programs and simulations."""

from __future__ import annotations

import importlib.metadata
import importlib.util
import re
import subprocess
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, Phase, find, given, settings
from hypothesis import strategies as st

from craft_dsl import (
    MODULES,
    REGISTRY,
    CounterfactualUnavailable,
    DslType,
    Program,
    Simulation,
    WorldSpec,
    question_to_program,
)
from craft_dsl.dataset.synonyms import SYNONYMS
from craft_dsl.recorded import load_simulation, simulation_dict
from craft_dsl.registry import lookup
from craft_dsl.scenes import list_scenes, sample_world
from craft_dsl.strategies import (
    QuestionRecord,
    StrategyArgumentError,
    node_lists,
    programs,
    questions,
    simulations,
    world_specs,
)
from craft_dsl.templates import first_instance, paraphrases, templates
from craft_dsl.vocabulary import (
    COLLISION,
    COLORS,
    DEFAULT_ENGINE,
    END,
    ENTER_BASKET,
    SHAPES,
    SIZES,
    START,
    TOUCH_END,
    TOUCH_START,
)
from tests.dsl_values import check_run
from tests.program_text import Node, inlined, overloads_used, read

ROOT = Path(__file__).resolve().parents[1]
SETTINGS = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
#: Fixed draws: coverage tests see the same examples on every run.
SEEDED = settings(max_examples=400, deadline=None, derandomize=True, database=None,
                  suppress_health_check=[HealthCheck.too_slow])
QUIET = settings(database=None, max_examples=1000, deadline=None, derandomize=True)
#: The first example found, not shrunk.
FIRST_FOUND = settings(QUIET, max_examples=2000, phases=[Phase.generate])
EVERY_OVERLOAD = {(m.name, k) for m in MODULES for k in range(len(m.overloads))}


def calls(program: Program) -> int:
    """Number of calls of the program's inlined form (its node count)."""
    return str(inlined(program)).count("(")


def depth(node: Node) -> int:
    return 1 + max((depth(a) for a in node.args), default=0) if node.kind == "call" else 0


def uses(module: str) -> Callable[[Program], bool]:
    """Whether a program calls ``module`` (canonical names in the canonical text)."""
    call = re.compile(rf"\b{module}\(")
    return lambda p: call.search(str(p)) is not None


# -- the optional dependency ----------------------------------------------------------------------------------


def test_import_without_hypothesis_names_the_extra() -> None:
    code = "import sys; sys.modules['hypothesis'] = None; import craft_dsl.strategies"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 1
    last = res.stderr.strip().splitlines()[-1]
    assert last == ("craft_dsl.errors.MissingExtraError: craft_dsl.strategies needs hypothesis, which is not "
                    "installed: pip install 'craft-dsl[strategies]'"), res.stderr


# -- programs -------------------------------------------------------------------------------------------------


@SETTINGS
@given(st.sampled_from(list(DslType)), st.data())
def test_programs_type_check_to_the_requested_type(typ: DslType, data: st.DataObject) -> None:
    p = data.draw(programs(typ))
    assert p.type is typ
    assert Program.parse(str(p)) == p


@SETTINGS
@given(programs((DslType.BOOL, DslType.COLOR)))
def test_programs_of_one_of_several_types(p: Program) -> None:
    assert p.type in (DslType.BOOL, DslType.COLOR)


@SETTINGS
@given(st.integers(3, 6), st.integers(0, 3), st.data())
def test_programs_respect_depth_bindings_and_literals(max_depth: int, max_bindings: int,
                                                      data: st.DataObject) -> None:
    p = data.draw(programs(max_depth=max_depth, max_bindings=max_bindings, literals=False))
    text = read(str(inlined(p)))
    assert depth(text.body) <= max_depth
    assert len(read(str(p)).bindings) <= max_bindings
    assert not re.search(r"[(,] ?-?\d", str(p)), "an integer literal was drawn with literals=False"


def collected(strategy: st.SearchStrategy[Any], n: int) -> list[Any]:
    """``n`` values drawn with a fixed seed: the same values on every run."""
    values: list[Any] = []

    @settings(SEEDED, max_examples=n)
    @given(strategy)
    def collect(value: Any) -> None:
        values.append(value)

    collect()
    return values


@pytest.fixture(scope="module")
def drawn_programs() -> list[Program]:
    """200 programs drawn with a fixed seed, then for each overload they miss, the first program of its output
    type that hypothesis draws with it. Hypothesis spreads its draws unevenly (it mutates earlier examples by
    copying sub-expressions, so modules that only stand at the root, the Bool ones, come up less often)."""
    corpus = collected(programs(), 200)
    seen = {used for p in corpus for used in overloads_used(p)}
    for module, k in sorted(EVERY_OVERLOAD - seen):
        output = REGISTRY[module].overloads[k].output
        corpus.append(find(programs(output), lambda p, m=(module, k): m in overloads_used(p),  # type: ignore[misc]
                           settings=FIRST_FOUND))
    return corpus


@pytest.fixture(scope="module")
def drawn_simulations() -> list[Simulation]:
    return collected(simulations(), 100)


def test_every_module_and_overload_is_drawn(drawn_programs: list[Program]) -> None:
    seen = {used for p in drawn_programs for used in overloads_used(p)}
    assert seen == EVERY_OVERLOAD, f"never drawn: {sorted(EVERY_OVERLOAD - seen)}"
    assert len(drawn_programs) < 200 + len(EVERY_OVERLOAD) // 5, "more than a fifth of the overloads needed a search"


def test_literals_vars_and_reuse_are_drawn(drawn_programs: list[Program]) -> None:
    found = Counter[str]()
    for p in drawn_programs:
        text = str(p)
        found["int literal"] += bool(re.search(r"[(,] ?-?\d", text))
        found["quoted input"] += bool(re.search(r"Equal(Color|Shape|Size)\([^\n]*\"\w+\"\)", text))
        bindings = read(text).bindings
        found["Var"] += bool(bindings)
        found["Var used twice"] += any(len(re.findall(rf"\b{name}\b", text)) > 2 for name, _ in bindings)
    assert all(found[k] > 0 for k in ("int literal", "quoted input", "Var", "Var used twice")), found


@SETTINGS
@given(programs(modules=["Count", "FilterColor", "SceneAtStart", "filter_shape"]))
def test_programs_use_only_the_allowed_modules(p: Program) -> None:
    assert {m for m, _ in overloads_used(p)} <= {"Count", "FilterColor", "SceneAtStart", "FilterShape"}


@pytest.mark.parametrize(("call", "message"), [
    (lambda: programs("Integer"), "is not a DslType"),
    (lambda: programs(DslType.COLOR, max_depth=2), "needs max_depth >= 3"),
    (lambda: programs(max_depth=0), "too small for any program"),
    (lambda: programs(modules=["Cout"]), "unknown module 'Cout'"),
    (lambda: programs(DslType.COLOR, modules=["Count", "SceneAtStart"]), "no allowed module produces Color"),
    (lambda: programs(modules=["Count"]), "no program can be built from modules ['Count']"),
    (lambda: programs(max_bindings=-1), "max_bindings must be an int >= 0"),
    (lambda: world_specs(scene=21), "not a built-in scene id"),
    (lambda: simulations(max_dynamic=0), "max_dynamic must be an int >= 1"),
    (lambda: simulations(scene=3), "pass live=True"),
    (lambda: questions(["cause_99"]), "unknown template ids ['cause_99']"),
])
def test_bad_arguments_are_reported(call: Callable[[], Any], message: str) -> None:
    with pytest.raises(StrategyArgumentError) as err:
        call()
    assert message in str(err.value)


# -- shrinking ------------------------------------------------------------------------------------------------


def test_a_planted_failure_shrinks_to_a_minimal_program() -> None:
    """'No program uses FilterCollideGround' fails; the counterexample hypothesis reports is tiny."""
    smallest = find(programs(), uses("FilterCollideGround"), settings=QUIET)
    assert str(smallest) == "FilterCollideGround(Events())"
    smallest = find(programs(max_depth=3), uses("EqualColor"), settings=QUIET)
    assert calls(smallest) <= 2, str(smallest)  # EqualColor("gray", "gray")


def test_a_planted_failure_shrinks_to_a_minimal_simulation() -> None:
    """'No dynamic object enters the basket' fails; the counterexample has one object and one event."""
    smallest = find(simulations(), lambda s: any(e.type == ENTER_BASKET for e in s.events), settings=QUIET)
    # ids as the simulator gives them: ground 2, basket 1, the dynamic object 0 (the simplest triple)
    assert [(o.id, o.shape, o.color, o.size) for o in smallest.objects] == [
        (0, "cube", "gray", "small"), (1, "basket", "black", "large"), (2, "ground", "black", "large")]
    assert [e.type for e in smallest.events] == [START, ENTER_BASKET, END]
    assert "EnterBasket@0" in repr(smallest)


# -- node lists -----------------------------------------------------------------------------------------------


@SETTINGS
@given(node_lists())
def test_node_lists_load_back_to_the_same_program(nodes: list[dict[str, Any]]) -> None:
    p = Program.from_nodes(nodes)
    assert p.to_nodes() == nodes
    assert Program.from_nodes(p.to_nodes()) == p
    for k, node in enumerate(nodes):
        assert set(node) == {"type", "inputs", "value_inputs"}
        spec = lookup(node["type"])
        assert spec is not None and node["type"] in {ov.original for ov in spec.overloads}
        assert all(0 <= i < k for i in node["inputs"])
        assert len(node["value_inputs"]) == len(spec.side_inputs)
        for value, typ in zip(node["value_inputs"], spec.side_inputs):
            assert value in {DslType.COLOR: COLORS, DslType.SHAPE: SHAPES, DslType.SIZE: SIZES}[typ]


@SETTINGS
@given(node_lists(DslType.INTEGER))
def test_node_lists_of_a_result_type(nodes: list[dict[str, Any]]) -> None:
    assert Program.from_nodes(nodes).type is DslType.INTEGER


def test_node_lists_share_nodes() -> None:
    """A sub-expression used twice (a Var, or the same call written twice) is one node with two consumers."""
    shared = find(node_lists(), lambda nodes: len({i for n in nodes for i in n["inputs"]})
                  < sum(len(n["inputs"]) for n in nodes), settings=QUIET)
    assert len(shared) <= 5, shared  # the smallest is Intersect(SceneAtStart(), SceneAtStart()): 2 nodes
    assert Program.from_nodes(shared).to_nodes() == shared


# -- world specs ----------------------------------------------------------------------------------------------


@SETTINGS
@given(world_specs())
def test_world_specs_are_sampled_scenes(world: WorldSpec) -> None:
    assert world.scene_id in list_scenes() and world.seed is not None
    assert world == sample_world(world.scene_id, world.seed)
    shapes = Counter(b.shape for b in world.bodies)
    assert shapes["ground"] == shapes["basket"] == 1
    assert sorted(b.uid for b in world.bodies) == list(range(len(world.bodies)))
    triples = [(b.size, b.color, b.shape) for b in world.bodies if b.dynamic]
    assert triples and len(set(triples)) == len(triples)


@SETTINGS
@given(world_specs(scene=7), world_specs(scene=[2, 18]))
def test_world_specs_of_chosen_scenes(seven: WorldSpec, two_or_eighteen: WorldSpec) -> None:
    assert seven.scene_id == 7
    assert two_or_eighteen.scene_id in (2, 18)


# -- simulations ----------------------------------------------------------------------------------------------


def check_simulation(sim: Simulation) -> None:
    """Every event's objects exist and fit its type; counterfactuals exist for every dynamic object and lack it."""
    ids = {o.id for o in sim.objects}
    dynamic = {o.id for o in sim.objects if o.dynamic}
    shapes = Counter(o.shape for o in sim.objects if not o.dynamic)
    assert shapes["ground"] == shapes["basket"] == 1
    triples = [(o.size, o.color, o.shape) for o in sim.objects if o.dynamic]
    assert triples and len(set(triples)) == len(triples)
    check_events(sim, ids, dynamic)
    for removed in sorted(dynamic):
        cf = sim.counterfactual(removed)
        assert {o.id for o in cf.objects} == ids - {removed}
        assert cf.removed[-1] == removed
        check_events(cf, ids - {removed}, dynamic - {removed})
    for static in sorted(ids - dynamic):
        if static in (sim.ground_id, sim.basket_id):
            with pytest.raises(CounterfactualUnavailable):
                sim.counterfactual(static)


def check_events(sim: Simulation, ids: set[int], dynamic: set[int]) -> None:
    """Start first, End last; contacts between two objects, one of them dynamic, that never overlap (a TouchEnd
    ends a touch that started, nothing starts while a pair touches); entries of dynamic objects into the basket."""
    events = sim.events
    assert events[0].type == START and events[-1].type == END and events[-1].step == sim.steps
    touching: set[frozenset[int]] = set()
    entries: set[tuple[int, int]] = set()
    for e in events[1:-1]:
        assert set(e.objects) <= ids and 0 <= e.step < sim.steps
        if e.type == ENTER_BASKET:
            assert e.objects[0] == sim.basket_id and e.objects[1] in dynamic
            assert (e.step, e.objects[1]) not in entries, f"{e} enters the basket twice in one step"
            entries.add((e.step, e.objects[1]))
            continue
        assert e.type in (COLLISION, TOUCH_START, TOUCH_END) and len(set(e.objects)) == 2
        assert set(e.objects) & dynamic, e
        pair = frozenset(e.objects)
        if e.type == TOUCH_END:
            assert pair in touching, f"{e} ends a touch that never started"
            touching.remove(pair)
        else:
            assert pair not in touching, f"{e} starts while the pair touches"
            if e.type == TOUCH_START:
                touching.add(pair)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(simulations())
def test_drawn_simulations_are_consistent(sim: Simulation) -> None:
    check_simulation(sim)
    assert sim.steps == 600


def test_drawn_simulations_cover_every_event_type_ties_and_the_moving_threshold(
        drawn_simulations: list[Simulation]) -> None:
    found = Counter[str]()
    for sim in drawn_simulations:
        found.update(e.type for e in sim.events)
        steps = [e.step for e in sim.events]
        found["tie"] += len(set(steps)) < len(steps)
        speeds = {abs(c) for o in sim.objects for s in o.states for c in s.velocity}
        found["at threshold"] += 0.001 in speeds
        found["moving"] += bool(sim.moving(0) | sim.moving(-1))
        found["static extra"] += any(o.shape in ("platform", "ramp", "static_ball") for o in sim.objects)
        cf_types = {e.type for o in sim.dynamic_ids for e in sim.counterfactual(o).events}
        found["cf event"] += bool(cf_types - {START, END})
    wanted = (START, END, COLLISION, TOUCH_START, TOUCH_END, ENTER_BASKET, "tie", "at threshold", "moving",
              "static extra", "cf event")
    assert all(found[k] > 0 for k in wanted), found


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(simulations())
def test_drawn_simulations_are_valid_recorded_files(sim: Simulation) -> None:
    """Written in the original JSON format and loaded back, a drawn simulation is the same simulation."""
    loaded = load_simulation(simulation_dict(sim))
    assert loaded.objects == sim.objects and loaded.events == sim.events and loaded.steps == sim.steps
    for removed in sim.dynamic_ids:
        assert loaded.counterfactual(removed).events == sim.counterfactual(removed).events


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(simulations(live=True, steps=120, scene=[1, 3]))
def test_live_simulations_are_consistent(sim: Simulation) -> None:
    assert sim.steps == 120 and sim.world is not None and sim.world.scene_id in (1, 3)
    assert sim.meta["engine"] == DEFAULT_ENGINE
    check_simulation(sim)


# -- questions ------------------------------------------------------------------------------------------------


def rendering_pattern(paraphrase: str, params: dict[str, str]) -> re.Pattern[str]:
    """Every text the generator can write for one paraphrase and these parameters."""
    pattern = re.escape(" ".join(paraphrase.split()))
    for word in set(re.findall(r"\\\*(.+?)\\\*", pattern)):
        alternatives = SYNONYMS[word.replace("\\ ", " ")]
        pattern = pattern.replace(rf"\*{word}\*", "(?:" + "|".join(map(re.escape, alternatives)) + ")")
    for placeholder, value in params.items():
        alternatives = SYNONYMS.get(value, (value,))
        pattern = pattern.replace(re.escape(placeholder), "(?:" + "|".join(map(re.escape, alternatives)) + ")")
    return re.compile(pattern.replace(r"\ ", " "))


@settings(max_examples=200, deadline=None)
@given(questions())
def test_questions_are_generator_texts_of_their_programs(q: QuestionRecord) -> None:
    template = templates()[q.template_id]
    assert list(q.params) == list(template.placeholders)
    vocab = {"Z": SIZES, "C": COLORS, "S": SHAPES}
    assert all(value in vocab[ph[1]] for ph, value in q.params.items())
    assert q.program == template.program(q.params)
    assert any(rendering_pattern(p, q.params).fullmatch(q.text) for p in paraphrases()[q.template_id]), q.text


@settings(max_examples=200, deadline=None)
@given(questions())
def test_question_texts_read_back_to_their_programs(q: QuestionRecord) -> None:
    """craft_dsl.question_to_program inverts every text questions() draws (any template, paraphrase, synonym)."""
    assert question_to_program(q.text) == q.program, q.text


def test_questions_draw_paraphrases_and_synonyms() -> None:
    texts: set[str] = set()
    ids: set[str] = set()

    @settings(SEEDED, max_examples=200)
    @given(questions(["descriptive_8", "cause_0"]), questions(include_dropped=False))
    def collect(q: QuestionRecord, kept: QuestionRecord) -> None:
        texts.add(q.text)
        ids.add(kept.template_id)

    collect()
    assert any(t.startswith("How many") and " hit the " in t for t in texts)  # "*fall to*" -> "hit"
    assert any(" floor" in t for t in texts)  # "*ground*" -> "floor"
    assert any(" tiny " in t or " big " in t or " block" in t for t in texts)  # value synonyms
    assert not ids & {t.id for t in templates().values() if t.dropped}


# -- st.from_type through the entry point ---------------------------------------------------------------------


def test_the_entry_point_is_installed() -> None:
    hooks = [e for e in importlib.metadata.entry_points(group="hypothesis") if e.name == "craft_dsl"]
    assert hooks, "no 'hypothesis' entry point: reinstall the package (pip install -e .)"
    assert hooks[0].value == "craft_dsl.hypothesis_hook:_hypothesis_setup_hook"


@settings(SETTINGS, max_examples=30)
@given(st.from_type(Program), st.from_type(Simulation), st.from_type(WorldSpec))
def test_from_type_draws_craft_values(p: Program, sim: Simulation, world: WorldSpec) -> None:
    assert isinstance(p, Program) and isinstance(sim, Simulation) and isinstance(world, WorldSpec)
    check_run(p, sim)


def test_the_hook_runs_on_import_without_physics() -> None:
    """Importing hypothesis registers the strategies: craft_dsl is imported, its physics, strategies and heavy
    libraries are not (the strategies module is imported when a test first asks st.from_type for a craft_dsl
    type)."""
    code = (
        "import sys, hypothesis\n"
        "from hypothesis import Phase, find, settings, strategies as st\n"
        "names = ('craft_dsl', 'craft_dsl.physics', 'pymunk', 'craft_dsl.strategies', 'lark', 'networkx')\n"
        "print(*(name in sys.modules for name in names))\n"
        "import craft_dsl\n"
        "once = settings(max_examples=1, phases=[Phase.generate], database=None)\n"
        "print(type(find(st.from_type(craft_dsl.Program), lambda p: True, settings=once)).__name__)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["True", "False", "False", "False", "False", "False", "Program"]


# -- soundness of the type checker ----------------------------------------------------------------------------


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(programs(), simulations())
def test_well_typed_programs_run_soundly_on_drawn_simulations(p: Program, sim: Simulation) -> None:
    check_run(p, sim)


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(programs(), simulations(live=True, steps=240))
def test_well_typed_programs_run_soundly_on_live_simulations(p: Program, sim: Simulation) -> None:
    check_run(p, sim)


def test_every_template_has_an_instance_on_a_drawn_simulation(drawn_simulations: list[Simulation]) -> None:
    """Drawn simulations exercise the DSL as CRAFT questions do: each of the 67 templates has a binding whose
    answer is not INVALID on one of them (cause, enable and prevent questions included)."""
    without = [t.id for t in templates().values()
               if not any(first_instance(t, sim) is not None for sim in drawn_simulations)]
    assert not without, without


# -- the worked example of docs/strategies.md -----------------------------------------------------------------


def test_the_worked_example_passes() -> None:
    """examples/oracle_properties.py (a toy parser and executor checked against the oracle) passes, and the code
    docs/strategies.md shows from it is the code that runs."""
    path = ROOT / "examples" / "oracle_properties.py"
    spec = importlib.util.spec_from_file_location("oracle_properties", path)
    assert spec is not None and spec.loader is not None
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    tests = [getattr(example, name) for name in dir(example) if name.startswith("test_")]
    assert len(tests) == 4
    for test in tests:
        settings(max_examples=15, database=None, deadline=None)(test)()
    docs = (ROOT / "docs" / "strategies.md").read_text(encoding="utf-8")
    worked = docs.split("## Worked example", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", worked, flags=re.S)
    assert len(blocks) >= 3
    source = path.read_text(encoding="utf-8")
    for block in blocks:
        assert block in source, f"docs/strategies.md shows code that examples/oracle_properties.py lacks:\n{block}"
