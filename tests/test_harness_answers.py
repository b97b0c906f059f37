"""Free-text answers read into the dataset's answer vocabulary (craft_dsl.harness.answers)."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest

from craft_dsl.errors import CraftError
from craft_dsl.harness.answers import (
    ANSWER_TYPE_OF_KIND,
    completion_text,
    kind_of_program,
    kind_of_record,
    kind_of_template,
    parse_answer,
)
from craft_dsl.program import Program
from craft_dsl.templates import templates

# (model output, answer kind, answer as dataset_minimal.json spells it, or None for no answer)
MESSY: list[tuple[str, str, str | None]] = [
    ("Two.", "count", "2"),
    ("The answer is: 2", "count", "2"),
    ("**yes**, it does", "bool", "True"),
    ("It is red", "color", "Red"),
    ("I cannot tell", "count", None),
    ("I cannot tell from the video.", "bool", None),
    ("two objects", "count", "2"),
    ("2, because the red ball hits the blue one and then the gray one", "count", "2"),
    ("Answer: no", "bool", "False"),
    ("B) red", "color", "Red"),
    ("(b) triangle", "shape", "Triangle"),
    ('"Red"', "color", "Red"),
    ("'cube'", "shape", "Cube"),
    ("RED", "color", "Red"),
    ("YES", "bool", "True"),
    ("It does not.", "bool", "False"),
    ("It does.", "bool", "True"),
    ("No, it could not have been prevented.", "bool", "False"),
    ("one or two", "count", None),
    ("Either red or blue.", "color", None),
    ("None of them.", "count", "0"),
    ("There are no objects that fall to the ground.", "count", "0"),
    ("zero", "count", "0"),
    ("<think>The ball falls, so maybe 3.</think> 4", "count", "4"),
    ("Let me think. <answer>False</answer>", "bool", "False"),
    ("It is a square.", "shape", "Cube"),
    ("Circles", "shape", "Circle"),
    ("a ball", "shape", "Circle"),
    ("The final answer is **3**.", "count", "3"),
    ("It’s blue", "color", "Blue"),
    ("I'm not sure, maybe yes", "bool", None),
    ("Looking at the video closely. There are two.", "count", "2"),
    ("`2`", "count", "2"),
    ("# Answer\n\n2", "count", "2"),
    ("2.", "count", "2"),
    ("2.5", "count", None),
    ("It is grey.", "color", "Gray"),
    ("The blue one", "color", "Blue"),
    ("A: Yes", "bool", "True"),
    ("10", "count", "10"),
    ("twice", "count", "2"),
    ("True", "bool", "True"),
    ("false.", "bool", "False"),
    ("Sorry, as an AI I can't watch videos.", "color", None),
    ("", "count", None),
    ("The video shows objects falling.", "count", None),
    ("**Answer:** *Large*, it is the big one.", "size", "Large"),
    ("Answer: 3 objects. First the red cube falls, then 2 circles.", "count", "3"),
    ("No, there are 2 of them.", "count", "2"),
    ("Yes or no?", "bool", None),
    ("No idea.", "bool", None),
    ("It cannot enter the basket.", "bool", "False"),
    ("It can't.", "bool", "False"),
    ("Not really.", "bool", "False"),
    ("It is impossible to determine from these frames.", "shape", None),
    ("We are unable to see the video", "count", None),
    ("no clue, sorry", "count", None),
]


@pytest.mark.parametrize(("text", "kind", "expected"), MESSY,
                         ids=[f"{i}:{t[:30]}" for i, (t, _, _) in enumerate(MESSY)])
def test_messy_outputs_read_as_the_dataset_spells_answers(text: str, kind: str, expected: str | None) -> None:
    assert parse_answer(text, kind) == expected


def test_at_least_thirty_kinds_of_messy_output() -> None:
    assert len({t for t, _, _ in MESSY}) >= 30


def test_the_kind_decides_what_is_read() -> None:
    text = "Yes: two red cubes."
    assert (parse_answer(text, "bool"), parse_answer(text, "count"), parse_answer(text, "color"),
            parse_answer(text, "shape")) == ("True", "2", "Red", "Cube")


def test_values_that_are_already_answers() -> None:
    assert parse_answer(True, "bool") == "True" and parse_answer(3, "count") == "3"
    assert parse_answer(True, "count") is None and parse_answer(-1, "count") is None


def test_chat_completions_are_read_from_their_last_assistant_message() -> None:
    chat = [{"role": "user", "content": "How many?"}, {"role": "assistant", "content": "Three."}]
    assert completion_text(chat) == "Three." and parse_answer(chat, "count") == "3"
    parts = [{"role": "assistant", "content": [{"type": "text", "text": "It is"}, {"type": "text", "text": "red"}]}]
    assert parse_answer(parts, "color") == "Red"
    with pytest.raises(CraftError, match="chat messages"):
        completion_text([1, 2])


def test_unknown_kind_and_template_are_clear_errors() -> None:
    with pytest.raises(CraftError, match="unknown answer kind 'number'; allowed: count, bool, color, shape, size"):
        parse_answer("2", "number")
    with pytest.raises(CraftError, match="not a CRAFT template id"):
        kind_of_template("descriptive_99")
    with pytest.raises(CraftError, match="not an answer"):
        kind_of_program(Program.parse("SceneAtStart()"))
    with pytest.raises(CraftError, match="answer kind is unknown"):
        kind_of_record({"question": "How many?"})


def test_every_template_has_the_kind_of_its_program_type() -> None:
    kinds = Counter(kind_of_template(tid) for tid in templates())
    assert kinds == {"count": 34, "bool": 29, "color": 2, "shape": 2}
    assert kind_of_template("descriptive_22") == "color" and kind_of_template("cause_0") == "bool"


def test_every_question_of_a_dataset_reads_its_own_answer(users_dataset: Path) -> None:
    """The kind from the template equals the kind of the question's own program and the answer_type column, and
    every recorded answer (as dataset_minimal.json and dataset.json spell it) reads back as itself."""
    minimal = json.loads((users_dataset / "dataset_minimal.json").read_text())
    programs = {(q["video_index"], q["question_index"]): q
                for video in json.loads((users_dataset / "dataset.json").read_text())
                for q in video["questions"]["questions"]}
    assert minimal
    for rec in minimal:
        kind = kind_of_record(rec)
        raw = programs[(rec["video_index"], rec["question_index"])]
        assert kind == kind_of_program(Program.from_nodes(raw["program"])) == kind_of_record(
            {"program": raw["program"]})
        assert ANSWER_TYPE_OF_KIND[kind] == rec["answer_type"] or (kind == "count" and rec["answer_type"] == "Count")
        assert parse_answer(rec["answer"], kind) == rec["answer"]
        assert parse_answer(raw["answer"], kind) == rec["answer"]  # raw: True, 2, "red"
        assert parse_answer(f"The answer is {str(raw['answer']).lower()}.", kind) == rec["answer"]
