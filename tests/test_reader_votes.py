"""Counterfactual answers voted over perturbed replays: the perturbed model, the majority rule, the CLI option."""

from __future__ import annotations

import itertools
from collections import Counter
from typing import Any

import numpy as np
import pytest

from craft_dsl import parse
from craft_dsl.errors import CraftError, PerceptionError
from craft_dsl.perception import ExecutionOptions, SceneModel, export_perceived
from craft_dsl.physics import simulate
from craft_dsl.reader import votes as votes_module
from craft_dsl.reader.answer import Answer, Question, format_answer
from craft_dsl.reader.votes import VOTES, decided, uses_counterfactuals, vote_counterfactuals
from craft_dsl.templates import first_instances

#: A counterfactual question of the kind CRAFT asks (how many objects enter the basket without the red one).
COUNTERFACTUAL = ("Count(FilterDynamic(FilterObjectsFromEvents(FilterEnterBasket(GetCounterfactEvents("
                  "Unique(FilterColor(SceneAtStart(), \"red\")))))))")


@pytest.fixture(scope="module")
def model() -> SceneModel:
    return SceneModel(export_perceived(simulate(3, 7)))


def test_a_perturbed_model_scales_each_dynamic_body_s_velocities_by_one_factor(model: SceneModel) -> None:
    base = model.base_run.trajectory
    other = model.perturbed(1000, 0.05)
    assert other.physics is model.physics and other.states is model.states  # the fit is shared, not redone
    got = other.base_run.trajectory
    np.testing.assert_array_equal(got.positions, base.positions)
    dynamic = [b.dynamic for b in model.physics.world.bodies]
    moving = np.abs(base.velocities) > 1e-9
    for column, is_dynamic in enumerate(dynamic):
        mask = moving[:, column]
        if not mask.any():
            continue
        ratio = got.velocities[:, column][mask] / base.velocities[:, column][mask]
        if is_dynamic:
            assert np.allclose(ratio, ratio[0]) and 0.95 <= ratio[0] <= 1.05 and ratio[0] != 1.0
        else:
            np.testing.assert_array_equal(ratio, 1.0)
    again = model.perturbed(1000, 0.05).base_run.trajectory.velocities
    np.testing.assert_array_equal(again, got.velocities)  # one seed, one perturbation
    assert not np.array_equal(model.perturbed(1001, 0.05).base_run.trajectory.velocities, got.velocities)


def test_a_perturbed_model_leaves_the_model_s_own_counterfactuals_alone(model: SceneModel) -> None:
    uid = next(b.uid for b in model.physics.world.bodies if b.dynamic)
    own = [(e.type, e.step, e.objects) for e in model.counterfactual_run(uid).events]
    perturbed = model.perturbed(7, 0.05)
    perturbed.counterfactual_run(uid)
    assert [(e.type, e.step, e.objects) for e in model.counterfactual_run(uid).events] == own
    unchanged = model.perturbed(7, 0.0).counterfactual_run(uid)
    assert [(e.type, e.step, e.objects) for e in unchanged.events] == own


def test_only_the_replay_mode_has_perturbed_replays() -> None:
    resimulated = SceneModel(export_perceived(simulate(3, 7)), ExecutionOptions(counterfactual="resimulate"))
    with pytest.raises(PerceptionError, match="replay"):
        resimulated.perturbed(0, 0.05)


def test_a_program_reads_counterfactuals_where_a_counterfactual_module_is_in_it() -> None:
    assert uses_counterfactuals(parse(COUNTERFACTUAL))
    assert not uses_counterfactuals(parse("Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround("
                                          "Events()))))"))


# -- the majority rule, with stand-ins whose answers each replay decides ------------------------------------------


class _Replay:
    def __init__(self, seed: int) -> None:
        self.seed = seed

    def simulation(self) -> int:
        return self.seed


class _Model:
    """``perturbed(seed, amount)``: a replay whose simulation is its seed's offset from the first."""

    def perturbed(self, seed: int, amount: float) -> _Replay:
        assert amount == votes_module.VOTE_AMOUNT
        return _Replay(seed - votes_module.VOTE_SEED)


class _Program:
    """Answers ``answers[k]`` on the k-th perturbed replay (an exception object: raised)."""

    def __init__(self, answers: list[Any], counterfactual: bool = True) -> None:
        self.answers = answers
        self.counterfactual = counterfactual

    def run(self, k: int) -> Any:
        value = self.answers[k]
        if isinstance(value, BaseException):
            raise value
        return value


def _vote(monkeypatch: pytest.MonkeyPatch, cases: list[tuple[Answer, _Program]], votes: int) -> list[Answer]:
    programs = {a.program: p for a, p in cases}
    monkeypatch.setattr(votes_module, "parse", lambda text: programs[text])
    monkeypatch.setattr(votes_module, "uses_counterfactuals", lambda p: p.counterfactual)
    return vote_counterfactuals(_Model(), [a for a, _ in cases], votes)  # type: ignore[arg-type]


def _answer(index: int, answer: str, **extra: Any) -> Answer:
    return Answer(Question(1, index, f"question {index}?"), answer, program=f"p{index}", **extra)


def test_the_majority_of_the_replays_answers_and_a_tie_keeps_the_reader_s_own(
        monkeypatch: pytest.MonkeyPatch) -> None:
    got = _vote(monkeypatch, [
        (_answer(0, "False"), _Program([True, True, False, True])),  # 3 True against 2 False
        (_answer(1, "False"), _Program([True, True, False, False])),  # 2 True against 3 False
        (_answer(2, "1"), _Program([2, 2, 1, 0])),  # a tie: 2 and 1 twice each
        (_answer(3, "1"), _Program([2, 2, 0, 0])),  # a tie of two other answers, each ahead of the own one
    ], votes=4)
    assert [a.answer for a in got] == ["True", "False", "1", "0"]
    assert got[0].votes == {"False": 2, "True": 3}
    assert got[2].votes == {"0": 1, "1": 2, "2": 2}
    assert got[3].votes == {"0": 2, "1": 1, "2": 2}


def test_a_replay_without_an_answer_does_not_vote(monkeypatch: pytest.MonkeyPatch) -> None:
    from craft_dsl import INVALID

    got = _vote(monkeypatch, [(_answer(0, "True"), _Program([CraftError("no basket"), INVALID, False, False]))],
                votes=4)
    assert got[0].answer == "False" and got[0].votes == {"False": 2, "True": 1}


def test_guesses_premises_distribution_modes_and_other_questions_are_not_voted(
        monkeypatch: pytest.MonkeyPatch) -> None:
    cases = [(_answer(0, "False", fallback=True), _Program([True] * 3)),
             (_answer(1, "False", premise="object 2 read as red"), _Program([True] * 3)),
             (_answer(2, "False", probability=0.6), _Program([True] * 3)),
             (_answer(3, "False"), _Program([True] * 3, counterfactual=False))]
    got = _vote(monkeypatch, cases, votes=3)
    assert got == [a for a, _ in cases]


def test_no_votes_leave_every_answer_as_it_is(monkeypatch: pytest.MonkeyPatch) -> None:
    answer = _answer(0, "False")
    assert _vote(monkeypatch, [(answer, _Program([]))], votes=0) == [answer]


# -- on a perceived scene ------------------------------------------------------------------------------------------


def test_votes_on_a_perceived_scene_are_recorded_and_the_same_every_time(model: SceneModel) -> None:
    sim = model.simulation()
    answers = []
    for template, _params, program, _truth in first_instances(simulate(3, 7), include_dropped=True):
        if uses_counterfactuals(program):
            answers.append(Answer(Question(3, len(answers), template.id), format_answer(program.run(sim)),
                                  program=str(program)))
    assert len(answers) >= 5
    first = vote_counterfactuals(model, answers)
    assert first == vote_counterfactuals(model, answers)
    for a in first:
        assert a.votes is not None and sum(a.votes.values()) <= VOTES + 1
        assert a.answer in a.votes and a.votes[a.answer] == max(a.votes.values())
    # a scene exported from its own simulation: nearby starts give the same answers as the run itself
    assert [a.answer for a in first] == [a.answer for a in answers]


def test_a_question_stops_being_replayed_once_its_majority_is_decided(monkeypatch: pytest.MonkeyPatch) -> None:
    stable = _Program([True, True, True, False, False, False])
    got = _vote(monkeypatch, [(_answer(0, "True"), stable)], votes=6)
    assert got[0].answer == "True" and got[0].votes == {"True": 4}  # 4 of 7 after three replays: decided


def _winner(tally: Counter[str], own: str) -> str:
    best = max(tally.values())
    return own if tally[own] == best else min(v for v, n in tally.items() if n == best)


def test_a_decided_majority_is_the_majority_of_every_way_the_votes_left_can_fall() -> None:
    values = ("a", "b", "c")
    for counts in itertools.product(range(4), repeat=3):
        for own in values:
            tally = Counter({v: n for v, n in zip(values, counts) if n})
            tally[own] += 1
            for left in range(4):
                finals = set()
                for rest in itertools.product(values, repeat=left):
                    finals.add(_winner(tally + Counter(rest), own))
                if decided(tally, own, left):
                    assert finals == {_winner(tally, own)}, (dict(tally), own, left)
                others = max((n for v, n in tally.items() if v != own), default=0)
                if tally[own] >= others + left:  # the stable case: the replays so far agree with the own answer
                    assert decided(tally, own, left)
