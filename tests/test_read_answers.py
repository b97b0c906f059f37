"""The reader's answers say when they are guesses, and why."""

from __future__ import annotations

from craft_dsl.perception import export_perceived
from craft_dsl.physics import simulate
from craft_dsl.reader.answer import Question, answer_questions


def test_a_guess_is_flagged_with_the_node_that_made_the_question_unanswerable() -> None:
    sim = simulate(1, seed=0, steps=200)
    scene = export_perceived(sim)
    dynamic = [o for o in sim.objects if o.dynamic]
    assert not any(o.shape == "cube" and o.color == "purple" and o.size == "large" for o in dynamic)
    present = dynamic[0]
    answers = answer_questions(scene, [
        Question(0, 0, "What color is the first object that collided with the large purple cube?"),
        Question(0, 1, f"How many objects does the {present.size} {present.color} {present.shape} cause to fall "
                       "to the ground?"),
    ])
    guess, read = answers
    record = guess.to_json()
    assert guess.fallback and record["fallback"] is True and record["answer"] == "Gray"
    assert record["error"].startswith("INVALID in every reading: Unique: the set holds 0 objects")
    assert '"purple"' in record["error"]  # the node is named: which object the question asked about
    assert not read.fallback and "fallback" not in read.to_json() and read.answer is not None
