"""Answer distributions: exact enumeration matches hand computation, Monte Carlo agrees within its standard error,
scores and JSON form."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from perception_helpers import tiny_scene

from craft_dsl import Program
from craft_dsl.errors import PerceptionError
from craft_dsl.perception import PerceivedScene
from craft_dsl.perception.distribution import (
    AnswerDistribution,
    answer_distribution,
    answer_distributions,
    reading_count,
    scene_factors,
)
from craft_dsl.perception.world import SceneModel

RED = Program.parse('Count(FilterColor(SceneAtStart(), "red"))')
GROUND = Program.parse("Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))")
CUBE_COLOR = Program.parse('QueryColor(Unique(FilterShape(SceneAtStart(), "cube")))')
MOVING = Program.parse("Exist(FilterMoving(SceneAtStart(), StartSceneStep()))")


def _uncertain(cube_red: float = 0.7, circle_red: float = 0.4, confidence: float = 0.9, cube_shape: float = 1.0,
               moving: float = 1.0) -> PerceivedScene:
    scene = tiny_scene()
    objects = []
    for o in scene.objects:
        if o.id == 1:
            shape = {"cube": cube_shape, "triangle": 1 - cube_shape} if cube_shape < 1 else {"cube": 1.0}
            o = o.model_copy(update={"color": {"red": cube_red, "green": 1 - cube_red}, "shape": shape})
        elif o.id == 0:
            o = o.model_copy(update={"color": {"red": circle_red, "blue": 1 - circle_red}, "moving_start": moving})
        objects.append(o)
    events = [e.model_copy(update={"confidence": confidence}) if e.type == "Collision" else e
              for e in scene.events or ()]
    return scene.model_copy(update={"objects": objects, "events": events})


def test_exact_enumeration_matches_hand_computation() -> None:
    red, ground = answer_distributions(_uncertain(), [RED, GROUND])
    assert red.method == "exact" and red.samples == 2 * 2 * 2
    assert red.probabilities == pytest.approx({"1": 0.7 * 0.6 + 0.3 * 0.4, "2": 0.28, "0": 0.18})
    assert list(red.probabilities) == ["1", "2", "0"]  # most likely first
    assert red.mode == 1 and red.p(2) == pytest.approx(0.28) and red.p("2") == red.p(2.0)
    assert ground.probabilities == pytest.approx({"1": 0.9, "0": 0.1})
    assert red.standard_errors == {} and red.invalid == 0.0


def test_readings_where_the_question_has_no_answer_are_left_out() -> None:
    dist = answer_distribution(_uncertain(cube_shape=0.75), CUBE_COLOR)
    # the cube is a triangle in a quarter of the readings: "the cube" does not exist there
    assert dist.invalid == pytest.approx(0.25)
    assert dist.probabilities == pytest.approx({"red": 0.7, "green": 0.3})


def test_moving_and_dynamic_flags_are_factors() -> None:
    dist = answer_distribution(_uncertain(moving=0.3), MOVING)
    assert dist.probabilities == pytest.approx({"false": 0.7, "true": 0.3})
    kinds = {f.kind for f in scene_factors(SceneModel(_uncertain(moving=0.3)))}
    assert kinds == {"color", "moving_start", "event"}


@settings(max_examples=8, deadline=None)
@given(st.floats(0.05, 0.95), st.floats(0.05, 0.95), st.floats(0.05, 0.95), st.integers(0, 2**16))
def test_monte_carlo_agrees_with_enumeration_within_its_standard_error(cube_red: float, circle_red: float,
                                                                         confidence: float, seed: int) -> None:
    scene = _uncertain(cube_red, circle_red, confidence, cube_shape=0.8, moving=0.6)
    model = SceneModel(scene)
    assert reading_count(scene_factors(model)) == 32
    exact = answer_distributions(model, [RED, GROUND, CUBE_COLOR, MOVING])
    sampled = answer_distributions(model, [RED, GROUND, CUBE_COLOR, MOVING], bound=1, samples=600, seed=seed)
    for e, m in zip(exact, sampled):
        assert m.method == "monte_carlo" and m.samples == 600
        for key in set(e.probabilities) | set(m.probabilities):
            se = m.standard_errors.get(key, 0.0)
            assert abs(e.probabilities.get(key, 0.0) - m.probabilities.get(key, 0.0)) <= 5 * max(se, 0.01), key


def test_monte_carlo_is_deterministic_in_its_seed() -> None:
    scene = _uncertain()
    a = answer_distribution(scene, RED, bound=1, samples=50, seed=3)
    b = answer_distribution(scene, RED, bound=1, samples=50, seed=3)
    assert a == b
    with pytest.raises(PerceptionError, match="at least 1"):
        answer_distribution(scene, RED, samples=0)


def test_scores_and_json_round_trip() -> None:
    dist = answer_distribution(_uncertain(), RED)
    assert dist.log_likelihood(1) == pytest.approx(math.log(0.54))
    assert dist.log_likelihood(5) == pytest.approx(math.log(1e-6))  # floor for an impossible answer
    assert dist.brier(1) == pytest.approx((1 - 0.54) ** 2 + 0.28 ** 2 + 0.18 ** 2)
    assert dist.brier(5) == pytest.approx(0.54 ** 2 + 0.28 ** 2 + 0.18 ** 2 + 1)
    again = AnswerDistribution.from_json(dist.to_json())
    assert again == dist and again.mode == 1
    booleans = AnswerDistribution.from_json({"method": "exact", "samples": 2,
                                             "answers": [{"answer": True, "p": 0.75}, {"answer": False, "p": 0.25}]})
    assert booleans.p("true") == booleans.p(True) == booleans.p("yes") == 0.75
    assert booleans.brier(True) == pytest.approx(2 * 0.25 ** 2)
    assert AnswerDistribution.single("Red").p("red") == 1.0
    with pytest.raises(PerceptionError, match="not an answer distribution"):
        AnswerDistribution.from_json({"answers": 3})
