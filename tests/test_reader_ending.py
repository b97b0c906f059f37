"""Whether the frames show a body moving when the video ends (craft_dsl.reader.ending)."""

from __future__ import annotations

import numpy as np
import pytest

from craft_dsl.physics import simulate
from craft_dsl.reader.detect import Blob
from craft_dsl.reader.ending import MOVE_PX, MOVING_STEPS, RESTING_STEPS, seen_moving_at_end
from craft_dsl.reader.perceive import perceive_frames
from craft_dsl.render import frames as render_frames

FRAMES = 600
ROWS = np.arange(1, FRAMES + 1)  # 60 fps: frame k shows step k + 1


def _blobs(xs: np.ndarray, ys: np.ndarray, seen: np.ndarray | None = None, edge_from: int = FRAMES
           ) -> list[Blob | None]:
    return [Blob(k, 0, 40.0, float(x), float(y), k >= edge_from) if seen is None or seen[k] else None
            for k, (x, y) in enumerate(zip(xs, ys))]


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
    xs = 250.0 + np.where(k >= FRAMES - 5, 1.5, 0.0)
    assert seen_moving_at_end(_blobs(xs, np.full(FRAMES, 30.0), edge_from=FRAMES - 5), ROWS) is None
    assert seen_moving_at_end(_blobs(xs, np.full(FRAMES, 30.0)), ROWS) is True


def test_lower_frame_rates_are_read_in_steps() -> None:
    """At 10 fps (a frame every 6 steps) the windows are the same steps."""
    rows = np.arange(6, FRAMES + 1, 6)
    k = np.arange(rows.size)
    moving = _blobs(100.0 + 3.0 * k, np.full(rows.size, 80.0))
    still = _blobs(np.full(rows.size, 100.0), np.full(rows.size, 80.0))
    assert seen_moving_at_end(moving, rows) is True
    assert seen_moving_at_end(still, rows) is False


@pytest.fixture(scope="module")
def rendered_end() -> tuple[object, np.ndarray]:
    sim = simulate(1, seed=3, steps=360)  # two bodies still at the end, one moving, one cut off by the border
    return sim, render_frames(sim)


def test_the_perceived_scene_says_what_the_frames_show(rendered_end: tuple[object, np.ndarray]) -> None:
    """Every body the frames decide about gets that ``moving_end`` in the perceived scene, and it is the truth."""
    sim, video = rendered_end
    p = perceive_frames(video)
    world = sim.world  # type: ignore[attr-defined]
    truth_uid = {(b.shape, b.color, b.size): b.uid for b in world.bodies if b.dynamic}
    ours = {b.uid: (b.shape, b.color, b.size) for b in p.reconstruction.simulation.world_spec.bodies if b.dynamic}
    decided = 0
    for obj in p.scene.objects:
        if obj.id not in ours:
            continue
        if obj.moving_end is not None:
            decided += 1
            assert obj.moving_end == (1.0 if truth_uid[ours[obj.id]] in sim.moving(-1) else 0.0)  # type: ignore[attr-defined]
    assert decided >= 3
    assert {obj.moving_end for obj in p.scene.objects if obj.id in ours} >= {0.0, 1.0}
