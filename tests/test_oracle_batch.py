"""craft_dsl.oracle.run_batch: a batch's outcomes are exactly those of each program run alone.

The differential tests hold ``run_batch`` equal to :func:`craft_dsl.oracle.program_outcome` (outcome kind and
answer) over every template's programs on recorded simulations in every form, over edited token sequences, node
lists and texts, and over drawn programs; the others cover rewards, bad input, determinism and the shared work
(a node evaluated once per simulation, a counterfactual computed once per simulation and removed object).
"""

from __future__ import annotations

import gc
import random
import re
import tracemalloc
from collections.abc import Sequence
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import CraftError, Program, Simulation, load_simulation
from craft_dsl.oracle import OUTCOMES, BatchResult, program_outcome, run_batch
from craft_dsl.oracle.batch import ANSWER, INVALID_ANSWER, SYNTAX_ERROR, TYPE_ERROR
from craft_dsl.recorded import simulation_dict
from craft_dsl.registry import IMPLS
from craft_dsl.strategies import node_lists, programs
from craft_dsl.templates import first_instances
from craft_dsl.tokens import program_vocabulary
from tests.conftest import BASIC_OBJECTS, make_sim
from tests.test_nodes_fast_path import EDITS, NAMES, edited

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
VOCABULARY = program_vocabulary()
FORMS = ("prefix", "postfix", "text", "nodes")


@pytest.fixture(scope="module")
def sims(e1: Simulation) -> list[Simulation]:
    """E1 and two live runs written to the recorded format and loaded back."""
    from craft_dsl.physics import simulate

    return [e1, *(load_simulation(simulation_dict(simulate(scene, seed=1))) for scene in (3, 12))]


def in_form(program: Program, form: str) -> Any:
    if form == "text":
        return str(program)
    if form == "nodes":
        return program.to_nodes()
    return program.to_tokens(form)  # type: ignore[arg-type]


def alone(programs: Sequence[Any], sims: Simulation | Sequence[Simulation], form: str | None) -> list[tuple[Any, ...]]:
    """(outcome, answer) of each program run alone."""
    sim_list = [sims] * len(programs) if isinstance(sims, Simulation) else list(sims)
    out = []
    for program, sim in zip(programs, sim_list):
        o = program_outcome(program, sim, form)  # type: ignore[arg-type]
        out.append((o.kind, o.answer))
    return out


def batched(result: BatchResult) -> list[tuple[Any, ...]]:
    return list(zip(result.kinds, result.answers))


def assert_same(programs: Sequence[Any], sims: Simulation | Sequence[Simulation], form: str | None) -> BatchResult:
    result = run_batch(programs, sims, form=form)  # type: ignore[arg-type]
    expected = alone(programs, sims, form)
    got = batched(result)
    wrong = [(p, g, e) for p, g, e in zip(programs, got, expected) if g != e]
    assert not wrong, f"{len(wrong)} differ, first: {wrong[0]}"
    return result


def token_edits(tokens: list[str], rng: random.Random) -> list[str]:
    """``tokens`` with 1 to 3 random edits: a vocabulary token in place of one, one deleted, one inserted, two
    swapped."""
    out = list(tokens)
    for _ in range(rng.randint(1, 3)):
        op = rng.randrange(4)
        i = rng.randrange(len(out) + 1)
        if op == 0 and i < len(out):
            out[i] = rng.choice(VOCABULARY)
        elif op == 1 and i < len(out) and len(out) > 1:
            del out[i]
        elif op == 2:
            out.insert(i, rng.choice(VOCABULARY))
        elif i + 1 < len(out):
            out[i], out[i + 1] = out[i + 1], out[i]
    return out


# -- differential: templates, edits, drawn programs -----------------------------------------------------------


@pytest.mark.parametrize("form", FORMS)
def test_every_template_program_as_alone(sims: list[Simulation], form: str) -> None:
    items = [(sim, p) for sim in sims for _t, _p, p, _a in first_instances(sim, include_dropped=True)]
    programs = [in_form(p, form) for _sim, p in items]
    result = assert_same(programs, [sim for sim, _p in items], form)
    assert result.counts()["answer"] == len(items)  # every template instance answers
    for sim in sims:  # one simulation for the whole batch
        mine = [in_form(p, form) for s, p in items if s is sim]
        assert_same(mine, sim, form)


@pytest.mark.parametrize("order", ["prefix", "postfix"])
def test_edited_token_sequences_as_alone(sims: list[Simulation], order: str) -> None:
    rng = random.Random(7)
    programs, on = [], []
    for sim in sims:
        for _t, _p, p, _a in first_instances(sim, include_dropped=True):
            tokens = p.to_tokens(order)  # type: ignore[arg-type]
            for _ in range(12):
                programs.append(token_edits(tokens, rng))
                on.append(sim)
    result = assert_same(programs, on, order)
    counts = result.counts()
    assert counts["syntax_error"] > 100 and counts["type_error"] > 100 and counts["answer"] > 10, counts


def test_edited_node_lists_and_texts_as_alone(sims: list[Simulation]) -> None:
    rng = random.Random(3)
    sim = sims[1]
    nodes, texts = [], []
    for _t, _p, p, _a in first_instances(sim, include_dropped=True):
        n = p.to_nodes()
        for kind in ("type", *EDITS):
            nodes.append(edited(n, rng.randrange(len(n)), kind, rng.choice(NAMES)))
        text = str(p)
        for _ in range(4):
            i = rng.randrange(len(text))
            texts.append(text[:i] + rng.choice(['"', "(", ")", ",", "x", " ", "Events()", '"red"']) + text[i + 1:])
        quoted = text.split('"')
        for _ in range(4):  # other quoted values: other words, other spellings, no words
            values = [rng.choice(["red", "Blue", "cube", "small", "purple", "0", "", "red blue", "\u201cred"])
                      if k % 2 else part for k, part in enumerate(quoted)]
            texts.append('"'.join(values))
    result = assert_same(nodes, sim, "nodes")
    assert result.counts()["syntax_error"] and result.counts()["type_error"] and result.counts()["answer"]
    assert_same(texts, sim, "text")


def test_repeated_node_lists_hit_the_node_memo_as_alone(sims: list[Simulation]) -> None:
    """Every edit of every node of some programs, each edited list three times as separate copies, so that every
    verdict of the node memo (a node, a type error, a node left to the single-program reader) is met again
    from the memo; and values that equal a memo key's without being plain (a str subclass, a bool index)."""
    import copy

    class Word(str):
        pass

    sim = sims[0]
    nodes: list[Any] = []
    for _t, _p, p, _a in list(first_instances(sim))[:12]:
        n = p.to_nodes()
        for k in range(len(n)):
            for kind in ("type", *EDITS):
                nodes.append(edited(n, k, kind, NAMES[(k * 7 + len(nodes)) % len(NAMES)]))
        sided = [k for k, node in enumerate(n) if node["value_inputs"]]
        for k in sided[:1]:
            odd = copy.deepcopy(n)
            odd[k]["value_inputs"] = [Word(odd[k]["value_inputs"][0])]
            nodes.append(odd)
        chained = [k for k, node in enumerate(n) if node["inputs"] == [1]]
        for k in chained[:1]:
            odd = copy.deepcopy(n)
            odd[k]["inputs"] = [True]
            nodes.append(odd)
    batch = [copy.deepcopy(x) for x in nodes for _ in range(3)]
    result = assert_same(batch, sim, "nodes")
    counts = result.counts()
    assert counts["syntax_error"] and counts["type_error"] and counts["answer"], counts


def _one_edit(nodes: list[dict[str, Any]], rng: random.Random) -> list[dict[str, Any]]:
    """A copy of ``nodes`` with one random edit: a module renamed (to another module, an original name or no
    module), an input index changed (to any index, a later or negative one included), an argument dropped (an
    input or a side input), or the side inputs written as null or left out."""
    import copy

    out = copy.deepcopy(nodes)
    node = out[rng.randrange(len(out))]
    edit = rng.choice(("rename", "input", "drop input", "drop side", "null sides", "no sides"))
    if edit == "input" and node["inputs"]:
        node["inputs"][rng.randrange(len(node["inputs"]))] = rng.randrange(-1, len(out) + 1)
    elif edit == "drop input" and node["inputs"]:
        del node["inputs"][rng.randrange(len(node["inputs"]))]
    elif edit == "drop side" and node["value_inputs"]:
        del node["value_inputs"][0]
    elif edit == "null sides":
        node["value_inputs"] = None
    elif edit == "no sides":
        del node["value_inputs"]
    else:
        node["type"] = rng.choice([*NAMES, "filter_red", "Count"])
    return out


def test_node_list_keys_only_where_duplicates_pay(sims: list[Simulation], monkeypatch: pytest.MonkeyPatch) -> None:
    """Equal node lists are keyed while the batch repeats them: a batch of distinct lists stops making keys after
    its first block, and duplicates that begin later are still found by the blocks keyed again; the outcomes are
    those of each program alone either way."""
    import copy

    from craft_dsl.oracle import batch as batch_module

    rng = random.Random(5)
    make_key = batch_module.node_list_key
    seen: set[Any] = set()
    distinct: list[Any] = []  # template node lists and edited copies of them, no two equal
    for sim in sims[:2]:
        for _t, _p, p, _a in first_instances(sim, include_dropped=True):
            gold = p.to_nodes()
            for nodes in [gold] + [_one_edit(gold, rng) for _ in range(7)]:
                key = make_key(nodes)
                if key not in seen:
                    seen.add(key)
                    distinct.append(nodes)
    block, probe = batch_module.KEY_BLOCK, batch_module.KEY_PROBE
    assert len(distinct) >= probe * block
    keys: list[int] = []

    def counting(nodes: list[Any]) -> Any:
        keys.append(1)
        return make_key(nodes)

    monkeypatch.setattr(batch_module, "node_list_key", counting)
    head = distinct[:4 * block]
    assert_same(head, sims[0], "nodes")
    assert len(keys) == block  # the first block found no duplicate: the next three (before a probe) make none
    keys.clear()
    repeated = [copy.deepcopy(n) for n in head[:block] for _ in range(8)]  # 8 equal copies each, after the head
    read: list[int] = []
    original = batch_module._Batch.read_node_lists_all

    def reading(self: Any, lists: Sequence[Any]) -> list[int | None]:
        read.append(len(lists))
        return original(self, lists)

    monkeypatch.setattr(batch_module._Batch, "read_node_lists_all", reading)
    programs = distinct[:probe * block] + repeated
    assert_same(programs, sims[0], "nodes")
    # The head's blocks after the first are keyed again only at the probe; from there on every block repeats.
    assert read[0] < len(programs) - len(repeated) // 2


def test_duplicated_and_edited_node_lists_as_alone(sims: list[Simulation], monkeypatch: pytest.MonkeyPatch) -> None:
    """Every template node list 8 times over two simulations, 7 of the 8 with one edit, each program then
    repeated as the same list and as an equal copy: the outcomes are those of each program alone, and each
    distinct list is read once (half the lists keyed find an equal one: keys pay all through)."""
    import copy

    from craft_dsl.oracle.batch import _Batch

    rng = random.Random(11)
    programs: list[Any] = []
    on: list[Simulation] = []
    for sim in sims[:2]:
        for _t, _p, p, _a in first_instances(sim, include_dropped=True):
            gold = p.to_nodes()
            for copy_k in range(8):
                program = gold if copy_k == 0 else _one_edit(gold, rng)
                programs += [program, program, copy.deepcopy(program)]
                on += [sim] * 3
            chained = [k for k, node in enumerate(gold) if node["inputs"] == [1]]
            for k in chained[:1]:  # equal under == to the gold, not the same program: not its duplicate
                for index in (True, 1.0):
                    odd = copy.deepcopy(gold)
                    odd[k]["inputs"] = [index]
                    programs += [odd, odd, copy.deepcopy(odd)]
                    on += [sim] * 3
    read: list[int] = []
    original = _Batch.read_node_lists_all

    def counting(self: _Batch, lists: Sequence[Any]) -> list[int | None]:
        read.append(len(lists))
        return original(self, lists)

    monkeypatch.setattr(_Batch, "read_node_lists_all", counting)
    result = assert_same(programs, on, "nodes")
    assert read == [len({repr(x) for x in programs})]  # equal lists have equal reprs here (1.0 and 1 do not)
    counts = result.counts()
    assert all(counts.values()), counts
    codes = result.codes.tolist()
    assert all(codes[i] == codes[i + 1] == codes[i + 2] for i in range(0, len(codes), 3))


def test_sampled_duplicates_as_alone(sims: list[Simulation]) -> None:
    """Runs of equal node lists in other objects (as a sampler gives them: the benchmark's 8 copies), some runs
    interleaved with edited copies, broken copies (a syntax error, a type error, a non-exact index, a list
    marshal does not take) and the same object again, on one simulation and on one simulation per program:
    every program gets the outcome it gets alone, and copies on other simulations do not share answers."""
    import copy

    class Index(int):
        pass

    rng = random.Random(17)
    programs: list[Any] = []
    on: list[Simulation] = []
    plain: list[bool] = []
    for sim in sims:
        for _t, _p, p, _a in list(first_instances(sim, include_dropped=True))[:25]:
            gold = p.to_nodes()
            broken = copy.deepcopy(gold)
            broken[-1]["type"] = "no_such_module"
            typed = copy.deepcopy(gold)
            typed[-1]["inputs"] = [0] if typed[-1]["inputs"] else []
            chained = [k for k, node in enumerate(gold) if node["inputs"] == [0]]
            odd = copy.deepcopy(gold)
            for k in chained[:1]:
                odd[k]["inputs"] = [rng.choice((False, 0.0, Index(0)))]  # == gold, read alone: not its duplicate
            unmarshallable = copy.deepcopy(gold)
            unmarshallable[0]["extra"] = object()
            for base in (gold, broken, typed, odd, unmarshallable):
                run = [copy.deepcopy(base) for _ in range(8)]
                if rng.random() < 0.5:
                    run[rng.randrange(8)] = _one_edit(base, rng)
                    run[rng.randrange(8)] = run[0]  # the same object again
                programs += run
                on += [sim] * len(run)
                plain += [base is not unmarshallable] * len(run)
    for batch, batch_on in ((programs, on),  # a list marshal does not take: every list keyed on its own
                            ([p for p, ok in zip(programs, plain) if ok], [s for s, ok in zip(on, plain) if ok])):
        counts = assert_same(batch, batch_on, "nodes").counts()
        assert all(counts.values()), counts
        first = [p for p, s in zip(batch, batch_on) if s is sims[0]]
        assert_same(first, sims[0], "nodes")
        # The same copies alternating between two simulations: each copy answers on its own simulation.
        pairs = [copy.deepcopy(batch[k]) for k in range(0, 200, 8) for _ in range(4)]
        assert_same(pairs, [sims[k % 2] for k in range(len(pairs))], "nodes")


@pytest.mark.parametrize("order", ["prefix", "postfix"])
def test_token_list_batches_as_alone(sims: list[Simulation], order: str) -> None:
    """Batches of token lists only (read in single passes over the batch) with tokens the batch reader leaves to
    the single-program reader (other spellings, integers written otherwise, non-strings), repeated; and the same
    batches with an unhashable token, an empty list or a tuple among them (read program by program)."""
    rng = random.Random(13)
    sim = sims[2]
    odd: list[Any] = ["count", "events", "+1", "007", 5, None, "Red", "FILTER_COLOR", "filter_color"]
    batch: list[Any] = []
    for _t, _p, p, _a in first_instances(sim, include_dropped=True):
        tokens = p.to_tokens(order)  # type: ignore[arg-type]
        batch += [tokens, token_edits(tokens, rng)]
        edited_tokens = list(tokens)
        edited_tokens[rng.randrange(len(tokens))] = rng.choice(odd)
        batch += [edited_tokens, list(edited_tokens)]
    result = assert_same(batch, sim, order)
    assert result.counts()["answer"] and result.counts()["syntax_error"] and result.counts()["type_error"]
    for other in (["Count", ["x"]], [], ("Count", "Events")):
        assert_same([*batch[:40], other, *batch[:40]], sim, order)


def test_the_shared_text_scanner() -> None:
    """craft_dsl.parser.scan_calls, the scanner of fast_check and of the batch text reader: each call closed once,
    in the order of its closing parenthesis, with its arguments as the hooks give them; None for what the
    grammar must decide, and where a hook gives up."""
    from craft_dsl.parser import GiveUp, scan_calls

    closed: list[tuple[str, list[Any], int]] = []

    def close(state: list[str], frame: Any) -> str:
        spec, _n_inputs, _arity, args, index = frame
        closed.append((spec.name, list(args), index))
        if spec.name in state:
            raise GiveUp
        return spec.name

    def input_value(state: Any, spec: Any, k: int, value: Any) -> tuple[str, Any]:
        return ("input", value)

    text = 'EqualColor(QueryColor(Unique(FilterColor(SceneAtStart(), "red"))), "blue")'
    root, items = scan_calls(text, [], close, input_value)  # type: ignore[misc]
    assert root == "EqualColor" and items == ["EqualColor", "QueryColor", "Unique", "FilterColor", "SceneAtStart"]
    assert closed == [("SceneAtStart", [], 4), ("FilterColor", ["SceneAtStart", "red"], 3),
                      ("Unique", ["FilterColor"], 2), ("QueryColor", ["Unique"], 1),
                      ("EqualColor", ["QueryColor", ("input", "blue")], 0)]
    side = scan_calls(text, [], close, input_value, lambda state, spec, k, value: ("side", k, value))
    assert side is not None and closed[-4][1] == ["SceneAtStart", ("side", 1, "red")]
    for bad in ("", "Count(", "Count(Events()) x", "Var(x, Events(), Count(x))", '"red"', "Count(Events(),)",
                "Count(Events() Events())", "Count(Events(), 7, 8)"):
        assert scan_calls(bad, [], close, input_value) is None, bad
    assert scan_calls(text, ["Unique"], close, input_value) is None


def test_mixed_forms_detected_per_program(sims: list[Simulation]) -> None:
    """form=None: a string is text, a list of objects a node list, a list of strings prefix tokens."""
    sim = sims[2]
    mixed: list[Any] = []
    for _t, _p, p, _a in first_instances(sim, include_dropped=True):
        mixed += [str(p), p.to_nodes(), p.to_tokens("prefix"), tuple(p.to_tokens("prefix")), " ".join(p.to_tokens())]
    mixed += [[], "", "Count(", ["Count", "Events", "Events"], [{"type": "count", "inputs": []}]]
    assert_same(mixed, sim, None)
    for order in ("prefix", "postfix"):  # space-separated token strings, with the order given
        spaced = [" ".join(p.to_tokens(order)) for _t, _p, p, _a in first_instances(sim)]  # type: ignore[arg-type]
        assert_same(spaced + ["", "  ", "Count Events Events"], sim, order)


@SETTINGS
@given(program=programs(), form=st.sampled_from(("prefix", "postfix", "text")), rng=st.randoms(use_true_random=False))
def test_drawn_programs_as_alone(e1: Simulation, program: Program, form: str, rng: random.Random) -> None:
    """Drawn programs (any type, bindings, literals) and edits of their tokens, on E1 and on a hand-made scene
    whose counterfactuals are missing for some objects."""
    batch: list[Any] = [in_form(program, form)]
    if form != "text":
        batch += [token_edits(batch[0], rng) for _ in range(4)]
    else:  # the text again, and with its quoted values and integers changed
        batch += [batch[0], re.sub(r'"[^"]*"|\b\d+\b', lambda m: rng.choice(['"red"', '"cube"', "1", '"large"']),
                                   batch[0])]
    for sim in (e1, _basic()):
        assert_same(batch, sim, form)


@SETTINGS
@given(node_lists(), st.integers(0, 100), st.sampled_from(("type", *EDITS)), st.sampled_from(NAMES))
def test_drawn_node_lists_as_alone(nodes: list[dict[str, Any]], at: int, kind: str, name: str) -> None:
    assert_same([nodes, edited(nodes, at % len(nodes), kind, name)], _basic(), "nodes")


_BASIC: list[Simulation] = []


def _basic() -> Simulation:
    """BASIC_OBJECTS with counterfactuals for objects 1 and 3 only (asking for another is INVALID)."""
    if not _BASIC:
        _BASIC.append(make_sim(BASIC_OBJECTS, [(40, "Collision", 3, 2), (80, "EnterBasket", 5, 2),
                                               (140, "Collision", 1, 6)],
                               {3: [(40, "Collision", 0, 4)], 1: []}))
    return _BASIC[0]


# -- shared work -----------------------------------------------------------------------------------------------


def test_each_node_is_evaluated_once_per_simulation(sims: list[Simulation], monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[int, Any]] = []
    real = IMPLS["FilterColor"]

    def counting(sim: Simulation, objs: Any, color: str) -> Any:
        calls.append((id(sim), color))
        return real(sim, objs, color)

    monkeypatch.setitem(IMPLS, "FilterColor", counting)
    texts = ['Count(FilterColor(SceneAtStart(), "red"))', 'Exist(FilterColor(SceneAtStart(), "red"))',
             'QueryShape(Unique(FilterColor(SceneAtStart(), "red")))', 'Count(FilterColor(SceneAtStart(), "blue"))']
    batch = texts * 5
    on = [sims[k // len(texts) % 2] for k in range(len(batch))]  # each round of the texts on one simulation
    assert_same(batch, on, "text")
    calls.clear()
    run_batch(batch, on, form="text")
    assert sorted(calls) == sorted({(id(s), c) for s in sims[:2] for c in ("red", "blue")})


def test_each_counterfactual_is_computed_once_per_simulation_and_object() -> None:
    asked: list[int] = []
    sim = make_sim(BASIC_OBJECTS, [(40, "Collision", 3, 2), (140, "Collision", 1, 6)],
                   {o: [(60, "Collision", 1 if o == 0 else 0, 6)] for o in (0, 1, 2, 3)})
    source = sim._counterfactuals
    assert source is not None

    def counting(obj: int) -> Simulation:
        asked.append(obj)
        return source(obj)

    sim._counterfactuals = counting
    batch = ["AnyTrue(ExistList(GetCounterfactEventsList(FilterDynamic(SceneAtStart()))))",
             "Count(GetCounterfactEvents(Unique(FilterColor(SceneAtStart(), \"red\"))))",
             "Exist(FilterCollision(GetCounterfactEvents(Unique(FilterShape(SceneAtStart(), \"cube\")))))",
             "AnyTrue(ExistList(FilterCollideGroundList(GetCounterfactEventsList(FilterDynamic(SceneAtStart())))))"]
    result = run_batch(batch * 3, sim, form="text")
    assert sorted(asked) == [0, 1, 2, 3]
    assert result.kinds == ["answer"] * 12
    assert batched(result) == alone(batch * 3, sim, "text")


# -- the result ---------------------------------------------------------------------------------------------------


def test_result_columns(sims: list[Simulation]) -> None:
    sim = sims[0]
    batch = ['Count(FilterDynamic(SceneAtStart()))', "Count(", 'Count(QueryColor(Unique(SceneAtStart())))',
             'QueryColor(Unique(SceneAtStart()))', 'Exist(FilterColor(SceneAtStart(), "red"))']
    result = run_batch(batch, sim)
    assert isinstance(result.codes, np.ndarray) and result.codes.dtype == np.int8
    assert result.codes.tolist() == [ANSWER, SYNTAX_ERROR, TYPE_ERROR, INVALID_ANSWER, ANSWER]
    assert result.kinds == [OUTCOMES[c] for c in result.codes.tolist()]
    assert result.answers[0] == Program.parse(batch[0]).run(sim) and result.answers[1:4] == [None] * 3
    assert len(result) == 5 and result.counts() == {"syntax_error": 1, "type_error": 1, "invalid": 1, "answer": 2}


def test_rewards(sims: list[Simulation]) -> None:
    sim = sims[0]
    count = Program.parse("Count(FilterDynamic(SceneAtStart()))").run(sim)
    batch = ["Count(FilterDynamic(SceneAtStart()))", "Count(SceneAtStart())", "Count(",
             "QueryColor(Unique(SceneAtStart()))", "Exist(FilterDynamic(SceneAtStart()))"]
    result = run_batch(batch, sim)
    assert result.rewards(str(count)).tolist() == [1.0, 0.0, 0.0, 0.0, 0.0]
    assert result.rewards(count, wrong=-0.5, error=-1.0, invalid=-0.25).tolist() == [1.0, -0.5, -1.0, -0.25, -0.5]
    per_program = [count, count, count, "red", "True"]
    assert result.rewards(per_program).tolist() == [1.0, 0.0, 0.0, 0.0, 1.0]
    assert result.rewards(per_program, error=0.1).tolist() == [1.0, 0.0, 0.1, 0.0, 1.0]
    assert result.rewards([[1], None, 2, 3, "yes"]).tolist() == [0.0, 0.0, 0.0, 0.0, 1.0]
    assert result.rewards(np.array(per_program, dtype=object)).tolist() == [1.0, 0.0, 0.0, 0.0, 1.0]
    with pytest.raises(CraftError, match="rewards: 2 gold answers for 5 programs"):
        result.rewards([1, 2])


# -- bad input ----------------------------------------------------------------------------------------------------


def test_bad_batches_are_refused_precisely(sims: list[Simulation]) -> None:
    sim = sims[0]
    with pytest.raises(CraftError, match=r"run_batch: 3 programs but 2 simulations; pass one simulation for every "
                                         r"program, or a list with one simulation per program"):
        run_batch(["Count(Events())"] * 3, [sim, sim])
    with pytest.raises(CraftError, match=r"run_batch: unknown program form 'tokens'; allowed: text, nodes, prefix, "
                                         r"postfix, or None"):
        run_batch(["Count(Events())"], sim, form="tokens")  # type: ignore[arg-type]
    with pytest.raises(CraftError, match="run_batch: programs must be a list of programs, found str"):
        run_batch("Count(Events())", sim)
    with pytest.raises(CraftError, match="run_batch: simulation 1 is a str, not a Simulation"):
        run_batch(["Count(Events())"] * 2, [sim, "e1"])  # type: ignore[list-item]
    with pytest.raises(CraftError, match="run_batch: sims must be a Simulation or a list of them, found NoneType"):
        run_batch(["Count(Events())"], None)  # type: ignore[arg-type]
    # A program that running alone refuses (not a program at all) is refused, naming it.
    with pytest.raises(CraftError, match=r"run_batch: program 1: a program must be DSL text"):
        run_batch(["Count(Events())", 42], sim)
    with pytest.raises(CraftError, match=r"run_batch: program 0: a text program must be a string"):
        run_batch([["Count", "Events"]], sim, form="text")
    assert gc.isenabled()  # the collector is on again after a refusal
    assert len(run_batch([], sim)) == 0


# -- determinism -----------------------------------------------------------------------------------------------------


def test_results_do_not_depend_on_the_batch(sims: list[Simulation]) -> None:
    """The same batch twice, shuffled, and each program in a batch of its own give the same results."""
    rng = random.Random(11)
    sim = sims[1]
    batch = [token_edits(p.to_tokens(), rng) if rng.random() < 0.5 else p.to_tokens()
             for _t, _p, p, _a in first_instances(sim, include_dropped=True) for _ in range(3)]
    first = batched(run_batch(batch, sim, form="prefix"))
    assert batched(run_batch(batch, sim, form="prefix")) == first
    order = list(range(len(batch)))
    rng.shuffle(order)
    shuffled = batched(run_batch([batch[i] for i in order], sim, form="prefix"))
    assert shuffled == [first[i] for i in order]
    assert [batched(run_batch([p], sim, form="prefix"))[0] for p in batch[:40]] == first[:40]


def test_nothing_outlives_a_batch(sims: list[Simulation]) -> None:
    """The node table, memos and node values go with the call (the checker keeps only its tables of token kinds
    and of type combinations no overload accepts, which stop growing), and a batch's peak memory grows with
    the batch."""
    from craft_dsl import checker
    from craft_dsl.oracle import batch as batch_module

    rng = random.Random(5)
    sim = sims[1]
    golds = [p.to_tokens() for _t, _p, p, _a in first_instances(sim, include_dropped=True)]
    batch = [token_edits(rng.choice(golds), rng) for _ in range(3000)]
    run_batch(batch, sim, form="prefix")
    tables = (len(checker._NO_OVERLOAD), len(checker._INPUT_TYPES), len(checker.RESOLUTIONS))
    tracemalloc.start()
    try:
        run_batch(batch, sim, form="prefix")
        _now, big = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        run_batch(batch[:1000], sim, form="prefix")
        _now, small = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert small < big * 0.6, (small, big)
    assert (len(checker._NO_OVERLOAD), len(checker._INPUT_TYPES), len(checker.RESOLUTIONS)) == tables
    assert not [o for o in gc.get_objects() if type(o) is batch_module._Batch]


# -- near duplicates: equal under ==, not the same program ------------------------------------------------------


class _Word(str):
    pass


class _Index(int):
    pass


class _Node(dict):
    pass


class _Inputs(list):
    pass


#: How a twin of a node list differs from it while equal to it under == (or, for the last two, not equal at all).
TWINS = ("bool index", "float index", "int subclass index", "numpy index", "str subclass name",
         "str subclass side", "key order", "dict subclass", "list subclass inputs", "str side / int side",
         "tuple inputs")


def _twin(nodes: list[dict[str, Any]], kind: str, at: int) -> tuple[list[Any], list[Any]]:
    """(a list, its twin): ``nodes`` and a copy with node ``at`` changed as ``kind`` says (see :data:`TWINS`);
    a kind that does not apply to the node list changes its last node's name to a str subclass."""
    import copy

    base: list[Any] = copy.deepcopy(nodes)
    twin: list[Any] = copy.deepcopy(nodes)
    k = at % len(nodes)
    node = twin[k]
    inputs = [j for j, node in enumerate(nodes) if node["inputs"]]
    sided = [j for j, node in enumerate(nodes) if node.get("value_inputs")]
    if kind.endswith(" index") and inputs:
        node = twin[inputs[at % len(inputs)]]
        i = node["inputs"][0]
        if kind == "bool index" and i in (0, 1):
            node["inputs"][0] = bool(i)
        elif kind == "int subclass index":
            node["inputs"][0] = _Index(i)
        elif kind == "numpy index":
            node["inputs"][0] = np.int64(i)
        else:
            node["inputs"][0] = float(i)
    elif kind == "str subclass side" and sided:
        node = twin[sided[at % len(sided)]]
        node["value_inputs"][0] = _Word(node["value_inputs"][0])
    elif kind == "str side / int side" and sided:
        j = sided[at % len(sided)]
        base[j]["value_inputs"][0] = "1"
        twin[j]["value_inputs"][0] = 1
    elif kind == "key order":
        twin[k] = dict(reversed(node.items()))
    elif kind == "dict subclass":
        twin[k] = _Node(node)
    elif kind == "list subclass inputs":
        node["inputs"] = _Inputs(node["inputs"])
    elif kind == "tuple inputs":
        node["inputs"] = tuple(node["inputs"])
    else:
        twin[-1]["type"] = _Word(twin[-1]["type"])
    return base, twin


@SETTINGS
@given(nodes=node_lists(), kind=st.sampled_from(TWINS), at=st.integers(0, 100),
       picks=st.lists(st.tuples(st.booleans(), st.booleans()), min_size=2, max_size=12),
       per_program=st.booleans(), as_tuple=st.booleans())
def test_drawn_near_duplicates_as_alone(e1: Simulation, nodes: list[dict[str, Any]], kind: str, at: int,
                                        picks: list[tuple[bool, bool]], per_program: bool, as_tuple: bool) -> None:
    """A node list and its twin (equal under ==, or nearly: a bool, float, int subclass or numpy index for an
    int, a str subclass, another key order, a dict or list subclass; a str side value for an int one), each as
    fresh copies or as the same object again, in any order, on one simulation or on two in turn: every program
    gets its outcome alone, so no two of them were read as one unless they are the same program."""
    import copy

    base, twin = _twin(nodes, kind, at)
    batch: list[Any] = []
    for is_twin, fresh in picks:
        program = twin if is_twin else base
        batch.append(copy.deepcopy(program) if fresh else program)
    on = [e1 if k % 2 or not per_program else _basic() for k in range(len(batch))]
    programs: Sequence[Any] = tuple(batch) if as_tuple else batch
    assert_same(programs, on if per_program else _basic(), "nodes")
