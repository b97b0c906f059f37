"""The reader's answers say when they are guesses, and why."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from craft_dsl.cli import main
from craft_dsl.perception import export_perceived
from craft_dsl.physics import simulate
from craft_dsl.reader.answer import Question, answer_questions
from craft_dsl.reader.video import MPEG_END_CODE, decode, incomplete


def test_a_guess_is_flagged_with_the_node_that_made_the_question_unanswerable() -> None:
    sim = simulate(1, seed=0, steps=200)
    scene = export_perceived(sim)
    dynamic = [o for o in sim.objects if o.dynamic]
    named = {("purple", "circle", "small"), ("yellow", "triangle", "small")}
    assert not any((o.color, o.shape, o.size) in named for o in dynamic)
    present = dynamic[0]
    # two objects the scene does not hold: no reading that reads one object otherwise holds both
    answers = answer_questions(scene, [
        Question(0, 0, "Does the small purple circle enter the basket before the small yellow triangle does?"),
        Question(0, 1, f"How many objects does the {present.size} {present.color} {present.shape} cause to fall "
                       "to the ground?"),
    ])
    guess, read = answers
    record = guess.to_json()
    assert guess.fallback and record["fallback"] is True and record["answer"] == "False"
    assert record["error"].startswith("INVALID in every reading: Unique: the set holds 0 objects")
    assert '"purple"' in record["error"]  # the node is named: which object the question asked about
    assert "premise" not in record
    assert not read.fallback and "fallback" not in read.to_json() and read.answer is not None


def test_a_cut_mpeg_stream_is_told_apart_from_a_whole_one(users_dataset: Path, tmp_path: Path) -> None:
    whole = sorted((users_dataset / "videos").rglob("*.mpg"))[0]
    assert whole.read_bytes().endswith(MPEG_END_CODE)
    assert incomplete(whole, len(decode(whole))) is None
    cut = tmp_path / whole.name
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size * 2 // 3])
    why = incomplete(cut, len(decode(cut)))
    assert why is not None and "cut short" in why


def test_read_warns_of_a_cut_video_and_flags_its_answers(users_dataset: Path, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    records = json.loads((users_dataset / "dataset_minimal.json").read_text())
    video = records[0]["video_index"]
    source = next((users_dataset / "videos").rglob(f"{video:06d}.mpg"))
    folder = tmp_path / "videos"
    folder.mkdir()
    (folder / source.name).write_bytes(source.read_bytes()[: source.stat().st_size * 2 // 3])
    questions = tmp_path / "questions.json"
    questions.write_text(json.dumps([{k: r[k] for k in ("video_index", "question_index", "question")}
                                     for r in records if r["video_index"] == video]))
    details = tmp_path / "details.jsonl"
    assert main(["read", "--steps", "200",
                 "--videos", str(folder), "--questions", str(questions), "--out", str(tmp_path / "p.json"),
                 "--details", str(details), "--workers", "1"]) == 0
    err = capsys.readouterr().err
    assert f"warning: video {video} (" in err and "the video is not whole" in err and "1 videos not whole" in err
    lines = [json.loads(line) for line in details.read_text().splitlines()]
    assert lines and all("cut short" in d["warning"] for d in lines)


def test_a_body_read_in_two_colours_keeps_the_colour_seen_over_more_pixels() -> None:
    from craft_dsl.reader.detect import Blob
    from craft_dsl.reader.track import TrackedObject, merge_colour_splits
    from craft_dsl.vocabulary import COLORS

    red, brown = COLORS.index("red"), COLORS.index("brown")

    def blob(k: int, color: int, area: float) -> Blob:
        return Blob(k, color, area, 100.0, 100.0, False)

    # a large red body, read brown in two frames of three (over a grey basket, say) but over few pixels
    reds = TrackedObject(red, [blob(k, red, 300.0) if k % 3 == 0 else None for k in range(60)])
    browns = TrackedObject(brown, [blob(k, brown, 20.0) if k % 3 else None for k in range(60)])
    merged = merge_colour_splits([browns, reds])
    assert len(merged) == 1 and merged[0].color_name == "red" and len(merged[0].seen()) == 60
