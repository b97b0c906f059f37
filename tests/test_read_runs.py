"""``craft-dsl read`` on videos of any name and container, and runs that survive: a journal resumed by the same
command to the same bytes, a journal of another run refused, a torn last line dropped, a video that raises reported
while the others are written.

Perception is real where the bytes of a resumed run are compared (three 200-step videos); the journal's other cases
replace the per-video function with a fast stand-in.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from craft_dsl.cli import main
from craft_dsl.errors import ReaderError
from craft_dsl.reader import cli as read_cli
from craft_dsl.reader import reconstruct
from craft_dsl.reader.answer import VIDEO_SUFFIXES, Answer, Question, find_videos
from craft_dsl.reader.runs import Journal, ctrl_c_outside_callbacks, journal_path, run_tasks
from craft_dsl.reader.video import decode
from tests.foreground import popen_foreground
from tests.reader_helpers import strip_dataset

VIDEOS = (0, 2, 4)  # one video of each of the users dataset's scenes


@pytest.fixture(scope="module")
def stripped(users_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three of the users dataset's videos, flat, and a questions file of their (video_index, question_index,
    question) records."""
    return strip_dataset(users_dataset, tmp_path_factory.mktemp("stripped"), VIDEOS)


@pytest.fixture(scope="module")
def reference(stripped: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """The files of an uninterrupted run in this process (one worker)."""
    out = tmp_path_factory.mktemp("reference")
    assert main(["read", "--steps", "200",
                 "--videos", str(stripped / "videos"), "--questions", str(stripped / "questions.json"),
                 "--out", str(out / "preds.json"), "--details", str(out / "details.jsonl"), "--workers", "1",
                 "--quiet"]) == 0
    assert not journal_path(out / "preds.json").exists()
    return {name: (out / name).read_bytes() for name in ("preds.json", "details.jsonl")}


# -- finding the videos -------------------------------------------------------------------------------------------


def _ffmpeg() -> str:
    import imageio_ffmpeg

    return str(imageio_ffmpeg.get_ffmpeg_exe())


#: suffix -> ffmpeg output options for a short re-encoding
ENCODINGS = {
    ".mpg": ["-c:v", "mpeg1video", "-q:v", "2", "-f", "mpeg1video"],
    ".mpeg": ["-c:v", "mpeg1video", "-q:v", "2", "-f", "mpeg"],
    ".mp4": ["-c:v", "libx264", "-qp", "0", "-pix_fmt", "yuv420p"],
    ".avi": ["-c:v", "mpeg4", "-q:v", "1"],
    ".mkv": ["-c:v", "ffv1"],
    ".webm": ["-c:v", "libvpx-vp9", "-lossless", "1"],
    ".mov": ["-c:v", "mjpeg", "-q:v", "2"],
    ".gif": ["-filter_complex", "split[a][b];[a]palettegen[p];[b][p]paletteuse=dither=none"],  # craft-dsl render's
}


def test_every_container_is_found_and_decoded_to_the_same_frames(users_dataset: Path, tmp_path: Path) -> None:
    assert set(ENCODINGS) == set(VIDEO_SUFFIXES)
    source = next(users_dataset.glob("videos/*/000000.mpg"))
    frames = 12
    truth = decode(source)[:frames].astype(np.int16)
    folder = tmp_path / "videos"
    for index, suffix in enumerate(VIDEO_SUFFIXES):
        target = folder / f"part_{index % 2}" / f"{index:06d}{suffix}"
        target.parent.mkdir(parents=True, exist_ok=True)
        subprocess.run([_ffmpeg(), "-loglevel", "error", "-f", "mpegvideo", "-i", str(source), "-frames:v",
                        str(frames), *ENCODINGS[suffix], "-y", str(target)], check=True)
    found = find_videos(folder, range(len(VIDEO_SUFFIXES)))
    assert [found[i].suffix for i in range(len(VIDEO_SUFFIXES))] == list(VIDEO_SUFFIXES)
    for path in found.values():
        for decoder in ("pyav", "ffmpeg"):
            got = decode(path, decoder)
            assert got.shape == truth.shape, (path, decoder)
            assert float(np.abs(got.astype(np.int16) - truth).mean()) < 2.0, (path, decoder)


def _touch(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"\0")
    return path


def test_videos_are_found_in_folders_and_files_given_by_path(tmp_path: Path) -> None:
    a1 = _touch(tmp_path / "a" / "sub" / "000001.mpg")
    _touch(tmp_path / "a" / "000001.mp4")  # another container of the same index: the .mpg is taken
    a2 = _touch(tmp_path / "a" / "000002.webm")
    b3 = _touch(tmp_path / "b" / "000003.mkv")
    _touch(tmp_path / "b" / "000004.mkv")  # not given: its folder is not searched
    # a file given again inside a folder given is one candidate, not two
    found = find_videos([tmp_path / "a", b3, str(a2)], [1, 2, 3])
    assert found == {1: a1, 2: a2, 3: b3}
    with pytest.raises(ReaderError, match="no video for video_index 4"):
        find_videos([tmp_path / "a", b3], [4])
    twin = _touch(tmp_path / "c" / "000002.webm")
    with pytest.raises(ReaderError, match=f"video_index 2: several files: .*{re.escape(str(twin))}"):
        find_videos([tmp_path / "a", tmp_path / "c"], [2])
    odd = _touch(tmp_path / "b" / "clip one.mkv")
    with pytest.raises(ReaderError, match=r"--videos .*clip one\.mkv: a video given by path is named by its "
                                          r"video_index in six digits .*--video-map"):
        find_videos([odd], [1])
    with pytest.raises(ReaderError, match="--videos .*nowhere: no such folder or file"):
        find_videos([tmp_path / "nowhere"], [1])


def test_mapping_files_name_videos_of_any_name(tmp_path: Path) -> None:
    clips = tmp_path / "clips"
    one = _touch(clips / "clip one.MKV")
    comma = _touch(clips / "take 2, final.webm")
    far = _touch(tmp_path / "elsewhere" / "x.avi")
    _touch(tmp_path / "videos" / "000001.mpg")  # the mapping wins over a folder's file of the same index
    three = _touch(tmp_path / "videos" / "000003.mp4")
    csv_map = clips / "map.csv"
    csv_map.write_text(f'video_index,path\n1,clip one.MKV\n\n000002,"take 2, final.webm"\n7,{far}\n')
    expected = {1: one, 2: comma, 3: three, 7: far}
    assert find_videos([tmp_path / "videos"], [1, 2, 3, 7], csv_map) == expected
    json_map = tmp_path / "map.json"
    json_map.write_text(json.dumps({"1": "clips/clip one.MKV", "2": "clips/take 2, final.webm", "7": str(far)}))
    assert find_videos([tmp_path / "videos"], [1, 2, 3, 7], json_map) == expected
    assert find_videos([], [2], json_map) == {2: tmp_path / "clips" / "take 2, final.webm"}


def test_the_not_found_message_names_the_index_and_what_was_tried(tmp_path: Path) -> None:
    b3 = _touch(tmp_path / "b" / "000003.mkv")
    (tmp_path / "a").mkdir()
    mapping = tmp_path / "m.csv"
    mapping.write_text("video_index,path\n3,b/000003.mkv\n")
    with pytest.raises(ReaderError) as err:
        find_videos([tmp_path / "a", b3], [3, 7, 9], mapping)
    message = str(err.value)
    assert message.startswith("no video for video_index 7: tried 000007 with the suffix "
                              ".mpg, .mpeg, .mp4, .avi, .mkv, .webm, .mov or .gif under ")
    assert f"under {tmp_path / 'a'} (searched recursively)" in message
    assert f"the files given ({b3})" in message
    assert f"--video-map {mapping} (no entry 7)" in message
    assert message.endswith("1 other indices have no video either: 9")


def _one_question(tmp_path: Path, index: int = 7) -> Path:
    path = tmp_path / "questions.json"
    path.write_text(json.dumps([{"video_index": index, "question_index": 0, "question": "How many objects?"}]))
    return path


MALFORMED = [
    ("m.csv", "index,file\n7,a.mpg\n", "line 1: header 'index,file'; expected video_index,path"),
    ("m.csv", "", "the file is empty; expected the header line video_index,path"),
    ("m.csv", "video_index,path\nx7,a.mpg\n", "line 2: video_index 'x7' is not a whole number"),
    ("m.csv", "video_index,path\n-7,a.mpg\n", "line 2: video_index '-7' is not a whole number"),
    ("m.csv", "video_index,path\n7,a.mpg\n007,a.mpg\n",
     "line 3: video_index 7 is mapped again (first on line 2); each video_index may be mapped once"),
    ("m.csv", "video_index,path\n7,a.mpg,x\n", "line 2: 3 fields; expected 2, video_index,path"),
    ("m.csv", "video_index,path\n7,missing.mpg\n", "line 2: no such file {dir}/missing.mpg (a relative path "
                                                   "is read from the folder of the mapping file, {dir})"),
    ("m.csv", "video_index,path\n7,\n", "line 2: the path is empty"),
    ("m.json", '{"7": "a.mpg", "007": "a.mpg"}', "key '007': names video_index 7, as key '7' does"),
    ("m.json", '{"seven": "a.mpg"}', "key 'seven': video_index 'seven' is not a whole number"),
    ("m.json", '{"7": 12}', "key '7': expected the video's path as a string, got 12"),
    ("m.json", '{"7": "missing.mpg"}', "key '7': no such file {dir}/missing.mpg"),
    ("m.json", '["a.mpg"]', 'expected a JSON object {"<video_index>": "path", ...}, got list'),
]


@pytest.mark.parametrize(("name", "text", "expected"), MALFORMED)
def test_a_malformed_mapping_file_is_one_error_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str,
                                                    text: str, expected: str) -> None:
    _touch(tmp_path / "a.mpg")
    mapping = tmp_path / name
    mapping.write_text(text)
    out = tmp_path / "preds.json"
    assert main(["read", "--video-map", str(mapping), "--questions", str(_one_question(tmp_path)), "--out",
                 str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: --video-map {mapping}: {expected.replace('{dir}', str(tmp_path))}"), err
    assert err.count("\n") == 1 and err.endswith("\n")
    assert not out.exists() and not journal_path(out).exists()


def test_a_duplicate_json_key_is_refused_by_the_file_reader(tmp_path: Path, capsys: pytest.CaptureFixture[str]) \
        -> None:
    _touch(tmp_path / "a.mpg")
    mapping = tmp_path / "m.json"
    mapping.write_text('{"7": "a.mpg", "7": "a.mpg"}')
    assert main(["read", "--video-map", str(mapping), "--questions", str(_one_question(tmp_path)), "--out",
                 str(tmp_path / "p.json"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {mapping}") and "'7'" in err and err.count("\n") == 1


def test_read_needs_videos_and_refuses_an_output_that_is_a_folder(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    questions = _one_question(tmp_path)
    assert main(["read", "--questions", str(questions), "--out", str(tmp_path / "p.json")]) == 2
    assert capsys.readouterr().err == "error: give the videos: --videos FOLDER_OR_FILE ... and/or --video-map FILE\n"
    _touch(tmp_path / "v" / "000007.mpg")
    assert main(["read", "--videos", str(tmp_path / "v"), "--questions", str(questions), "--out",
                 str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith(f"error: --out {tmp_path}: is a folder")


# -- runs that survive: the real reader, killed and resumed ---------------------------------------------------------


def _read_command(stripped: Path, out: Path, workers: int, *extra: str) -> list[str]:
    return [sys.executable, "-m", "craft_dsl", "read", "--steps", "200",
            "--videos", str(stripped / "videos"), "--questions",
            str(stripped / "questions.json"), "--out", str(out / "preds.json"), "--details",
            str(out / "details.jsonl"), "--workers", str(workers), *extra]


def _records(journal: Path) -> int:
    """Finished videos in a journal (lines after the header)."""
    try:
        return max(0, journal.read_bytes().count(b"\n") - 1)
    except OSError:
        return 0


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a terminal's Ctrl-C: SIGINT to a process group")
def test_a_run_stopped_by_ctrl_c_resumes_to_the_same_bytes(stripped: Path, reference: dict[str, bytes],
                                                           tmp_path: Path) -> None:
    """Two worker processes, against a reference read in this process."""
    out = tmp_path / "run"
    journal = journal_path(out / "preds.json")
    command = _read_command(stripped, out, 2)
    proc = popen_foreground(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             start_new_session=True)
    deadline = time.monotonic() + 120
    while _records(journal) < 1 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    sent = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)  # what a terminal's Ctrl-C does: the whole foreground process group
    _stdout, stderr = proc.communicate(timeout=60)
    stopped = time.monotonic() - sent
    assert proc.returncode == 130, stderr
    assert stopped < 5, stopped  # under 1 s on an idle machine (docs/reader.md)
    assert "Traceback" not in stderr and stderr.rstrip().endswith("interrupted"), stderr
    finished = _records(journal)
    assert 1 <= finished < len(VIDEOS)
    assert not (out / "preds.json").exists() and not (out / "details.jsonl").exists()
    resumed = subprocess.run(command, capture_output=True, text=True, timeout=300, check=False)
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming {journal}: {finished} of {len(VIDEOS)} videos already read" in resumed.stderr
    assert re.search(r"3/3 \[[0-9:]+<[0-9:]+, +[0-9.]+s/video\]", resumed.stderr), resumed.stderr  # rate, time left
    assert {name: (out / name).read_bytes() for name in reference} == reference
    assert not journal.exists() and not [p for p in out.iterdir() if ".tmp" in p.name]


def _space_calling(callback: Any) -> Any:
    """A pymunk space whose next step calls ``callback`` from C (two overlapping bodies: a collision begins)."""
    pymunk = pytest.importorskip("pymunk")
    space = pymunk.Space()
    for x in (0.0, 0.5):
        body = pymunk.Body(1, 1)
        body.position = (x, 0.0)
        space.add(body, pymunk.Circle(body, 1.0))
    space.on_collision(None, None, begin=callback)
    return space


@pytest.mark.parametrize("deferred", [True, False])
def test_ctrl_c_in_an_engine_callback_is_raised_after_it(deferred: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """In this process (one worker) a Ctrl-C that lands in a pymunk callback would be reported as unraisable and
    lost by cffi; the reader raises it once the callback has returned."""
    finished: list[bool] = []
    lost: list[type[BaseException] | None] = []
    monkeypatch.setattr(sys, "unraisablehook", lambda unraisable: lost.append(unraisable.exc_type))

    def begin(*_args: Any) -> None:
        signal.raise_signal(signal.SIGINT)
        for _ in range(1000):  # bytecodes, where a raised KeyboardInterrupt would surface
            pass
        finished.append(True)

    space = _space_calling(begin)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a foreground command
    try:
        with ctrl_c_outside_callbacks() if deferred else contextlib.nullcontext():
            if deferred:
                start = time.monotonic()
                with pytest.raises(KeyboardInterrupt):
                    space.step(0.01)
                    time.sleep(5.0)
                assert time.monotonic() - start < 1.0  # raised 20 ms after the callback, the sleep cut short
            else:
                space.step(0.01)
    finally:
        signal.signal(signal.SIGINT, previous)
    if deferred:
        assert finished == [True] and lost == []
    else:  # what the deferral prevents: the callback cut short, the Ctrl-C lost
        assert finished == [] and lost == [KeyboardInterrupt]


# -- the journal, with a stand-in for the per-video function -----------------------------------------------------


class StandIn:
    """A fast ``read_video``: answers every question "True"; records the videos it reads; raises ``raise_at[index]``
    for a video of that index."""

    def __init__(self, raise_at: dict[int, BaseException] | None = None) -> None:
        self.read: list[int] = []
        self.paths: list[str] = []
        self.votes: list[Any] = []  # --votes of each call
        self.steps: list[Any] = []  # --steps of each call
        self.engines: list[Any] = []  # --engine of each call
        self.first_engines: list[Any] = []  # the engine tried first (the dataset's), of each call
        self.raise_at = raise_at or {}

    def __call__(self, path: str, questions: list[Question], *args: Any) -> dict[str, Any]:
        index = questions[0].video_index
        if index in self.raise_at:
            raise self.raise_at[index]
        self.read.append(index)
        self.paths.append(path)
        _decoder, _distribution, _samples, votes, steps, engine, first_engine = args
        self.votes.append(votes)
        self.steps.append(steps)
        self.engines.append(engine)
        self.first_engines.append(first_engine)
        return {"path": path, "answers": [Answer(q, "True", None, f"program {q.key}") for q in questions],
                "scene": json.dumps({"video": index}), "timings": {"perception": 0.5}}


@pytest.fixture
def dummy(tmp_path: Path) -> Path:
    """A folder of three video files (not decodable: the stand-in does not decode) and their questions."""
    for index in VIDEOS:
        _touch(tmp_path / "videos" / f"{index:06d}.mp4")
    (tmp_path / "questions.json").write_text(json.dumps([
        {"video_index": v, "question_index": q, "question": f"Question {q}?"} for v in VIDEOS for q in range(3)]))
    return tmp_path


def _read(dummy: Path, out: Path, *extra: str) -> int:
    return main(["read", "--videos", str(dummy / "videos"), "--questions", str(dummy / "questions.json"), "--out",
                 str(out), "--details", str(out.with_suffix(".jsonl")), "--workers", "1", *extra])


def _uninterrupted(dummy: Path, monkeypatch: pytest.MonkeyPatch) -> bytes:
    monkeypatch.setattr(read_cli, "read_video", StandIn())
    assert _read(dummy, dummy / "whole.json", "--quiet") == 0
    return (dummy / "whole.json").read_bytes() + (dummy / "whole.jsonl").read_bytes()


def _interrupted(dummy: Path, monkeypatch: pytest.MonkeyPatch, out: Path, at: int, *extra: str) -> None:
    """A run stopped by Ctrl-C when it reaches video ``at``."""
    monkeypatch.setattr(read_cli, "read_video", StandIn({at: KeyboardInterrupt()}))
    assert _read(dummy, out, "--quiet", *extra) == 130
    assert journal_path(out).exists() and not out.exists()


def test_a_journal_of_another_run_is_refused(dummy: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    whole = _uninterrupted(dummy, monkeypatch)
    out = dummy / "preds.json"
    _interrupted(dummy, monkeypatch, out, VIDEOS[1])
    journal = journal_path(out)
    kept = journal.read_bytes()
    capsys.readouterr()
    assert _read(dummy, out, "--quiet", "--samples", "8") == 2
    assert capsys.readouterr().err == (
        f"error: {journal}: the journal of another run (--samples 64 there, 8 here); it is not mixed into this one: "
        "run the command that wrote it to finish that run, or delete it to start afresh\n")
    questions = json.loads((dummy / "questions.json").read_text())
    questions[0]["question"] = "Another question?"
    (dummy / "other.json").write_text(json.dumps(questions))
    assert main(["read", "--videos", str(dummy / "videos"), "--questions", str(dummy / "other.json"), "--out",
                 str(out), "--quiet"]) == 2
    assert "the journal of another run (other questions)" in capsys.readouterr().err
    assert journal.read_bytes() == kept and not out.exists()
    stand_in = StandIn()
    monkeypatch.setattr(read_cli, "read_video", stand_in)
    assert _read(dummy, out) == 0
    assert stand_in.read == list(VIDEOS[1:])  # the finished video is not read again
    assert out.read_bytes() + out.with_suffix(".jsonl").read_bytes() == whole
    assert not journal.exists()
    assert "resuming" in capsys.readouterr().err


def _resumed_with(dummy: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
                  *option: str) -> tuple[str, StandIn]:
    """A run stopped at its second video, resumed with ``option`` (refused: its error text), then resumed as it was
    run by a stand-in, returned with the text."""
    out = dummy / "preds.json"
    _interrupted(dummy, monkeypatch, out, VIDEOS[1])
    capsys.readouterr()
    assert _read(dummy, out, "--quiet", *option) == 2
    err = capsys.readouterr().err
    stand_in = StandIn()
    monkeypatch.setattr(read_cli, "read_video", stand_in)
    assert _read(dummy, out, "--quiet") == 0
    return err, stand_in


def test_votes_are_an_input_of_the_run(dummy: Path, monkeypatch: pytest.MonkeyPatch,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    err, stand_in = _resumed_with(dummy, monkeypatch, capsys, "--votes", "0")
    assert "the journal of another run (--votes 6 there, 0 here)" in err
    assert stand_in.votes == [6, 6]
    with pytest.raises(SystemExit):
        _read(dummy, dummy / "other.json", "--votes", "-1")
    assert "--votes: expected a whole number >= 0, got '-1'" in capsys.readouterr().err


def test_the_run_length_is_an_input_of_the_run(dummy: Path, monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    err, stand_in = _resumed_with(dummy, monkeypatch, capsys, "--steps", "200")  # 600-step videos may be cut at 200
    assert "the journal of another run (--steps 600 there, 200 here)" in err
    assert stand_in.steps == [600, 600]


def test_the_engine_is_an_input_of_the_run(dummy: Path, monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    err, stand_in = _resumed_with(dummy, monkeypatch, capsys, "--engine", "pymunk")
    assert "the journal of another run (--engine auto there, pymunk here)" in err
    assert stand_in.engines == ["auto", "auto"]
    stand_in = StandIn()
    monkeypatch.setattr(read_cli, "read_video", stand_in)
    assert _read(dummy, dummy / "alone.json", "--quiet", "--engine", "pymunk") == 0
    assert stand_in.engines == ["pymunk"] * len(VIDEOS)
    monkeypatch.setattr(reconstruct, "reader_engines", lambda aliased=False: ("pymunk",))  # no Box2D installed
    assert _read(dummy, dummy / "box2d.json", "--quiet", "--engine", "box2d") == 2
    assert "--engine box2d: Box2D is not installed (pip install 'craft-dsl[reader]'); installed: pymunk" in \
        capsys.readouterr().err
    assert ("auto", *reconstruct.READER_ENGINES) == read_cli.ENGINE_CHOICES


def test_a_video_is_reconstructed_with_the_engine_given_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[Any] = []

    def perceive(path: str, decoder: str, engines: Any = None, first_engine: str | None = None) -> Any:
        seen.append((engines, first_engine))
        raise ReaderError(f"{path}: stand-in")

    monkeypatch.setattr("craft_dsl.reader.perceive.perceive_video", perceive)
    for engine, engines in (("auto", None), ("pymunk", ("pymunk",)), ("box2d", ("box2d",))):
        assert read_cli.read_video("v.mp4", [], engine=engine) == {"path": "v.mp4", "error": "v.mp4: stand-in"}
        assert seen.pop() == (engines, None)
    read_cli.read_video("v.mp4", [], first_engine="pymunk")
    assert seen.pop() == (None, "pymunk")


def test_read_tries_the_engine_its_dataset_names_first(dummy: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A generation_config.json beside the questions (or above the videos) names the engine tried first; one that
    names none means pymunk; without one the reader's default order stands (None)."""
    for config, first in ((None, None), ({"engine": "box2d"}, "box2d"), ({"engine": "pymunk"}, "pymunk"),
                          ({"format_version": 3}, "pymunk"), ({"engine": "original"}, "original")):
        if config is not None:
            (dummy / "generation_config.json").write_text(json.dumps(config))
        stand_in = StandIn()
        monkeypatch.setattr(read_cli, "read_video", stand_in)
        out = dummy / f"out_{first}_{len(config or {})}.json"
        assert _read(dummy, out, "--quiet") == 0
        assert stand_in.first_engines == [first] * len(VIDEOS)
    assert read_cli.dataset_engine([str(dummy / "videos" / "000000.mp4")]) == "original"  # the folder above
    assert reconstruct.reader_engines(first="pymunk") == ("pymunk", "box2d")
    assert reconstruct.reader_engines(first="original") == ("box2d",)


def test_a_torn_last_line_is_dropped_and_its_video_read_again(dummy: Path, monkeypatch: pytest.MonkeyPatch,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    whole = _uninterrupted(dummy, monkeypatch)
    out = dummy / "preds.json"
    _interrupted(dummy, monkeypatch, out, VIDEOS[2])
    journal = journal_path(out)
    data = journal.read_bytes()
    assert data.count(b"\n") == 3  # the header and two videos
    journal.write_bytes(data[:-25])  # killed while writing the second video's line
    stand_in = StandIn()
    monkeypatch.setattr(read_cli, "read_video", stand_in)
    capsys.readouterr()
    assert _read(dummy, out) == 0
    assert stand_in.read == list(VIDEOS[1:])
    err = capsys.readouterr().err
    assert f"{journal}: line 3 was cut short (the run was stopped while writing it): dropped, its video is read " \
           "again" in err
    assert out.read_bytes() + out.with_suffix(".jsonl").read_bytes() == whole


def test_a_damaged_journal_line_before_the_last_is_refused(dummy: Path, monkeypatch: pytest.MonkeyPatch,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    out = dummy / "preds.json"
    _interrupted(dummy, monkeypatch, out, VIDEOS[2])
    journal = journal_path(out)
    lines = journal.read_bytes().split(b"\n")
    journal.write_bytes(b"\n".join([lines[0], b"{not json", *lines[2:]]))
    capsys.readouterr()
    assert _read(dummy, out, "--quiet") == 2
    assert capsys.readouterr().err.startswith(f"error: {journal}: line 2 is not the record of a finished video")
    journal.write_bytes(b'{"something": "else"}\n')
    assert _read(dummy, out, "--quiet") == 2
    assert capsys.readouterr().err.startswith(f"error: {journal}: not a journal of craft-dsl read")


def test_a_journal_in_use_is_refused(dummy: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("fcntl")
    out = dummy / "preds.json"
    header = {"journal": "craft-dsl read", "version": 1, "questions": "", "videos": "", "options": {}}
    with Journal.open(journal_path(out), header):
        assert _read(dummy, out, "--quiet") == 2
    assert capsys.readouterr().err.startswith(f"error: {journal_path(out)}: another craft-dsl read is writing this "
                                              "journal")


def test_perceived_scenes_missing_on_resume_are_read_again(dummy: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = dummy / "preds.json"
    perceived = dummy / "perceived"
    _interrupted(dummy, monkeypatch, out, VIDEOS[2], "--perceived", str(perceived))
    assert sorted(p.name for p in perceived.iterdir()) == ["000000.json", "000002.json"]
    (perceived / "000002.json").unlink()
    stand_in = StandIn()
    monkeypatch.setattr(read_cli, "read_video", stand_in)
    assert _read(dummy, out, "--quiet", "--perceived", str(perceived)) == 0
    assert stand_in.read == [2, 4]
    assert [json.loads((perceived / f"{v:06d}.json").read_text()) for v in VIDEOS] == [{"video": v} for v in VIDEOS]


def test_read_takes_video_files_folders_and_a_mapping_file(dummy: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    given = _touch(dummy / "given" / "000002.avi")
    odd = _touch(dummy / "odd" / "the fourth (take 2).mov")
    (dummy / "map.json").write_text(json.dumps({"4": "odd/the fourth (take 2).mov"}))
    stand_in = StandIn()
    monkeypatch.setattr(read_cli, "read_video", stand_in)
    out = dummy / "preds.json"
    assert main(["read", "--videos", str(dummy / "videos" / "000000.mp4"), str(given), "--video-map",
                 str(dummy / "map.json"), "--questions", str(dummy / "questions.json"), "--out", str(out),
                 "--workers", "1", "--quiet"]) == 0
    assert stand_in.paths == [str(dummy / "videos" / "000000.mp4"), str(given), str(odd)]
    assert len(json.loads(out.read_text())) == 9


def test_a_video_that_raises_is_reported_and_the_others_written(dummy: Path, monkeypatch: pytest.MonkeyPatch,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(read_cli, "read_video", StandIn({2: ValueError("no layout fits")}))
    out = dummy / "preds.json"
    assert _read(dummy, out, "--quiet") == 2
    assert capsys.readouterr().err == f"error: video 2 ({dummy / 'videos' / '000002.mp4'}): ValueError: no layout " \
                                      "fits\n"
    assert sorted(json.loads(out.read_text())) == [f"{v}_{q}" for v in (0, 4) for q in range(3)]
    assert not journal_path(out).exists()


def _task(key: int) -> int:
    """A task for the worker processes: raises for key 1, kills its process for key 3."""
    if key == 1:
        raise ValueError("bad key")
    if key == 3:
        os._exit(7)
    return key * 10


def test_worker_processes_report_exceptions_and_deaths_and_go_on() -> None:
    results: dict[int, int] = {}
    failures: dict[int, str] = {}
    run_tasks(_task, [(k, (k,)) for k in range(6)], 2, results.__setitem__, failures.__setitem__)
    assert results == {0: 0, 2: 20, 4: 40, 5: 50}
    assert failures == {1: "ValueError: bad key", 3: "the worker process died (exit code 7)"}


def test_a_task_sent_to_a_worker_that_has_just_died_stays_to_do() -> None:
    # the race behind a flaky failure: a worker may die (here: killed) after its last result arrived and before
    # the next task is sent to it; the send must not raise, and the task must stay for another worker
    import multiprocessing
    from collections import deque

    from craft_dsl.pool import _Worker

    worker = _Worker(multiprocessing.get_context("spawn"), _task, "test worker")
    worker.process.kill()
    worker.process.join(timeout=10)
    todo = deque([(0, (0,)), (2, (2,))])
    try:
        assert worker.feed(todo) is False
    finally:
        worker.stop()
    assert list(todo) == [(0, (0,)), (2, (2,))] and not worker.queued


def test_every_task_is_run_when_workers_keep_dying_between_tasks() -> None:
    results: dict[int, int] = {}
    failures: dict[int, str] = {}
    run_tasks(_task, [(k, (k,)) for k in (3, 0, 3, 2, 3, 4)], 2, results.__setitem__, failures.__setitem__)
    assert results == {0: 0, 2: 20, 4: 40}
    assert failures == {3: "the worker process died (exit code 7)"}
