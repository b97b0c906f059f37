"""Per-video question generation (craft_dsl.dataset.questions): DFS, text, records, perturbation filter."""

from __future__ import annotations

import json
import re
from collections import Counter
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from craft_dsl import Simulation
from craft_dsl.dataset import generate_questions, instantiate_dfs, perturbation_filter
from craft_dsl.dataset.questions import program_nodes, render_text, star_paraphrases
from craft_dsl.dataset.synonyms import SYNONYMS
from craft_dsl.physics import LiveSimulation, simulate
from craft_dsl.program import Program, to_json
from craft_dsl.templates import paraphrases, templates
from craft_dsl.types import INVALID_JSON

RECORD_KEYS = [
    "video_filename", "video_index", "video", "question", "program", "answer", "template_filename",
    "question_family_index", "question_index", "template_id",
]

#: Three dynamic objects that all enter the basket (5): one large, two small (the original's documented example).
THREE_ENTER = [
    (6, "ground"), (5, "basket"),
    (3, "large red cube"), (2, "small blue circle"), (1, "small green triangle"),
]
THREE_ENTER_EVENTS = [(80, "EnterBasket", 5, 3), (90, "EnterBasket", 5, 2), (100, "EnterBasket", 5, 1)]


@pytest.fixture(scope="module")
def live() -> LiveSimulation:
    return simulate(20, 1)


@pytest.fixture(scope="module")
def live_questions(live: LiveSimulation) -> list[dict[str, Any]]:
    return generate_questions(live, np.random.default_rng(0), video_index=42, video_filename="videos/000042.mpg")


def _gen(sim: Simulation, seed: int, **kw: Any) -> list[dict[str, Any]]:
    return generate_questions(sim, np.random.default_rng(seed), video_index=7, video_filename="v.mpg", **kw)


class _FixedChoice:
    """A stand-in generator: every draw picks the first (or last) alternative; shuffles keep the order."""

    def __init__(self, last: bool) -> None:
        self.last = last

    def integers(self, n: int) -> int:
        return n - 1 if self.last else 0

    def permutation(self, n: int) -> np.ndarray:
        return np.arange(n)


# -- records --------------------------------------------------------------------------------------------------


def test_records_have_the_section_4_9_format(live_questions: list[dict[str, Any]]) -> None:
    assert len(live_questions) > 30
    for i, q in enumerate(live_questions):
        assert list(q) == RECORD_KEYS
        assert q["question_index"] == i
        assert q["video"] == "000042" and q["video_index"] == 42 and q["video_filename"] == "videos/000042.mpg"
        family, index = q["template_id"].rsplit("_", 1)
        assert q["template_filename"] == f"{family}.json" and q["question_family_index"] == int(index)
        assert isinstance(q["answer"], (bool, int, str)) and q["answer"] != INVALID_JSON
        for node in q["program"]:
            assert set(node) == {"type", "inputs", "value_inputs", "_output"}
    order = list(templates())
    positions = [order.index(q["template_id"]) for q in live_questions]
    assert positions == sorted(positions)  # file order, one question per template


def test_every_program_gives_its_answer(live: LiveSimulation, live_questions: list[dict[str, Any]]) -> None:
    for q in live_questions:
        program = Program.from_nodes(q["program"])
        assert to_json(program.run(live), original=True) == q["answer"], q["template_id"]
        assert q["program"][-1]["_output"] == q["answer"]


def test_program_nodes_equal_to_nodes_with_outputs(live: LiveSimulation) -> None:
    for template in templates().values():
        for _params, program, _answer in instantiate_dfs(template, live, np.random.default_rng(3)):
            assert program_nodes(program, live) == program.to_nodes(outputs=live)


def test_questions_are_deterministic_for_a_seed_and_differ_across_seeds(
    live: LiveSimulation, live_questions: list[dict[str, Any]]
) -> None:
    again = generate_questions(simulate(20, 1), np.random.default_rng(0), video_index=42,
                               video_filename="videos/000042.mpg")
    assert again == live_questions
    assert json.dumps(again).encode() == json.dumps(live_questions).encode()
    others = [json.dumps(_gen(live, seed)) for seed in (1, 2)]
    assert len({json.dumps(_gen(live, 0)), *others}) == 3


def test_template_selection_and_instances(live: LiveSimulation) -> None:
    qs = _gen(live, 0, template_ids=["prevent_4", "descriptive_3"])
    assert [q["template_id"] for q in qs] == ["descriptive_3", "prevent_4"]  # file order, not the given order
    two = _gen(live, 0, template_ids=["descriptive_0", "counterfactual_3"], instances_per_template=2)
    counts = Counter(q["template_id"] for q in two)
    assert counts == {"descriptive_0": 2, "counterfactual_3": 2}
    assert two[0]["program"] != two[1]["program"]
    with pytest.raises(ValueError, match="unknown template ids: nope_1"):
        _gen(live, 0, template_ids=["nope_1"])


# -- DFS ------------------------------------------------------------------------------------------------------


def test_fast_pruning_matches_evaluating_every_unique_prefix(live: LiveSimulation) -> None:
    for template in templates().values():
        fast = instantiate_dfs(template, live, np.random.default_rng(11), 2, fast=True)
        slow = instantiate_dfs(template, live, np.random.default_rng(11), 2, fast=False)
        assert [(p, a) for p, _, a in fast] == [(p, a) for p, _, a in slow], template.id


def test_selection_is_hierarchical(sim_builder: Callable[..., Simulation]) -> None:
    # sizes first, so the lone large object is chosen about half of the time, each small one a quarter.
    sim = sim_builder(THREE_ENTER, THREE_ENTER_EVENTS)
    template = templates()["descriptive_16"]
    picks: Counter[str] = Counter()
    for seed in range(600):
        ((params, _program, _answer),) = instantiate_dfs(template, sim, np.random.default_rng(seed))
        picks[" ".join(params[k] for k in ("<Z>", "<C>", "<S>"))] += 1
    assert set(picks) == {"large red cube", "small blue circle", "small green triangle"}
    assert 0.42 < picks["large red cube"] / 600 < 0.58
    assert 0.18 < picks["small blue circle"] / 600 < 0.32
    assert 0.18 < picks["small green triangle"] / 600 < 0.32


def test_last_value_of_the_shuffled_list_is_explored_first(sim_builder: Callable[..., Simulation]) -> None:
    sim = sim_builder(THREE_ENTER, THREE_ENTER_EVENTS)
    # Identity "shuffles": sizes (small, large) -> large first; the large red cube is the only candidate.
    ((params, _, _),) = instantiate_dfs(templates()["descriptive_16"], sim, _FixedChoice(last=False))  # type: ignore[arg-type]
    assert params == {"<Z>": "large", "<C>": "red", "<S>": "cube"}
    ((params, _, answer),) = instantiate_dfs(templates()["descriptive_0"], sim, _FixedChoice(last=False))  # type: ignore[arg-type]
    assert params == {"<S>": "circle"} and answer == 0  # shapes (cube, triangle, circle): circle first


def test_search_backtracks_over_a_when_no_b_exists(basic_sim: Simulation) -> None:
    # cause_1: B must have entered the basket and differ from A. Only object 2 enters, so A is never 2.
    template = templates()["cause_1"]
    for seed in range(40):
        ((params, _, _),) = instantiate_dfs(template, basic_sim, np.random.default_rng(seed))
        assert (params["<Z2>"], params["<C2>"], params["<S2>"]) == ("small", "blue", "circle")
        assert (params["<Z>"], params["<C>"], params["<S>"]) != ("small", "blue", "circle")


def test_templates_that_cannot_be_instantiated_yield_nothing(
    basic_sim: Simulation, sim_builder: Callable[..., Simulation]
) -> None:
    # descriptive_38 needs two objects entering the basket; basic_sim has one.
    produced = {q["template_id"] for q in _gen(basic_sim, 0)}
    assert "descriptive_38" not in produced and "descriptive_16" in produced
    assert not instantiate_dfs(templates()["descriptive_38"], basic_sim, np.random.default_rng(0))
    three = sim_builder(THREE_ENTER, THREE_ENTER_EVENTS)
    assert instantiate_dfs(templates()["descriptive_38"], three, np.random.default_rng(0))
    # counterfactual_0 needs two dynamic objects; d22-d25 need a dynamic-dynamic collision (none here).
    lone = sim_builder([(6, "ground"), (5, "basket"), (1, "small red cube")], [(50, "EnterBasket", 5, 1)],
                       {1: []})
    ids = {q["template_id"] for q in _gen(lone, 0)}
    assert "counterfactual_0" not in ids and "descriptive_22" not in ids
    assert {"descriptive_0", "descriptive_16", "counterfactual_3"} <= ids


# -- text -----------------------------------------------------------------------------------------------------


def test_text_has_no_leftover_markers(live_questions: list[dict[str, Any]]) -> None:
    for seed in range(3):
        for q in live_questions if seed == 0 else _gen(simulate(20, 1), seed):
            text = q["question"]
            assert "*" not in text and "<" not in text and ">" not in text, text
            assert text == " ".join(text.split()) and text[0].isupper() and text.endswith("?"), text


def test_text_is_rendered_as_the_original() -> None:
    texts = paraphrases()["descriptive_4"]
    first = star_paraphrases(texts, _FixedChoice(last=False))  # type: ignore[arg-type]
    assert render_text(first, {"<S>": "cube"}, _FixedChoice(last=False)) == "How many cubes enter the basket?"  # type: ignore[arg-type]
    last = star_paraphrases(texts, _FixedChoice(last=True))  # type: ignore[arg-type]
    assert render_text(last, {"<S>": "cube"}, _FixedChoice(last=True)) == "How many blocks fall into the bucket?"  # type: ignore[arg-type]
    # one synonym per distinct starred word: both *basket* of descriptive_16 agree; *enter*/*enters* are drawn
    # independently; value synonyms small -> small/tiny, colours unchanged.
    seen: set[str] = set()
    for seed in range(60):
        rng = np.random.default_rng(seed)
        text = render_text(star_paraphrases(paraphrases()["descriptive_16"], rng),
                           {"<Z>": "small", "<C>": "red", "<S>": "triangle"}, rng)
        m = re.fullmatch(r"How many objects (.+) the (\w+) after the (small|tiny) red triangle (.+) the (\w+)\?", text)
        assert m, text
        assert m.group(2) == m.group(5) and m.group(2) in SYNONYMS["basket"]
        assert m.group(1) in SYNONYMS["enter"] and m.group(4) in SYNONYMS["enters"]
        seen.add(m.group(3))
    assert seen == {"small", "tiny"}


# -- perturbation filter --------------------------------------------------------------------------------------


def test_perturbation_by_zero_keeps_everything(live: LiveSimulation, live_questions: list[dict[str, Any]]) -> None:
    same = live.perturbed(123, 0.0)
    assert same.events == live.events
    for uid in live.dynamic_ids:
        assert same.counterfactual(uid).events == live.counterfactual(uid).events
    kept, stats = perturbation_filter(live, live_questions, np.random.default_rng(5), amount=0.0)
    assert kept == live_questions
    assert set(stats) == {q["template_id"] for q in live_questions} and not any(stats.values())


def test_perturbation_drops_unstable_questions_consistently(
    live: LiveSimulation, live_questions: list[dict[str, Any]]
) -> None:
    dropped_families: Counter[str] = Counter()
    for seed in (1, 2):
        kept, stats = perturbation_filter(live, live_questions, np.random.default_rng(seed), perturbations=3)
        assert sum(stats.values()) == len(live_questions) - len(kept)
        assert set(stats) == {q["template_id"] for q in live_questions}
        assert all(n in (0, 1) for n in stats.values())  # one question per template
        kept_ids = [q["question_index"] for q in kept]
        assert kept_ids == sorted(kept_ids)
        assert all(live_questions[q["question_index"]] is q for q in kept)  # records unchanged
        assert {q["template_id"] for q in kept} == {t for t, n in stats.items() if n == 0}
        for tid, n in stats.items():
            dropped_families[tid.rsplit("_", 1)[0]] += n
        again = perturbation_filter(live, live_questions, np.random.default_rng(seed), perturbations=3)
        assert again == (kept, stats)
    assert dropped_families["descriptive"] + dropped_families["counterfactual"] > 0
