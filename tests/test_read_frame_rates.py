"""The reader at any frame rate from 5 to 60 fps: the rate measured (stated by the file, or inferred from the number
of frames), the step each frame shows, and videos of 10 and 5 fps read as their 60-fps original."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from craft_dsl.errors import ReaderError
from craft_dsl.physics import simulate
from craft_dsl.physics.live import LiveSimulation
from craft_dsl.reader.perceive import Perception, perceive_frames, perceive_video
from craft_dsl.reader.video import (
    checked_rate,
    decode,
    frame_rate,
    incomplete,
    infer_rate,
    mpeg_header_rate,
    steps_shown,
)
from craft_dsl.render import frame_steps, write_frames, write_video
from tests.reader_helpers import tracks_px

STEPS = 240  # 4 s: 240 frames at 60 fps, 40 at 10 fps, 20 at 5 fps


@pytest.fixture(scope="module")
def sim() -> LiveSimulation:
    return simulate(1, seed=0, steps=STEPS)


@pytest.fixture(scope="module")
def videos(sim: LiveSimulation, tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    """The run at 60 fps (MPEG-1, as the dataset stores it), at 10 and 5 fps (H.264, as --downsampled does) and at
    25 fps (a rate that does not divide 60)."""
    out = tmp_path_factory.mktemp("rates")
    return {60: write_video(sim, out / "v60.mpg"), 10: write_video(sim, out / "v10.mp4", fps=10),
            5: write_video(sim, out / "v5.mp4", fps=5), 25: write_video(sim, out / "v25.mp4", fps=25)}


@pytest.fixture(scope="module")
def read_60(videos: dict[int, Path]) -> Perception:
    return perceive_video(videos[60])


def _ffmpeg(*args: str) -> None:
    import imageio_ffmpeg

    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", *args], check=True)


# -- the step each frame shows --------------------------------------------------------------------------------


@pytest.mark.parametrize("fps", [60, 30, 25, 24, 20, 12, 10, 7, 5, 1])
def test_frames_show_the_steps_the_renderer_draws(fps: int) -> None:
    rows = frame_steps(600, fps)
    assert np.array_equal(steps_shown(rows.size, fps), rows)
    assert np.all(np.diff(steps_shown(rows.size, fps)) >= 1)


def test_frame_times_that_fall_between_steps_take_the_nearest() -> None:
    assert steps_shown(5, 25).tolist() == [2, 5, 7, 10, 12]  # 2.4, 4.8, 7.2, 9.6, 12 steps
    assert steps_shown(3, 60).tolist() == [1, 2, 3]
    assert checked_rate(59.94) == 60.0 and checked_rate(30000 / 1001) == 30.0  # NTSC labels of whole rates


@pytest.mark.parametrize("bad", [0, -5, float("nan"), float("inf"), 61, 120])
def test_a_rate_the_reader_cannot_read_is_refused(bad: float) -> None:
    with pytest.raises(ReaderError, match="positive number|above the simulation's 60 steps per second"):
        checked_rate(bad)


# -- measuring the rate ---------------------------------------------------------------------------------------


def test_the_rate_a_file_states_is_taken(videos: dict[int, Path], tmp_path: Path) -> None:
    for fps, path in videos.items():
        rate = frame_rate(path, len(decode(path)))
        assert (rate.fps, rate.source) == (fps, "stated"), rate
    assert mpeg_header_rate(videos[60]) == 60  # a raw MPEG-1 stream: the sequence header says it
    for suffix in (".mkv", ".avi", ".webm"):  # other containers
        copy = tmp_path / f"v10{suffix}"
        _ffmpeg("-i", str(videos[10]), "-c:v", "libvpx" if suffix == ".webm" else "mpeg4", str(copy))
        assert frame_rate(copy, 40).fps == 10.0


@pytest.mark.parametrize(("frames", "fps"), [(600, 60), (590, 60), (501, 60), (100, 10), (97, 10), (50, 5),
                                             (48, 5), (250, 25), (240, 24), (700, 60)])
def test_without_a_stated_rate_the_count_over_a_craft_run_says_it(frames: int, fps: int) -> None:
    assert infer_rate(frames) == fps  # a few frames missing at the end keep the rate


def test_an_mpeg_stream_that_states_no_rate_is_read_by_its_count(videos: dict[int, Path], tmp_path: Path) -> None:
    data = bytearray(videos[60].read_bytes())
    at = data.find(b"\x00\x00\x01\xb3")
    data[at + 7] &= 0xF0  # frame rate code 0: forbidden, states nothing
    blank = tmp_path / "blank.mpg"
    blank.write_bytes(bytes(data))
    assert mpeg_header_rate(blank) is None
    assert frame_rate(blank, 100).fps == 10.0 and frame_rate(blank, 100).source == "count"
    assert frame_rate(blank, 598).fps == 60.0


def test_a_truncated_60_fps_video_stays_60_fps_and_is_reported(videos: dict[int, Path], tmp_path: Path) -> None:
    data = videos[60].read_bytes()
    cut = tmp_path / "cut.mpg"
    cut.write_bytes(data[: len(data) * 9 // 10])
    frames = len(decode(cut))
    assert frames < STEPS
    assert frame_rate(cut, frames).fps == 60.0
    assert "cut short" in (incomplete(cut, frames) or "")


def test_a_10_fps_container_missing_frames_is_reported(videos: dict[int, Path], tmp_path: Path) -> None:
    import av

    with av.open(str(videos[10])) as container:
        packets = [k.pos for k in container.demux(container.streams.video[0]) if k.size]
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(videos[10].read_bytes()[: packets[30]])  # whole packets; the index (in front) states 40 frames
    frames = len(decode(cut))
    assert 0 < frames < 40 and frame_rate(cut, frames).fps == 10.0
    assert incomplete(cut, frames) is not None
    assert incomplete(cut, int(steps_shown(frames, 10)[-1])) is not None  # counted in steps, as a scene's frames
    assert incomplete(videos[10], 40) is None and incomplete(videos[10], STEPS) is None


def test_a_video_above_60_fps_is_refused(videos: dict[int, Path], tmp_path: Path) -> None:
    fast = tmp_path / "fast.mp4"
    frames = decode(videos[10])[:8]
    write_frames(np.repeat(frames, 3, axis=0), fast, fps=120)
    with pytest.raises(ReaderError, match="120 fps, above the simulation's 60 steps per second.*re-encode"):
        perceive_video(fast)


def test_an_override_that_does_not_fit_the_frames_is_refused() -> None:
    frames = np.zeros((10, 256, 256, 3), dtype=np.uint8)
    with pytest.raises(ReaderError, match="above the simulation's 60"):
        perceive_frames(frames, fps=90)
    with pytest.raises(ReaderError, match="10 whole, increasing steps"):
        perceive_frames(frames, frame_steps=[6, 12, 18])
    with pytest.raises(ReaderError, match="10 whole, increasing steps"):
        perceive_frames(frames, frame_steps=[1, 2, 2, 3, 4, 5, 6, 7, 8, 9])
    with pytest.raises(ReaderError, match="not both"):
        perceive_frames(frames, fps=10, frame_steps=list(range(6, 61, 6)))


# -- reading -------------------------------------------------------------------------------------------------


def _same_reading(low: Perception, high: Perception, sim: LiveSimulation, tolerance_px: float) -> None:
    assert low.layout.scene == high.layout.scene == 1
    assert sorted(low.reconstruction.attributes) == sorted(high.reconstruction.attributes)
    truth = {(b.shape, b.color, b.size) for b in sim.world_spec.bodies if b.dynamic}
    assert set(low.reconstruction.attributes) == truth
    ours, theirs = tracks_px(low), tracks_px(high)
    n = min(len(v) for v in ours.values())
    for key, track in ours.items():
        assert float(np.mean(np.hypot(*(track[:n] - theirs[key][:n]).T))) < tolerance_px, key


@pytest.mark.parametrize("fps", [10, 5, 25])
def test_a_low_rate_video_reads_as_its_60_fps_original(fps: int, videos: dict[int, Path], read_60: Perception,
                                                        sim: LiveSimulation) -> None:
    low = perceive_video(videos[fps])
    assert (low.frame_rate.fps, low.frame_rate.source) == (fps, "stated")
    assert low.frame_steps.tolist() == frame_steps(STEPS, fps).tolist()
    assert low.scene.video.fps == 60 and low.scene.meta["video_fps"] == fps  # the run, one frame per step
    assert low.scene.steps == STEPS
    _same_reading(low, read_60, sim, 1.5)


def test_the_rate_can_be_stated_by_the_caller(videos: dict[int, Path]) -> None:
    frames = decode(videos[10])
    given = perceive_frames(frames, fps=10)
    measured = perceive_video(videos[10])
    assert (given.frame_rate.source, measured.frame_rate.source) == ("given", "stated")
    ours, theirs = json.loads(given.scene.dumps()), json.loads(measured.scene.dumps())
    assert ours["meta"].pop("video_fps_source") == "given" and theirs["meta"].pop("video_fps_source") == "stated"
    assert ours == theirs
    by_steps = perceive_frames(frames, frame_steps=frame_steps(STEPS, 10))
    assert by_steps.reconstruction.attributes == given.reconstruction.attributes
