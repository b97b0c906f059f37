"""Frames missing inside a video (dropped by a capture, cut out by an editor) are found by the frames' times, and
each frame is read at the step its time shows: the video is read as its original, and says what it lacks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from reader_helpers import assert_same_answers, reencoded, video_questions

from craft_dsl.cli import main
from craft_dsl.reader.perceive import perceive_video
from craft_dsl.reader.video import GAP_INTERVALS, decode, decode_video, steps_shown, timed_steps
from craft_dsl.reader.whole import frames_missing

#: the test dataset's runs (tests/conftest.py: USERS_DATASET)
STEPS = 200


def test_evenly_spaced_times_leave_the_steps_to_the_rate() -> None:
    assert timed_steps(None) is None and timed_steps(np.array([0.0, 0.1])) is None
    assert timed_steps(np.arange(600) / 60) is None
    jitter = np.random.default_rng(0).uniform(-0.002, 0.002, 600)  # a capture's timestamps a little uneven
    assert timed_steps(np.arange(600) / 60 + jitter) is None


@pytest.mark.parametrize("fps", [60, 30, 10])
def test_frames_missing_are_found_and_the_others_keep_their_steps(fps: int) -> None:
    every = steps_shown(10 * fps, fps)  # the steps of a whole video at this rate
    kept = np.ones(every.size, dtype=bool)
    kept[20:32] = False
    kept[50] = False
    times = (every[kept] - every[0]) / 60  # a container's times: the first frame at 0
    timed = timed_steps(times)
    assert timed is not None and timed.missing == 13 and timed.fps == fps
    assert np.array_equal(timed.steps, every[kept])
    assert timed.first_gap == pytest.approx(20 / fps)


def test_times_that_cannot_be_steps_are_not_taken() -> None:
    assert timed_steps(np.array([0.0, 0.1, 0.1, 0.5])) is None  # not increasing
    assert timed_steps(np.array([0.0, 0.004, 0.008, 0.05])) is None  # frames within a step of each other
    assert GAP_INTERVALS > 1


def test_the_reason_names_how_many_and_where() -> None:
    assert frames_missing(0) is None
    why = frames_missing(31, 1.683)
    assert why is not None and "31 frames are missing inside it, the first 1.68 s into it" in why


def _dropped(video: Path, target: Path) -> Path:
    """``video`` without its frames 60-71 and 130 (0-based), each other frame at its own time."""
    return reencoded(video, target, r"select=not(between(n\,60\,71)+eq(n\,130))", ("-fps_mode", "vfr"))


def test_a_video_with_frames_dropped_is_read_at_its_frames_times(users_dataset: Path, video: Path,
                                                                 tmp_path: Path) -> None:
    dropped = _dropped(video, tmp_path / "dropped.mp4")
    decoded = decode_video(dropped)
    assert decoded.times is not None and len(decoded.frames) == len(decode(video)) - 13
    assert decode_video(video).times is None  # a raw MPEG stream's times are not its frames'
    assert decode_video(reencoded(video, tmp_path / "whole.mp4")).times is not None
    perception = perceive_video(dropped)
    kept = [k + 1 for k in range(len(decode(video))) if not (60 <= k <= 71 or k == 130)]
    assert perception.frames_missing == 13 and perception.frame_steps.tolist() == kept
    assert perception.scene.meta["frames_missing"] == 13 and perception.scene.meta["first_gap_s"] == 1.0
    questions = video_questions(users_dataset, video)
    assert_same_answers(perceive_video(video).scene, perception.scene, questions)


def test_read_warns_of_frames_missing_inside_a_video(users_dataset: Path, video: Path, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    index = int(video.stem)
    questions = tmp_path / "questions.json"
    questions.write_text(json.dumps([{k: r[k] for k in ("video_index", "question_index", "question")}
                                     for r in json.loads((users_dataset / "dataset_minimal.json").read_text())
                                     if r["video_index"] == index]))
    folder = tmp_path / "videos"
    folder.mkdir()
    _dropped(video, folder / f"{index:06d}.mkv")
    details = tmp_path / "details.jsonl"
    assert main(["read", "--steps", str(STEPS), "--videos", str(folder), "--questions", str(questions), "--out",
                 str(tmp_path / "p.json"), "--details", str(details), "--workers", "1"]) == 0
    assert "13 frames are missing inside it, the first 1.00 s into it" in capsys.readouterr().err
    lines = [json.loads(line) for line in details.read_text().splitlines()]
    assert lines and all("frames are missing" in d["warning"] for d in lines)
