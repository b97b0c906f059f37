"""A question's premise as evidence: a question naming an object no reading holds is answered on the reading that
reads one object otherwise (craft_dsl.perception.premise), flagged, with its own confidence."""

from __future__ import annotations

import math

from craft_dsl.perception import export_perceived
from craft_dsl.perception.premise import PROBABILITY_FLOOR, premise_reading
from craft_dsl.perception.schema import PerceivedScene
from craft_dsl.perception.world import SceneModel
from craft_dsl.physics import simulate
from craft_dsl.question_parsing import question_to_program
from craft_dsl.reader.answer import Question, answer_questions
from craft_dsl.reader.confidence import PREMISE_RATE

QUESTION = "How many objects does the large red cube cause to fall to the ground?"


def _scenes() -> tuple[PerceivedScene, PerceivedScene, int]:
    """Scene 1 (seed 0: large gray, green and red cubes, a small gray cube, a large green triangle) as perceived
    exactly, and with the large red cube's colour misread as brown (certainly)."""
    sim = simulate(1, seed=0, steps=200)
    truth = export_perceived(sim)
    red = next(o.id for o in sim.objects if (o.color, o.shape, o.size) == ("red", "cube", "large"))
    misread = truth.model_copy(update={"objects": [o.model_copy(update={"color": {"brown": 1.0}}) if o.id == red
                                                   else o for o in truth.objects]})
    return truth, misread, red


def test_the_misread_object_is_read_as_the_question_names_it() -> None:
    truth, misread, red = _scenes()
    program = question_to_program(QUESTION)
    found = premise_reading(SceneModel(misread), program)
    # three cubes could be the red one with one colour changed, each as improbable (the perception is certain of
    # their colours): the one read brown is, red being nearer brown than gray or green
    assert found is not None and found.object_id == red
    assert found.changes == (("color", "brown", "red"),)
    assert found.log_ratio == math.log(PROBABILITY_FLOOR)
    assert found.value == program.run(SceneModel(truth).simulation())
    assert "brown" in found.describe() and "red" in found.describe()


def test_the_reader_answers_on_that_reading_and_flags_it() -> None:
    truth, misread, red = _scenes()
    questions = [Question(0, 0, QUESTION)]
    right = answer_questions(truth, questions)[0]
    read = answer_questions(misread, questions)[0]
    assert right.premise is None and "premise" not in right.to_json()
    assert read.answer == right.answer and not read.fallback
    record = read.to_json()
    assert record["premise"] == read.premise and f"object {red}" in record["premise"]
    assert read.confidence == PREMISE_RATE


def test_a_reading_the_perception_gave_weight_comes_first() -> None:
    truth, _misread, red = _scenes()
    gray = next(o.id for o in truth.objects if o.color == {"gray": 1.0} and o.size == {"large": 1.0})
    # the red cube read brown for certain; the large gray cube read gray, possibly red
    doubted = truth.model_copy(update={"objects": [
        o.model_copy(update={"color": {"brown": 1.0}}) if o.id == red else
        o.model_copy(update={"color": {"gray": 0.99, "red": 0.01}}) if o.id == gray else o
        for o in truth.objects]})
    model = SceneModel(doubted)
    assert model.most_likely_reading().object(gray).color == "gray"
    found = premise_reading(model, question_to_program(QUESTION))
    assert found is not None and found.object_id == gray  # 0.01 / 0.99 beats the floor, however near brown is
    assert found.log_ratio == math.log(0.01) - math.log(0.99)
