"""Tracks of bodies of one colour: pieces of one body counted once; two bodies that touch and part relinked so
that each is one shape."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from craft_dsl.reader.detect import PALETTE, Blob, blobs, grid_labels, grid_rims
from craft_dsl.reader.track import (
    IMPURE_WEIGHT,
    TrackedObject,
    classify_shape,
    colour_distance,
    count_per_color,
    drop_riding,
    drop_strays,
    measure_frames,
    pair_twins,
    purity,
    refine_frames,
    relink_merges,
    riding_frames,
    riding_share,
    select_objects,
    track,
)
from craft_dsl.render import frames as render_frames
from craft_dsl.render.raster import static_layer
from craft_dsl.vocabulary import COLORS
from craft_dsl.world import WorldSpec, assign_uids, make_dynamic, make_static
from tests.synthetic_scene import simulation_from_rows


@pytest.fixture(scope="module")
def passing_bodies() -> tuple[np.ndarray, np.ndarray, list[TrackedObject]]:
    """A green circle and a green triangle that slide past each other, touching for a while (one blob): frames,
    background, and their tracks."""
    bodies = [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
              make_static(0, "basket", (12.0, -1.2)),
              make_dynamic(0, "circle", "green", "large", (0.0, 0.0)),
              make_dynamic(0, "triangle", "green", "large", (0.0, 0.0))]
    world = WorldSpec(bodies=assign_uids(bodies), scene_id=None, seed=0)
    steps = 120
    k = np.arange(steps + 1)
    pos = np.zeros((steps + 1, len(bodies), 2))
    for i, b in enumerate(world.bodies):
        pos[:, i] = b.position
        if b.shape == "circle":
            pos[:, i] = np.stack([-12 + 0.2 * k, np.full(k.size, 24.0)], axis=1)
        elif b.shape == "triangle":
            pos[:, i] = np.stack([12 - 0.2 * k, np.full(k.size, 20.5)], axis=1)
    frames = render_frames(simulation_from_rows(world, pos, np.zeros((steps + 1, len(bodies)))))
    background = static_layer(WorldSpec(bodies=tuple(b for b in world.bodies if not b.dynamic)), 256)
    return frames, background, track(blobs(grid_labels(frames, background), grid_rims(background)), len(frames))


def _shapes(objects: list[TrackedObject], frames: np.ndarray, background: np.ndarray) -> list[str]:
    for obj in objects:
        classify_shape(obj, frames, background)
    return [max(obj.shape_size, key=lambda key: obj.shape_size[key])[0] for obj in objects]


def _copies(objects: list[TrackedObject]) -> list[TrackedObject]:
    return [TrackedObject(o.color, list(o.blobs)) for o in objects]


def test_tracks_swapped_at_a_merge_are_swapped_back(passing_bodies: tuple[np.ndarray, np.ndarray,
                                                                           list[TrackedObject]]) -> None:
    frames, background, tracked = passing_bodies
    a, b = objects = _copies(tracked)
    both_lost = [k for k in range(len(frames)) if a.blobs[k] is None and b.blobs[k] is None]
    assert len(both_lost) >= 10  # they touched: one blob, given to neither
    parted = both_lost[-1] + 1
    a.blobs[parted:], b.blobs[parted:] = b.blobs[parted:], a.blobs[parted:]  # the tracker's mistake
    assert relink_merges(objects, frames, background) == 1
    assert [o.blobs for o in objects] == [o.blobs for o in tracked]
    assert sorted(_shapes(objects, frames, background)) == ["circle", "triangle"]


def test_tracks_that_kept_their_bodies_are_left_alone(passing_bodies: tuple[np.ndarray, np.ndarray,
                                                                             list[TrackedObject]]) -> None:
    frames, background, tracked = passing_bodies
    objects = _copies(tracked)
    assert relink_merges(objects, frames, background) == 0
    assert [o.blobs for o in objects] == [o.blobs for o in tracked]
    assert all(not o.measurements for o in objects)  # measurements of blobs that may have moved are dropped


def _blob(frame: int, x: float, y: float, area: float) -> Blob:
    return Blob(frame, 1, area, x, y, False)


def test_pieces_of_one_body_count_as_one_body() -> None:
    # the original renderer's eyes cut a large triangle into an apex (44 px) and a base (140 px) 11 px apart, in
    # most frames of a video: the colour holds one body, and that body is tracked in every frame
    frames = 40
    pieces = [b for k in range(frames) for b in (_blob(k, 100.0 + k, 69.0, 44.0), _blob(k, 100.4 + k, 80.1, 140.0))]
    assert count_per_color(pieces, frames) == {1: 1}
    (body,) = track(pieces, frames)
    assert len(body.seen()) == frames


def test_two_bodies_of_one_colour_apart_count_as_two() -> None:
    frames = 40
    apart = [b for k in range(frames) for b in (_blob(k, 60.0, 100.0, 56.0), _blob(k, 60.0 + k, 130.0, 140.0))]
    assert count_per_color(apart, frames) == {1: 2}
    # side by side in every frame (centres nearer than the square root of the summed area), they read as one
    close = [b for k in range(frames) for b in (_blob(k, 60.0, 100.0, 56.0), _blob(k, 60.0, 112.0, 140.0))]
    assert count_per_color(close, frames) == {1: 1}


def _body_with_a_speck_elsewhere(body_area: float) -> tuple[list[Blob], int]:
    """A body of 272 px moving right along a row, and a speck of its colour (16-24 px) far from it in enough frames
    to count as a second body of the colour (the original renderer's gray near another body's eyes); in frames 30-59
    the speck is not seen and the body's blob measures ``body_area`` (its area varies from frame to frame)."""
    frames = 60
    out = []
    for k in range(frames):
        out.append(_blob(k, 40.0 + k, 100.0, 272.0 if k < 30 else body_area))
        if k < 30:
            out.append(_blob(k, 220.0, 240.0, 16.0 + 8.0 * (k % 2)))
    return out, frames


def test_a_body_s_larger_blob_is_its_own_while_the_only_other_body_of_its_colour_is_far_away() -> None:
    # the speck's track is a body of the colour; the body's blob larger than its own area plus half the speck's is
    # still the body's alone: the speck was last seen 180 px away, out of the blob's reach
    pieces, frames = _body_with_a_speck_elsewhere(296.0)
    assert count_per_color(pieces, frames) == {1: 2}
    body = max(track(pieces, frames), key=lambda t: sum(b.area for b in t.blobs if b is not None))
    assert len(body.seen()) == frames


def test_a_blob_as_large_as_two_bodies_near_it_together_is_given_to_neither() -> None:
    # a small body (60 px) moves 30 px from a large one (330 px), then one blob of 390 px covers both: it is neither's
    frames = 60
    pieces = []
    for k in range(frames):
        if k < 30:
            pieces += [_blob(k, 40.0 + k, 100.0, 330.0), _blob(k, 40.0 + k, 130.0, 60.0)]
        else:
            pieces.append(_blob(k, 40.0 + k, 103.0, 390.0))
    large, small = sorted(track(pieces, frames), key=lambda t: -max(b.area for b in t.blobs if b is not None))
    assert large.seen() == list(range(30)) and small.seen() == list(range(30))


def _still_track(color: str, core: tuple[float, float, float], frames: int, area: float, x: int
                 ) -> tuple[TrackedObject, np.ndarray]:
    """A track of one small blob at column ``x`` in every frame, and a strip of frames whose pixels there have the
    colour ``core``."""
    picture = np.full((frames, 32, 64, 3), 255, dtype=np.uint8)
    picture[:, 10:22, x - 6:x + 6] = np.array(core, dtype=np.uint8)
    c = COLORS.index(color)
    return TrackedObject(c, [Blob(k, c, area, float(x), 16.0, False) for k in range(frames)]), picture


def test_purity_falls_with_the_core_colour_s_distance_from_the_palette() -> None:
    red = tuple(float(v) for v in PALETTE[COLORS.index("red")])
    weights = []
    for lift in (0.0, 25.0, 60.0):  # brighter by ``lift`` in every channel: the luma off by as much, the same chroma
        obj, picture = _still_track("red", (red[0] + lift, red[1] + lift, red[2] + lift), 4, 30.0, 32)
        weights.append(purity(obj, picture))
    assert weights[0] == 1.0
    assert IMPURE_WEIGHT * 0.9 < weights[1] <= IMPURE_WEIGHT
    assert weights[2] < 0.1 * weights[1]


def test_compression_keeps_a_small_body_s_luma_and_hue_and_shrinks_its_chroma() -> None:
    """Cores measured on an H.264 copy (crf 28): a small brown circle's is 39 RGB units from brown but has its luma
    and hue, so it is pure; a piece of a green body read gray has gray's luma but the green's chroma, so it is not;
    a gray body's own core is neutral."""
    assert purity(*_still_track("brown", (108.0, 83.0, 57.0), 4, 28.0, 32)) == 1.0
    assert purity(*_still_track("blue", (66.0, 66.0, 194.0), 4, 20.0, 32)) == 1.0
    assert purity(*_still_track("gray", (89.0, 88.0, 90.0), 4, 36.0, 32)) == 1.0
    assert purity(*_still_track("gray", (67.0, 91.0, 68.0), 4, 24.0, 32)) < 0.5 * IMPURE_WEIGHT
    assert colour_distance(np.array([108.0, 83.0, 57.0]), COLORS.index("brown")) < 0.2
    # a hue the colour does not have is far however much chroma it keeps: brown's luma with purple's hue
    assert colour_distance(np.array([110.0, 70.0, 140.0]), COLORS.index("brown")) > 1.5


def test_a_compressed_small_body_outranks_a_gray_piece_of_another_body() -> None:
    """The H.264 copy that lost 10 answers: a small brown circle's core desaturated by compression, and a gray track
    along a green body's edge (its darker pixels read gray), seen in almost as many frames: the brown body is kept."""
    body, left = _still_track("brown", (108.0, 83.0, 57.0), 60, 28.0, 16)
    piece, right = _still_track("gray", (67.0, 91.0, 68.0), 60, 24.0, 48)
    piece.blobs = piece.blobs[:50] + [None] * 10
    frames = np.where(np.arange(64)[None, None, :, None] < 32, left, right)
    assert select_objects([piece, body], 1, frames) == [body]


def test_a_softened_small_body_outranks_the_gray_ring_of_another_body_s_eye() -> None:
    """Rescaled from a small video, a small blue body's core is off its colour (both tracks impure) and a large
    body's eye leaves a gray ring, seen in more frames and larger: the body is kept, the ring is not."""
    blue = PALETTE[COLORS.index("blue")]
    body, left = _still_track("blue", (float(blue[0]), float(blue[1]), float(blue[2]) - 40.0), 180, 32.0, 16)
    ring, right = _still_track("gray", (125.0, 171.0, 120.0), 200, 60.0, 48)
    picture = np.where(np.arange(64)[None, None, :, None] < 32, left[:180], right[:180])
    body.blobs = body.blobs + [None] * 20
    frames = np.concatenate([picture, right[180:]])
    assert select_objects([ring, body], 1, frames) == [body]


def _moving_track(color: str, frames: int, area: float, x0: float, seen: range | None = None) -> TrackedObject:
    """A track moving one pixel a frame along row 100 from column ``x0``, seen in the frames ``seen`` (all)."""
    c = COLORS.index(color)
    shown = range(frames) if seen is None else seen
    return TrackedObject(c, [Blob(k, c, area, x0 + k, 100.0, False) if k in shown else None for k in range(frames)])


def test_a_track_inside_a_larger_body_of_another_colour_rides_on_it() -> None:
    """The gray of a body's blurred eyes, inside that body's blob, rides on it; a gray body beside another does not
    (bodies do not overlap), nor does the larger body on the smaller track at its centre, nor a track of the same
    colour."""
    host = _moving_track("red", 100, 200.0, 50.0)  # a disk of radius 8 px
    eyes = _moving_track("gray", 100, 40.0, 53.0)  # 3 px from the host's centre
    beside = _moving_track("gray", 100, 40.0, 62.0)  # 12 px away: touching, not inside
    half = _moving_track("gray", 100, 40.0, 53.0, range(50))  # rides while seen, then gone
    twin = _moving_track("red", 100, 40.0, 53.0)  # the host's own colour: a piece of it, not a rider
    assert riding_share(eyes, [host, eyes]) == 1.0
    assert riding_share(beside, [host, beside]) == 0.0
    assert riding_share(half, [host, half]) == 1.0
    assert riding_share(host, [host, eyes]) == 0.0
    assert riding_share(twin, [host, twin]) == 0.0
    host.blobs[:25] = [None] * 25  # the host leaves the picture for a quarter of the frames
    assert riding_share(eyes, [host, eyes]) == 0.75


def test_a_faded_small_body_outranks_gray_riding_on_other_bodies_eyes() -> None:
    """A compressed video: a small blue body faded to 20 px² seen in 300 frames; a gray track of 40 px² seen in 200
    frames, three quarters of them on a red body's eyes. Frames times area alone keep the gray track."""
    frames = 300
    picture = np.full((frames, 400, 400, 3), 255, dtype=np.uint8)
    blue, red = PALETTE[COLORS.index("blue")], PALETTE[COLORS.index("red")]
    gray = PALETTE[COLORS.index("gray")]
    for k in range(frames):
        picture[k, 147:153, 200 + k // 2 - 3:200 + k // 2 + 3] = blue
        picture[k, 92:108, 42 + k:58 + k] = red
        picture[k, 97:103, 50 + k:56 + k] = gray
    body = TrackedObject(COLORS.index("blue"), [Blob(k, COLORS.index("blue"), 20.0, 200.0 + k // 2, 150.0, False)
                                                for k in range(frames)])
    host = _moving_track("red", frames, 200.0, 50.0)
    rider = _moving_track("gray", frames, 40.0, 53.0, range(150))
    for k in range(250, frames):  # a quarter of its frames away from any body
        rider.blobs[k] = Blob(k, COLORS.index("gray"), 40.0, 300.0, 150.0, False)
    picture[250:, 147:153, 297:303] = gray
    assert purity(rider, picture) == 1.0 and purity(body, picture) == 1.0
    assert riding_share(rider, [host, rider, body]) == 0.75
    assert select_objects([host, rider, body], 2, picture) == [host, body]


def test_a_body_read_in_two_colours_does_not_ride_on_itself() -> None:
    """A small brown body faded by compression reads partly gray: two blobs of similar areas at one place, neither
    the other's host."""
    brown = _moving_track("brown", 50, 16.0, 80.0)
    gray = _moving_track("gray", 50, 24.0, 80.5)
    assert riding_frames(brown, [brown, gray]) == [] and riding_frames(gray, [brown, gray]) == []


def _path(frames: int, x0: float = 40.0, y: float = 100.0, step: float = 2.0) -> list[Blob | None]:
    """A body moving ``step`` pixels a frame along a row."""
    return [_blob(k, x0 + step * k, y, 50.0) for k in range(frames)]


def test_a_piece_that_seeds_a_track_before_its_body_is_seen_is_dropped() -> None:
    """H.264 cuts a piece off a large triangle in frames 1-2 while a cube's sliver at the top edge is not seen yet;
    the piece starts the cube's track, which then jumps 190 px to the cube."""
    blobs: list[Blob | None] = [None, _blob(1, 214.5, 92.1, 56.0), _blob(2, 213.5, 90.9, 40.0)]
    blobs += [_blob(k, 45.5, 0.5 + 0.1 * k, 40.0) for k in range(3, 60)]
    kept = drop_strays(blobs)
    assert kept[:3] == [None, None, None] and kept[3:] == blobs[3:]


def test_a_speck_between_two_runs_of_a_body_is_dropped_and_the_runs_kept() -> None:
    blobs = _path(80)
    blobs[40] = _blob(40, 230.0, 20.0, 20.0)  # a speck of the colour elsewhere while the body is not seen alone
    kept = drop_strays(blobs)
    assert kept[40] is None and [k for k, b in enumerate(kept) if b is None] == [40]


def test_a_track_that_moves_as_a_body_can_is_left_whole() -> None:
    assert drop_strays(_path(80, step=3.4)) == _path(80, step=3.4)  # the fastest body of 100 simulated scenes
    hidden = _path(80)
    hidden[20:60] = [None] * 40  # hidden for 40 frames, seen again 80 px on
    assert drop_strays(hidden) == hidden
    # at 10 fps a frame is 6 steps: 30 px between frames is a body's speed, not a jump
    sparse = _path(60, step=30.0)
    assert drop_strays(sparse, rows=[6 * (k + 1) for k in range(60)]) == sparse
    # at 60 fps the same track jumps in every frame: all its runs are short, and none is dropped for another
    assert drop_strays(sparse) == sparse


def test_a_body_s_track_loses_the_specks_it_picked_up_on_a_larger_body_before_it_entered() -> None:
    """H.264, crf 28: before a small green body falls into the picture, its track holds green specks on a large brown
    body's rim; placed there, the green body's start (its first sighting) is wrong."""
    frames = 120
    host = _moving_track("brown", frames, 220.0, 50.0)
    green = COLORS.index("green")
    specks = [Blob(k, green, 40.0, 52.0 + k, 101.0, False) for k in range(50)]
    body = [Blob(k, green, 24.0, 180.0, 2.0 * (k - 60), False) for k in range(60, frames)]
    track_ = TrackedObject(green, [*specks, *[None] * 10, *body])
    drop_riding([host, track_])
    assert track_.seen() == list(range(60, frames)) and host.seen() == list(range(frames))


def test_two_bodies_of_one_colour_at_rest_together_are_not_measured_as_one() -> None:
    # a small yellow circle rolls up to a large one and rests 0.4 m from it: two blobs on the detection grid, one
    # piece at full resolution; measured as either body, the pair reads as a small triangle
    bodies = [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
              make_static(0, "basket", (12.0, -1.2)),
              make_dynamic(0, "circle", "yellow", "large", (-10.0, 10.0)),
              make_dynamic(0, "circle", "yellow", "small", (0.0, 9.0))]
    world = WorldSpec(bodies=assign_uids(bodies), scene_id=None, seed=0)
    steps = 60
    pos = np.zeros((steps + 1, len(bodies), 2))
    for i, b in enumerate(world.bodies):
        pos[:, i] = b.position
    pos[:, 5, 0] = np.maximum(-6.6, -0.34 * np.arange(steps + 1))  # apart for 20 frames, then at rest beside it
    frames = render_frames(simulation_from_rows(world, pos, np.zeros((steps + 1, len(bodies)))))
    background = static_layer(WorldSpec(bodies=tuple(b for b in world.bodies if not b.dynamic)), 256)
    tracked = track(blobs(grid_labels(frames, background), grid_rims(background)), len(frames))
    assert sorted(len(o.seen()) for o in tracked) == [steps, steps]  # two blobs in every frame
    large = max(tracked, key=lambda o: o.blobs[0].area)  # type: ignore[union-attr]

    alone = _copies([large])[0]
    classify_shape(alone, frames, background)
    assert alone.best() != ("circle", "large")  # what happens without its twin: the pair measured as one body

    objects = _copies(tracked)
    pair_twins(objects)
    assert [len(o.twins) for o in objects] == [1, 1]
    paired = next(o for o in objects if o.blobs == large.blobs)
    classify_shape(paired, frames, background)
    assert paired.best() == ("circle", "large")
    resting = [k for k, m in paired.measurements.items() if k >= 25]
    assert resting and not any(paired.measurements[k].complete for k in resting)


def test_a_frame_is_fitted_once_per_shape_however_often_its_pose_is_asked_for(
        passing_bodies: tuple[np.ndarray, np.ndarray, list[TrackedObject]], monkeypatch: pytest.MonkeyPatch) -> None:
    """Render and compare fits each frame once per (shape, size): asking again for a shape tried before, or for a
    frame whose fit failed, gives what the first fit gave without fitting again."""
    import craft_dsl.reader.track as track_module

    frames, background, tracked = passing_bodies
    circle = _copies([min(tracked, key=lambda o: o.seen()[0] if o.seen() else 0)])[0]
    which = circle.seen_whole()[:6]
    measure_frames(circle, frames, background, which)
    fitted_frames: list[int] = []
    real_refine = track_module.refine

    def counting_refine(*args: Any, **kwargs: Any) -> Any:
        fitted_frames.extend(args[5])
        return real_refine(*args, **kwargs)

    monkeypatch.setattr(track_module, "refine", counting_refine)
    refine_frames(circle, frames, background, which, "circle", "large")
    first = dict(circle.poses)
    assert first and len(fitted_frames) == len(set(which) & set(circle.measurements))
    refine_frames(circle, frames, background, which, "cube", "large")  # another shape: its own fits
    assert circle.pose_shape == ("cube", "large")
    asked = len(fitted_frames)
    refine_frames(circle, frames, background, which, "circle", "large")  # back to the first: nothing fitted again
    refine_frames(circle, frames, background, which, "cube", "large")
    assert len(fitted_frames) == asked
    refine_frames(circle, frames, background, which, "circle", "large")
    assert circle.poses == first
