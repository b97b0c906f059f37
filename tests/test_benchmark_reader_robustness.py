"""benchmarks/reader_robustness.py: each variant's copy decodes with its codec, size and frame count; resampled
frames show the steps stated (ffmpeg's ``fps=10`` 3 steps early, ``fps=5`` 6, ``fps=10:round=down`` the renderer's
steps); the paired intervals resample videos."""

from __future__ import annotations

import json
import os
from collections.abc import Collection
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from craft_dsl.physics import simulate
from craft_dsl.reader.answer import find_videos
from craft_dsl.reader.video import decode
from craft_dsl.render.video import write_video
from tests.script_module import load_script

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "reader_robustness.py"
STEPS = 60


@pytest.fixture(scope="module")
def rr() -> ModuleType:
    return load_script(SCRIPT, "reader_robustness")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 60-step MPEG-1 video of scene 1 (objects falling from the first step), named as a dataset names it."""
    out = tmp_path_factory.mktemp("tiny") / "000000.mpg"
    write_video(simulate(1, seed=0, steps=STEPS), out)
    return out


@pytest.fixture(scope="module")
def copies(rr: ModuleType, tiny: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Every copied variant of ``tiny``, each in its own folder (made with two ffmpeg processes at a time)."""
    root = tmp_path_factory.mktemp("copies")
    out = {}
    for name, variant in rr.VARIANTS.items():
        if variant.copied:
            out[name] = rr.make_copies({0: tiny}, variant, root / name, 2, rr.ffmpeg_exe())[0]
    return out


def test_every_variant_but_the_original_is_copied(rr: ModuleType, copies: dict[str, Path]) -> None:
    assert set(copies) == set(rr.VARIANTS) - {"original"}


@pytest.mark.parametrize("name", ["h264-crf28", "mpeg4-q8", "scale-128", "scale-512", "fps-10", "fps-10-down",
                                  "fps-5", "range-tv", "grade-strong", "crop-8", "letterbox-16x9",
                                  "pad-4x3-gray"])
def test_a_copy_decodes_with_its_codec_size_and_frames(rr: ModuleType, tiny: Path, copies: dict[str, Path],
                                                       name: str) -> None:
    variant = rr.VARIANTS[name]
    copy = copies[name]
    assert copy.name == f"000000{variant.suffix}"
    assert find_videos([copy.parent], [0]) == {0: copy}  # the name craft-dsl read --videos FOLDER finds
    want = rr.expected(variant, STEPS, 256)
    found = rr.describe(copy)
    assert {k: found[k] for k in want} == want
    assert found["fps"] == pytest.approx(variant.fps or 60)
    assert want["frames"] == (STEPS * variant.fps // 60 if variant.fps else STEPS)
    frames = decode(copy)  # the reader's decoder: the square picture, between the bars of a boxed copy
    assert frames.shape == (want["frames"], want["height"], want["height"], 3)


def test_the_original_is_what_it_says(rr: ModuleType, tiny: Path) -> None:
    assert rr.describe(tiny) == {"codec": "mpeg1video", "width": 256, "height": 256, "frames": STEPS, "fps": 60.0}


def test_ffmpeg_fps_filter_shows_steps_3_early_and_round_down_the_renderers(
        rr: ModuleType, tiny: Path, copies: dict[str, Path], tmp_path: Path) -> None:
    near = rr.step_offsets(tiny, copies["fps-10"], 10)
    down = rr.step_offsets(tiny, copies["fps-10-down"], 10)
    assert len(near) >= 8 and set(near) == {-3}
    assert len(down) >= 8 and set(down) == {0}
    five = rr.step_offsets(tiny, copies["fps-5"], 5)  # 6 early: beyond a search of 5 frames either way
    assert len(five) >= 4 and set(five) == {-6}
    # craft-dsl render --fps 10 (lossy H.264) is the round=down copy, up to its encoding
    rendered = decode(write_video(simulate(1, seed=0, steps=STEPS), tmp_path / "r10.mp4", fps=10)).astype(np.int16)
    gap_down = np.abs(decode(copies["fps-10-down"]).astype(np.int16) - rendered).mean()
    gap_near = np.abs(decode(copies["fps-10"]).astype(np.int16) - rendered).mean()
    assert gap_down < 0.5 < gap_near


def test_a_missing_encoder_is_named(rr: ModuleType) -> None:
    variant = rr.Variant("x", ".mp4", ("-c:v", "nosuch"), "nosuch", "nosuch")
    why = rr.unavailable(variant, "/bin/ffmpeg", {"libx264"})
    assert why is not None and "no nosuch encoder" in why and "IMAGEIO_FFMPEG_EXE" in why
    assert rr.unavailable(rr.VARIANTS["original"], "/bin/ffmpeg", set()) is None


def test_a_copy_that_fails_names_the_variant_and_file(rr: ModuleType, tmp_path: Path) -> None:
    bad = tmp_path / "000001.mpg"
    bad.write_bytes(b"not a video")
    with pytest.raises(rr.CopyError, match=r"h264-crf28: ffmpeg could not write 000001\.mp4"):
        rr.make_copies({1: bad}, rr.VARIANTS["h264-crf28"], tmp_path / "out", 1, rr.ffmpeg_exe())


def test_a_folder_that_is_not_a_dataset_is_named(rr: ModuleType, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert rr.main(["--dataset", str(tmp_path)]) == 2
    assert "dataset_minimal.json: missing; --dataset must be a folder written by craft-dsl generate --videos" in \
        capsys.readouterr().err
    with pytest.raises(SystemExit):
        rr.main(["--dataset", str(tmp_path / "none")])
    with pytest.raises(SystemExit):
        rr.main(["--dataset", str(tmp_path), "--variants", "nosuch"])


def test_a_variant_that_cannot_be_made_is_a_row_of_its_own(rr: ModuleType, users_dataset: Path) -> None:
    suite = rr.load_suite(users_dataset, 1)
    variant = rr.Variant("x", ".mp4", ("-c:v", "nosuch"), "nosuch", "nosuch")
    sources = find_videos(users_dataset / "videos", suite.videos)
    row = rr.run_variant(variant, suite, sources, Path("unused"), 1, rr.ffmpeg_exe(), {"libx264"}, {})
    assert "no nosuch encoder" in row["reason"] and "figures" not in row
    printed = rr.table({"x": row}, suite)
    assert "| x | failed: " in printed


def test_a_paired_difference_counts_the_answers_that_changed(rr: ModuleType) -> None:
    base = {f"0_{i}": True for i in range(98)} | {"0_98": False, "0_99": False}
    other = dict(base) | {"0_0": False, "0_1": False, "0_2": False, "0_98": True}  # 3 lost, 1 gained
    lost, gained, diff, low, high = rr.paired_difference(base, other, base)
    assert (lost, gained) == (3, 1) and diff == pytest.approx(-2.0)
    half = 100 * 1.96 * np.sqrt(4 - 4 / 100) / 100
    assert (low, high) == (pytest.approx(-2.0 - half), pytest.approx(-2.0 + half))
    assert rr.paired_difference(base, base, base)[:3] == (0, 0, 0.0)  # unchanged: no difference
    assert rr.paired_difference(base, other, ["0_0", "9_9"])[:3] == (1, 0, -100.0)  # keys base lacks are left out
    assert rr.paired_difference(base, other, [])[:3] == (0, 0, 0.0)


def test_the_paired_table_is_printed_against_the_original(rr: ModuleType, users_dataset: Path) -> None:
    suite = rr.load_suite(users_dataset, 2)
    keys = sorted(f"{v}_{q}" for v, q in set().union(*suite.parts.values()))
    assert keys, "the users' dataset has test questions"
    original = {k: True for k in keys}
    worse = dict(original) | {keys[0]: False}
    rows = {"original": {"figures": {"correct": original}}, "worse": {"figures": {"correct": worse}}}
    lines = rr.paired_lines(rows, suite)
    counts, intervals = [line for line in lines if line.startswith("| worse | ")]
    assert "-1 +0" in counts
    assert "[" in intervals and intervals.rstrip(" |").split("| ")[-1].startswith("not met: ")  # a loss in 2 videos
    assert rr.paired_lines({"original": rows["original"]}, suite) == []  # nothing to pair
    found = rr.paired_intervals(rows, suite)
    assert list(found) == ["worse"] and found["worse"]["goal_met"] is False and found["worse"]["short"]
    same = rr.paired_intervals({"original": rows["original"], "same": {"figures": {"correct": original}}}, suite)
    assert same["same"]["short"] == []  # no difference: every lower end 0
    assert same["same"]["goal_met"] is False  # but too few questions for the goal
    assert all(cell["low"] == cell["high"] == 0.0 for part in same["same"]["parts"].values() for cell in part.values())


def _answers(videos: int, questions: int, wrong: Collection[int] = ()) -> dict[str, bool]:
    """Right answers to ``questions`` questions of each of ``videos`` videos, those of the videos ``wrong`` wrong."""
    return {f"{v}_{q}": v not in wrong for v in range(videos) for q in range(questions)}


def test_identical_answers_have_no_difference(rr: ModuleType) -> None:
    base = _answers(10, 10) | {"3_0": False, "7_4": False}
    assert rr.bootstrap_difference(base, base, base) == (0.0, 0.0, 0.0)
    assert rr.bootstrap_difference(base, base, []) == (0.0, 0.0, 0.0)


def test_a_video_lost_whole_gives_an_interval_over_videos(rr: ModuleType) -> None:
    base = _answers(10, 10)
    worse = _answers(10, 10, wrong={4})  # every answer of one video of ten wrong: -10 points
    diff, low, high = rr.bootstrap_difference(base, worse, base)
    assert diff == pytest.approx(-10.0)
    assert low < -10.0 < high <= 0.0  # negative, containing the true value
    assert low <= -20.0  # a draw holding the video twice or more: the questions of one video go together
    _, _, _, normal_low, normal_high = rr.paired_difference(base, worse, base)
    assert high - low > normal_high - normal_low  # wider than the questions' interval, which takes them as free
    assert rr.bootstrap_difference(base, worse, base) == (diff, low, high)  # a fixed seed: the same interval


def test_the_bootstrap_weighs_videos_by_their_questions(rr: ModuleType) -> None:
    base = _answers(4, 5) | {f"9_{q}": True for q in range(20)}  # four videos of 5 questions, one of 20
    worse = dict(base) | {f"9_{q}": False for q in range(20)}
    diff, low, high = rr.bootstrap_difference(base, worse, base, resamples=500)
    assert diff == pytest.approx(-50.0)  # 20 of 40 questions
    assert low < -50.0 < high
    assert rr.bootstrap_difference(base, {}, ["0_0", "8_8"])[0] == -100.0  # not answered: wrong; unknown: left out


def test_calibration_of_a_variants_answers(rr: ModuleType) -> None:
    # ten answers: the most confident eight hold one wrong one; bins 0.9-1.0 (six, 5 right) and 0.5-0.6 (four, 2)
    confidence = [0.95] * 6 + [0.55] * 4
    correct = [True, True, True, True, True, False, True, True, False, False]
    cal = rr.calibration(confidence, correct)
    assert cal["answers"] == 10
    assert cal["ece"] == pytest.approx((6 * abs(5 / 6 - 0.95) + 4 * abs(0.5 - 0.55)) / 10)
    assert cal["kept_accuracy"] == pytest.approx(100 * 7 / 8)
    assert cal["mean_confidence"] == pytest.approx(0.79)
    assert rr.calibration([], [])["ece"] is None


def test_two_videos_in_two_variants(rr: ModuleType, users_dataset: Path, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "figures.json"
    assert rr.main(["--dataset", str(users_dataset), "--videos", "2", "--variants", "original,fps-10-down",
                    "--workers", "1", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())["variants"]
    assert list(rows) == ["original", "fps-10-down"]
    assert "reason" not in rows["original"] and rows["original"]["figures"]["not_read"] == 0
    assert "figures" in rows["fps-10-down"] or "reason" in rows["fps-10-down"]  # a failed variant is reported
    assert rows["fps-10-down"]["check"]["step_offsets"].keys() <= {"0"}
    if "figures" in rows["fps-10-down"]:  # the renderer's steps: read at them
        assert rows["fps-10-down"]["figures"]["frame_offsets"] == {"0": 2}
    calibration = rows["original"]["figures"]["calibration"]
    assert calibration["answers"] == len(rows["original"]["figures"]["correct"])  # every answer is rated
    assert 0 <= calibration["ece"] <= 1
    printed = capsys.readouterr().out
    assert "| original |" in printed and "| fps-10-down |" in printed

    # each variant's figures saved by a run of its own print, together, the tables the one run printed
    saved = json.loads(out.read_text())
    files = []
    for name in ("fps-10-down", "original"):  # in any order: original is the base
        part = tmp_path / f"{name}.json"
        part.write_text(json.dumps({**saved, "variants": {name: saved["variants"][name]}}))
        files.append(str(part))
    assert rr.main(["--dataset", str(users_dataset), "--videos", "2", "--tables-from", *files]) == 0
    together = capsys.readouterr().out
    tables = printed[printed.index("| variant |"):printed.index("Videos checked")].strip()
    assert tables in together

    # files that cannot be put together are named, with what is wrong
    assert rr.main(["--dataset", str(users_dataset), "--videos", "1", "--tables-from", *files]) == 2
    assert "made on other test videos" in capsys.readouterr().err
    assert rr.main(["--dataset", str(users_dataset), "--videos", "2", "--tables-from", files[1], files[1]]) == 2
    assert "variant original is in an earlier file too" in capsys.readouterr().err
    (tmp_path / "broken.json").write_text("{")
    assert rr.main(["--dataset", str(users_dataset), "--videos", "2", "--tables-from",
                    str(tmp_path / "broken.json")]) == 2
    assert "broken.json: cannot be read as a --json file" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # nothing to count against
        rr.main(["--dataset", str(users_dataset), "--videos", "2", "--tables-from", files[0]])


@pytest.mark.skipif(os.environ.get("CRAFT_DSL_SLOW") != "1",
                    reason="reads 2 videos in all 13 variants (about 160 s on 2 busy cores): set CRAFT_DSL_SLOW=1")
def test_the_whole_script_on_two_videos(rr: ModuleType, users_dataset: Path, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "figures.json"
    assert rr.main(["--dataset", str(users_dataset), "--videos", "2", "--workers", "2", "--json", str(out),
                    "--keep", str(tmp_path / "kept")]) == 0
    data = json.loads(out.read_text())
    assert list(data["variants"]) == list(rr.VARIANTS)
    original = data["variants"]["original"]
    assert "reason" not in original and original["figures"]["not_read"] == 0
    assert original["figures"]["warnings"] == 0  # whole runs of the dataset's 200 steps (its generation_config)
    for name, row in data["variants"].items():
        assert "figures" in row or "reason" in row, name
        if rr.VARIANTS[name].copied:
            assert len(list((tmp_path / "kept" / name).iterdir())) == 2
    printed = capsys.readouterr().out
    assert "| original |" in printed and "| fps-10 |" in printed


def test_the_run_length_is_the_dataset_s_own(rr: ModuleType, users_dataset: Path, tmp_path: Path) -> None:
    assert rr.load_suite(users_dataset).steps == 200  # tests/conftest.py: USERS_DATASET's steps
    assert rr.run_steps(tmp_path) == 600  # no generation_config.json: CRAFT's 10 s
