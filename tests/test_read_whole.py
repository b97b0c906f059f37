"""A video cut short or cut at the start is read all the same, and says so: whole as a file (re-encoded after the
cut) is not whole as a run."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from reader_helpers import reencoded

from craft_dsl.cli import main
from craft_dsl.reader.confidence import default_model
from craft_dsl.reader.perceive import perceive_video
from craft_dsl.reader.video import steps_shown
from craft_dsl.reader.whole import START_PX, cut_at_start, cut_short, why_not_whole

#: the test dataset's runs (tests/conftest.py: USERS_DATASET)
STEPS = 200


def test_a_whole_run_is_not_cut_short_at_any_frame_rate() -> None:
    assert cut_short(steps_shown(600, 60)) is None
    assert cut_short(steps_shown(100, 10)) is None and cut_short(steps_shown(50, 5)) is None
    assert cut_short(steps_shown(100, 10) - 3) is None  # ffmpeg's fps=10: each frame 3 steps early
    assert cut_short(steps_shown(250, 25)) is None and cut_short(steps_shown(200, 60), steps=200) is None
    assert cut_short(np.zeros(0, dtype=np.int64)) is None


def test_a_run_missing_frames_at_its_end_is_cut_short() -> None:
    why = cut_short(steps_shown(420, 60))
    assert why is not None and "step 420 (7.0 s) of the run's 600 (10.0 s)" in why and "--steps N" in why
    assert cut_short(steps_shown(598, 60)) is not None  # two frames missing
    assert cut_short(steps_shown(90, 10)) is not None  # a second missing at 10 fps
    assert cut_short(steps_shown(200, 60), steps=600) is not None  # a 200-step run is not CRAFT's 600


def test_a_start_that_most_bodies_do_not_follow_is_a_cut_at_the_start() -> None:
    assert cut_at_start({}) is None and cut_at_start({0: 0.2, 1: START_PX}) is None
    assert cut_at_start({0: 0.2, 1: 19.0}) is None  # one body of two off: a misreading, not a cut
    assert cut_at_start({0: 19.0}) is None  # nor the only body seen at the start
    assert cut_at_start({0: 0.2, 1: 19.0, 2: 7.0, 3: 0.1}) is None  # half of them
    why = cut_at_start({0: 0.2, 1: 12.3, 2: 7.04})
    assert why is not None and "2 of its 3 bodies" in why and "7.0-12.3 px" in why and "cut at the start" in why


def test_a_whole_video_and_its_re_encoded_copy_are_whole(video: Path, tmp_path: Path) -> None:
    for path in (video, reencoded(video, tmp_path / "copy.mp4")):
        perception = perceive_video(path)
        assert why_not_whole(str(path), perception, steps=STEPS) is None
        start = perception.reconstruction.start_px
        assert start and max(start.values()) < 1.0
        assert perception.scene.meta["start_px"] == {str(uid): round(d, 3) for uid, d in sorted(start.items())}
    why = why_not_whole(str(video), perceive_video(video))  # a 200-step run read as one of CRAFT's 600 steps
    assert why is not None and "cut short" in why


def test_a_video_re_encoded_after_a_cut_at_the_start_says_both(video: Path, tmp_path: Path) -> None:
    cut = reencoded(video, tmp_path / "late.mp4", "trim=start_frame=60,setpts=PTS-STARTPTS")  # from its second 1
    perception = perceive_video(cut)
    start = perception.reconstruction.start_px
    assert 2 * sum(d > START_PX for d in start.values()) > len(start)  # most bodies are in flight at its start
    why = why_not_whole(str(cut), perception, steps=STEPS)
    assert why is not None and "cut at the start" in why and "cut short" in why


def test_read_warns_of_a_video_cut_short_as_a_run_and_flags_its_answers(users_dataset: Path, video: Path,
                                                                       tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    index = int(video.stem)
    records = [r for r in json.loads((users_dataset / "dataset_minimal.json").read_text())
               if r["video_index"] == index]
    questions = tmp_path / "questions.json"
    questions.write_text(json.dumps([{k: r[k] for k in ("video_index", "question_index", "question")}
                                     for r in records]))
    folder = tmp_path / "videos"
    folder.mkdir()
    reencoded(video, folder / f"{index:06d}.mp4", "trim=end_frame=120")  # a whole file of a run cut after 2 s
    details = tmp_path / "details.jsonl"
    assert main(["read", "--videos", str(folder), "--questions", str(questions), "--out", str(tmp_path / "p.json"),
                 "--details", str(details), "--workers", "1", "--steps", str(STEPS)]) == 0
    err = capsys.readouterr().err
    assert f"warning: video {index} (" in err and "of the run's 200 (3.3 s)" in err
    assert "the video was cut short" in err and "1 videos not whole" in err
    lines = [json.loads(line) for line in details.read_text().splitlines()]
    assert lines and all("cut short" in d["warning"] for d in lines)
    model = default_model()
    assert all(d["confidence"] <= model.guess_rate(d["confidence_inputs"].get("type")) + 1e-6 for d in lines)


def test_read_steps_must_be_a_positive_whole_number(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["read", "--videos", str(tmp_path), "--questions", "q.json", "--out", "p.json", "--steps", "0"])
    assert "--steps: expected a whole number >= 1, got '0'" in capsys.readouterr().err
