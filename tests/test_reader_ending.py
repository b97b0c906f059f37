"""Whether the frames show a body moving when the video ends (craft_dsl.reader.ending)."""

from __future__ import annotations

import numpy as np
import pytest

from craft_dsl.physics import simulate
from craft_dsl.reader.detect import Blob
from craft_dsl.reader.ending import (
    CONTRADICTED_SPEED,
    MOVE_PX,
    MOVING_STEPS,
    RESTING_STEPS,
    VISIBLE_SPEED,
    RunEnd,
    run_end,
    scene_moving_at_end,
    seen_moving_at_end,
)
from craft_dsl.reader.perceive import perceive_frames
from craft_dsl.render import frames as render_frames
from craft_dsl.simulation import Trajectory

FRAMES = 600
ROWS = np.arange(1, FRAMES + 1)  # 60 fps: frame k shows step k + 1


def _blobs(xs: np.ndarray, ys: np.ndarray, seen: np.ndarray | None = None, edge_from: int = FRAMES,
           on_floor: bool = False) -> list[Blob | None]:
    return [Blob(k, 0, 40.0, float(x), float(y), k >= edge_from, on_floor=on_floor and k >= edge_from)
            if seen is None or seen[k] else None for k, (x, y) in enumerate(zip(xs, ys))]


def _stopping_at(stop: int, speed: float = 0.5) -> list[Blob | None]:
    """A body moving right at ``speed`` pixels a frame until frame ``stop``, then still."""
    k = np.arange(FRAMES)
    return _blobs(100.0 + speed * np.minimum(k, stop), np.full(FRAMES, 80.0))


def test_a_body_moving_in_the_last_frames_is_moving() -> None:
    assert seen_moving_at_end(_stopping_at(FRAMES), ROWS) is True
    assert seen_moving_at_end(_stopping_at(FRAMES - MOVING_STEPS + 2), ROWS) is True


def test_a_body_still_for_the_last_second_is_at_rest() -> None:
    assert seen_moving_at_end(_stopping_at(FRAMES - 60), ROWS) is False
    assert seen_moving_at_end(_blobs(np.full(FRAMES, 10.0), np.full(FRAMES, 20.0)), ROWS) is False


def test_a_body_that_stopped_less_than_the_resting_time_ago_is_left_to_the_run() -> None:
    """Sleeping takes 30 steps of rest: a body still for 25 frames may be awake or asleep."""
    assert seen_moving_at_end(_stopping_at(FRAMES - 25), ROWS) is None


def test_the_compression_flicker_of_a_still_body_is_not_motion() -> None:
    """Edges that move by 0.6 px in two frames of every four (an MPEG group) average out."""
    k = np.arange(FRAMES)
    xs = 50.0 + np.where(k % 4 < 2, 0.6, 0.0)
    assert seen_moving_at_end(_blobs(xs, np.full(FRAMES, 30.0)), ROWS) is False


def test_a_passing_jump_of_the_centroid_is_not_motion() -> None:
    """The centroid off by 0.8 px for a few frames (an artefact) and back: not moving, and not seen at rest."""
    k = np.arange(FRAMES)
    xs = 50.0 + np.where((k >= FRAMES - 16) & (k < FRAMES - 10), 0.8, 0.0)
    assert seen_moving_at_end(_blobs(xs, np.full(FRAMES, 30.0)), ROWS) is None


def test_slow_motion_just_over_the_threshold_counts() -> None:
    k = np.arange(FRAMES)
    per_frame = 2.5 * MOVE_PX / 18  # the averaged positions 10 steps apart differ by more than MOVE_PX
    xs = 50.0 + per_frame * k
    assert seen_moving_at_end(_blobs(xs, np.full(FRAMES, 30.0)), ROWS) is True


def test_a_body_not_seen_at_the_end_or_mostly_hidden_is_left_to_the_run() -> None:
    still = np.full(FRAMES, 10.0)
    hidden_last = np.ones(FRAMES, dtype=bool)
    hidden_last[-1] = False
    assert seen_moving_at_end(_blobs(still, still, hidden_last), ROWS) is None
    mostly_hidden = np.ones(FRAMES, dtype=bool)
    mostly_hidden[FRAMES - RESTING_STEPS:-1] = np.arange(RESTING_STEPS - 1) % 3 == 0
    assert seen_moving_at_end(_blobs(still, still, mostly_hidden), ROWS) is None
    assert seen_moving_at_end([], np.zeros(0, dtype=np.int64)) is None
    assert seen_moving_at_end(_blobs(still, still)[:-1], ROWS) is None  # blobs and rows disagree


def test_a_blob_cut_off_by_the_border_is_not_looked_at() -> None:
    """A body entering the frame's edge: its blob's centroid moves with the cut."""
    k = np.arange(FRAMES)
    xs = 240.0 + 0.3 * np.clip(k - (FRAMES - 25), 0, None)
    assert seen_moving_at_end(_blobs(xs, np.full(FRAMES, 30.0), edge_from=FRAMES - 25), ROWS) is None
    assert seen_moving_at_end(_blobs(xs, np.full(FRAMES, 30.0)), ROWS) is True


def test_a_still_body_shifted_once_is_not_moving() -> None:
    """A lossy copy moves a still body's centroid once where a group of pictures begins (MPEG-4 at q 8: 1.6 px):
    as far from the last position 10 steps before the end as 20 steps before, which no motion is."""
    k = np.arange(FRAMES)
    xs = 50.0 + np.where(k >= FRAMES - 6, 1.6, 0.0)
    assert seen_moving_at_end(_blobs(xs, np.full(FRAMES, 30.0)), ROWS) is not True
    falling = 30.0 + 0.5 * 0.02 * np.clip(k - (FRAMES - 20), 0, None) ** 2  # from rest 20 steps before the end
    assert seen_moving_at_end(_blobs(np.full(FRAMES, 50.0), falling), ROWS) is True


def test_a_body_rolling_along_the_ground_line_is_seen_moving() -> None:
    """At the frame's bottom edge the ground line is drawn: a body rolling on the ground that a rescaled video blurs
    into it reaches the border, but its blob moves only as the body does (a body cut at a side is left to the run)."""
    k = np.arange(FRAMES)
    xs = 120.0 - 0.1 * k
    ys = np.full(FRAMES, 251.5)
    assert seen_moving_at_end(_blobs(xs, ys, edge_from=0, on_floor=True), ROWS) is True
    assert seen_moving_at_end(_blobs(xs, ys, edge_from=0), ROWS) is None
    assert seen_moving_at_end(_blobs(np.full(FRAMES, 120.0), ys, edge_from=0, on_floor=True), ROWS) is False


def test_a_body_cut_by_the_border_whose_blob_stays_put_is_at_rest() -> None:
    """A large circle at rest against the picture's right edge (H.264 copy: its run rolled it on at 1.4 m/s): its cut
    blob does not move in the last second, so neither does the body; one whose cut blob moves is left to the run."""
    still = _blobs(np.full(FRAMES, 244.0), np.full(FRAMES, 192.0), edge_from=0)
    assert seen_moving_at_end(still, ROWS) is False
    k = np.arange(FRAMES)
    leaving = _blobs(200.0 + 0.1 * k, np.full(FRAMES, 192.0), edge_from=0)
    assert seen_moving_at_end(leaving, ROWS) is None
    arriving = _blobs(np.full(FRAMES, 244.0), np.full(FRAMES, 192.0), edge_from=FRAMES - 30)
    assert seen_moving_at_end(arriving, ROWS) is False  # touching the border only in the last frames (a pixel wider)


def test_lower_frame_rates_are_read_in_steps() -> None:
    """At 10 fps (a frame every 6 steps) the windows are the same steps."""
    rows = np.arange(6, FRAMES + 1, 6)
    k = np.arange(rows.size)
    moving = _blobs(100.0 + 3.0 * k, np.full(rows.size, 80.0))
    still = _blobs(np.full(rows.size, 100.0), np.full(rows.size, 80.0))
    assert seen_moving_at_end(moving, rows) is True
    assert seen_moving_at_end(still, rows) is False


MOVING = _stopping_at(FRAMES)  # seen moving at the end
STILL = _stopping_at(FRAMES - 60)  # seen still for the last second
STOPPED_LONG_AGO = RunEnd(moving=False, speed=0.0, last_moving=300)
FLYING = RunEnd(moving=True, speed=2.0, last_moving=FRAMES)


def test_a_scene_is_read_from_the_frames_where_they_decide_every_body() -> None:
    runs = {0: STOPPED_LONG_AGO, 1: FLYING}
    assert scene_moving_at_end({0: MOVING, 1: STILL}, runs, 2, ROWS) == {0: True, 1: False}


def test_a_scene_read_in_part_corrects_only_bodies_seen_still_that_the_run_has_flying() -> None:
    """Where a body is undecided, another is corrected only where the frames and the run flatly disagree: seen still
    while its run ends at CONTRADICTED_SPEED or faster. A body seen moving that the run stopped, or one whose run ends
    slower, waits for the whole scene."""
    undecided = _stopping_at(FRAMES - 25)  # stopped 25 frames ago: the frames do not say
    runs = {0: STOPPED_LONG_AGO, 1: FLYING, 2: FLYING}
    assert scene_moving_at_end({0: MOVING, 1: STILL, 2: undecided}, runs, 3, ROWS) == {1: False}
    assert scene_moving_at_end({0: MOVING, 1: STILL}, runs, 3, ROWS) == {1: False}  # a slot untracked
    assert scene_moving_at_end({0: MOVING, 1: STILL}, {1: FLYING}, 2, ROWS) == {1: False}  # no run for slot 0
    slower = RunEnd(moving=True, speed=0.5 * (VISIBLE_SPEED + CONTRADICTED_SPEED), last_moving=FRAMES)
    assert scene_moving_at_end({1: STILL, 2: undecided}, {1: slower, 2: FLYING}, 2, ROWS) == {}
    assert scene_moving_at_end({1: STILL, 2: STILL}, {1: slower, 2: FLYING}, 2, ROWS) == {1: False, 2: False}


def test_the_frames_overrule_the_run_only_where_both_cannot_be_right() -> None:
    """A run creeping too slowly to show, or stopping the body in the last steps, is kept."""
    creeping = RunEnd(moving=True, speed=0.5 * VISIBLE_SPEED, last_moving=FRAMES)
    stopping_late = RunEnd(moving=False, speed=0.0, last_moving=FRAMES - MOVING_STEPS // 2)
    assert scene_moving_at_end({0: STILL, 1: MOVING}, {0: creeping, 1: stopping_late}, 2, ROWS) == {0: True, 1: False}


def test_how_a_run_ends_for_a_body() -> None:
    steps = 10
    velocities = np.zeros((steps + 1, 2, 2))
    velocities[:6, 0] = (0.5, 0.0)  # body 7 stops after step 5
    velocities[:, 1] = (0.0, -0.3)  # body 9 falls to the end
    traj = Trajectory((7, 9), np.zeros((steps + 1, 2, 2)), np.zeros((steps + 1, 2)), velocities,
                      np.zeros((steps + 1, 2)))
    assert run_end(traj, 7) == RunEnd(False, 0.0, 5)
    falling = run_end(traj, 9)
    assert falling.moving and falling.last_moving == steps and falling.speed == pytest.approx(0.3)


@pytest.fixture(scope="module")
def rendered_end() -> tuple[object, np.ndarray]:
    sim = simulate(3, seed=6, steps=360)  # two bodies moving at the end, one still
    return sim, render_frames(sim)


def test_the_perceived_scene_says_what_the_frames_show(rendered_end: tuple[object, np.ndarray]) -> None:
    """The frames decide every body of this video: each object's ``moving_end`` is theirs, and the truth."""
    sim, video = rendered_end
    p = perceive_frames(video)
    world = sim.world  # type: ignore[attr-defined]
    truth_uid = {(b.shape, b.color, b.size): b.uid for b in world.bodies if b.dynamic}
    ours = {b.uid: (b.shape, b.color, b.size) for b in p.reconstruction.simulation.world_spec.bodies if b.dynamic}
    flags = {obj.id: obj.moving_end for obj in p.scene.objects if obj.id in ours}
    assert len(flags) == len(truth_uid) and set(flags.values()) == {0.0, 1.0}
    for uid, flag in flags.items():
        assert flag == (1.0 if truth_uid[ours[uid]] in sim.moving(-1) else 0.0)  # type: ignore[attr-defined]
