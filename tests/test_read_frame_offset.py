"""A resampled copy whose frames show earlier steps than the renderer's (ffmpeg's ``fps`` filter keeps a middle
frame of each interval): the offset is measured from the start of the run, or given, and the copy reads as its
60-fps original."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from craft_dsl.errors import ReaderError
from craft_dsl.physics import simulate
from craft_dsl.physics.live import LiveSimulation
from craft_dsl.reader.perceive import Perception, perceive_frames, perceive_video
from craft_dsl.reader.timing import offsets_allowed
from craft_dsl.reader.video import decode, steps_shown
from craft_dsl.render import frame_steps, write_video
from tests.reader_helpers import tracks_px

STEPS = 240  # 4 s: 240 frames at 60 fps, 40 at 10 fps


@pytest.fixture(scope="module")
def sim() -> LiveSimulation:
    return simulate(1, seed=0, steps=STEPS)


@pytest.fixture(scope="module")
def frames_60(sim: LiveSimulation, tmp_path_factory: pytest.TempPathFactory) -> np.ndarray:
    """The run's 60-fps video as decoded: frame j shows step j + 1."""
    return decode(write_video(sim, tmp_path_factory.mktemp("offset") / "v60.mpg"))


@pytest.fixture(scope="module")
def read_60(frames_60: np.ndarray) -> Perception:
    return perceive_frames(frames_60)


def _resampled(frames_60: np.ndarray, fps: int, offset: int) -> np.ndarray:
    """Every (60 / fps)-th frame, each showing ``offset`` steps before the renderer's step of its interval."""
    return frames_60[steps_shown(len(frames_60) * fps // 60, fps) + offset - 1]


def _mean_px_apart(low: Perception, high: Perception) -> float:
    """The largest of the bodies' mean distances (pixels) between the two readings' runs."""
    ours, theirs = tracks_px(low), tracks_px(high)
    assert ours.keys() == theirs.keys()
    return max(float(np.mean(np.hypot(*(ours[k] - theirs[k]).T))) for k in ours)


@pytest.mark.parametrize(("rows", "allowed"), [
    (frame_steps(600, 10), [0, -1, -2, -3, -4, -5]),
    (frame_steps(600, 5), list(range(0, -12, -1))),
    (frame_steps(600, 60), [0]),
    (frame_steps(600, 25), [0, -1]),  # frames 2 or 3 steps apart: within the shorter spacing
    (np.array([2, 8, 14]), [0, -1]),  # never before step 1
    (np.array([6]), [0]),
])
def test_the_offsets_a_resampled_copy_can_have(rows: np.ndarray, allowed: list[int]) -> None:
    assert offsets_allowed(np.asarray(rows)) == allowed


def test_a_copy_whose_frames_are_3_steps_early_is_measured_and_read_as_its_original(
        frames_60: np.ndarray, read_60: Perception, sim: LiveSimulation) -> None:
    early = _resampled(frames_60, 10, -3)  # ffmpeg's fps=10: steps 3, 9, 15, ...
    low = perceive_frames(early, fps=10)
    assert low.frame_offset == -3
    assert low.frame_steps.tolist() == (frame_steps(STEPS, 10) - 3).tolist()
    assert low.scene.meta["frame_offset"] == -3
    assert low.scene.steps == STEPS  # the run goes on to the end of the rule's last frame
    assert sorted(low.reconstruction.attributes) == sorted(
        (b.shape, b.color, b.size) for b in sim.world_spec.bodies if b.dynamic)
    assert _mean_px_apart(low, read_60) < 1.5
    # read with the renderer's steps instead, the same copy's run is a few steps off all along
    stated = perceive_frames(early, fps=10, frame_offset=0)
    assert stated.frame_offset == 0 and "frame_offset" not in stated.scene.meta
    assert _mean_px_apart(stated, read_60) > _mean_px_apart(low, read_60)


def test_a_copy_with_the_renderers_steps_keeps_them(frames_60: np.ndarray) -> None:
    low = perceive_frames(_resampled(frames_60, 10, 0), fps=10)
    assert low.frame_offset == 0
    assert low.frame_steps.tolist() == frame_steps(STEPS, 10).tolist()
    assert "frame_offset" not in low.scene.meta


def test_a_60_fps_video_has_no_offset_to_measure(read_60: Perception) -> None:
    assert read_60.frame_offset == 0
    assert read_60.frame_steps.tolist() == list(range(1, STEPS + 1))


def test_a_given_offset_is_used_as_it_is(frames_60: np.ndarray) -> None:
    early = _resampled(frames_60, 10, -2)
    given = perceive_frames(early, fps=10, frame_offset=-2)
    assert given.frame_offset == -2 and given.frame_steps[0] == 4


def test_an_offset_the_frames_cannot_have_is_refused(tmp_path: Path) -> None:
    frames = np.zeros((10, 256, 256, 3), dtype=np.uint8)
    with pytest.raises(ReaderError, match=r"frame_offset -6 is not one these frames can have: 0, -1, -2, -3, -4, -5"):
        perceive_frames(frames, fps=10, frame_offset=-6)
    with pytest.raises(ReaderError, match="frame_offset 1 is not one"):
        perceive_frames(frames, fps=10, frame_offset=1)
    with pytest.raises(ReaderError, match="frame_steps or frame_offset, not both"):
        perceive_frames(frames, frame_steps=list(range(6, 61, 6)), frame_offset=0)
    with pytest.raises(ReaderError, match="frame_offset -1 is not one these frames can have: 0"):
        perceive_frames(frames, frame_offset=-1)  # 60 fps: every step is a frame
    missing = tmp_path / "none.mp4"
    with pytest.raises(ReaderError):
        perceive_video(missing, frame_offset=0)
