"""What a lossy re-encoding does to bodies, and how the reader copes: a body cut into pieces at its first sighting
is tracked as one body, a speck of a body's colour elsewhere does not make that body's blob a pair of touching
bodies, and a large triangle whose cut tip makes its features read small is read large."""

from __future__ import annotations

import math

import numpy as np
import pytest

from craft_dsl.reader.detect import Blob, blobs, grid_labels, grid_rims
from craft_dsl.reader.measure import Measurement
from craft_dsl.reader.track import (
    ERODED_ABOVE,
    SHAPE_FEATURES,
    TABLE_EROSION,
    TrackedObject,
    _log_likelihoods,
    classify_shape,
    compared_residuals,
    compression_depth,
    eroded,
    erosion,
    measure_frames,
    perimeter,
    track,
    verify_shape,
)
from craft_dsl.render import frames as render_frames
from craft_dsl.render.raster import static_layer
from craft_dsl.vocabulary import COLORS
from craft_dsl.world import WorldSpec, assign_uids, make_dynamic, make_static
from tests.synthetic_scene import simulation_from_rows


def _blob(frame: int, x: float, y: float, area: float, edge: bool = False) -> Blob:
    return Blob(frame, 1, area, x, y, edge)


def test_a_body_cut_at_the_frame_s_edge_is_one_body_and_the_other_body_is_tracked_from_the_start() -> None:
    # a large triangle entering at the top, its tip a separate 20-px piece for the first frames (as H.264 at crf 28
    # leaves it), and a large cube of the same colour elsewhere: both bodies are tracked from frame 0
    frames = 30
    found = []
    for k in range(frames):
        if k < 3:
            found.append(_blob(k, 76.5, 0.5, 20.0, edge=True))
        found += [_blob(k, 77.0, 9.5 + k, 168.0), _blob(k, 207.5 - k, 78.0, 352.0)]
    triangle, cube = sorted(track(found, frames, counts={1: 2}), key=lambda o: o.blobs[-1].x)  # type: ignore[union-attr]
    assert all(b is not None and b.area == 168.0 for b in triangle.blobs)
    assert all(b is not None and b.area == 352.0 for b in cube.blobs)


def test_a_piece_of_a_tracked_body_is_not_a_body_entering() -> None:
    # the eyes cut a large triangle in two for a few frames (44 px beside 144 px) before a second body of its colour
    # enters: the second track waits for that body instead of taking the piece
    frames = 40
    found = []
    for k in range(frames):
        found.append(_blob(k, 40.0, 62.0 + k, 144.0))
        if 1 <= k < 5:
            found.append(_blob(k, 40.5, 51.5 + k, 44.0))
        if k >= 20:
            found.append(_blob(k, 150.0, 0.5 + k, 56.0, edge=k < 24))
    body, entering = sorted(track(found, frames, counts={1: 2}), key=lambda o: o.blobs[-1].x)  # type: ignore[union-attr]
    assert all(b is not None and b.area == 144.0 for b in body.blobs)
    assert entering.seen() == list(range(20, frames))


def _sliding_body(shape: str, size: str, steps: int = 40) -> tuple[np.ndarray, np.ndarray, TrackedObject]:
    """A video of one red body sliding right, its background and its track."""
    bodies = [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
              make_static(0, "basket", (12.0, -1.2)),
              make_dynamic(0, shape, "red", size, (0.0, 0.0))]
    world = WorldSpec(bodies=assign_uids(bodies), scene_id=None, seed=0)
    pos = np.zeros((steps + 1, len(bodies), 2))
    for i, b in enumerate(world.bodies):
        pos[:, i] = (-8.0 + 0.1 * np.arange(steps + 1))[:, None] * [1.0, 0.0] + [0.0, 20.0] if b.dynamic \
            else b.position
    video = render_frames(simulation_from_rows(world, pos, np.zeros((steps + 1, len(bodies)))))
    background = static_layer(WorldSpec(bodies=tuple(b for b in world.bodies if not b.dynamic)), 256)
    (obj,) = track(blobs(grid_labels(video, background), grid_rims(background)), len(video))
    return video, background, obj


def test_a_large_triangle_whose_features_read_small_is_read_large_by_its_drawing() -> None:
    video, background, obj = _sliding_body("triangle", "large")
    classify_shape(obj, video, background)
    assert obj.best() == ("triangle", "large")
    measure_frames(obj, video, background, list(range(0, len(video), 4)))
    # the features of a lossy copy: the tip cut, the body a little smaller, read as a small triangle
    obj.shape_size = {key: 1e-6 for key in obj.shape_size}
    obj.shape_size[("triangle", "small")] = 1.0
    verify_shape(obj, video, background)
    assert obj.best() == ("triangle", "large")
    assert obj.shape_size[("triangle", "large")] > 0.99


def test_the_shape_check_draws_the_body_in_frames_spread_over_the_whole_run() -> None:
    # measured first in the start window only (as the reconstruction's first fit measures it), a small cube is still
    # checked in frames spread to the end of the run, where it is seen whole, and read a small cube
    video, background, obj = _sliding_body("cube", "small", steps=80)
    measure_frames(obj, video, background, list(range(6)))
    obj.shape_size = {key: 1e-6 for key in obj.shape_size}
    obj.shape_size[("circle", "small")] = 0.6
    obj.shape_size[("cube", "small")] = 0.4
    verify_shape(obj, video, background)
    assert max(obj.measurements) >= len(video) - 2  # the last frames were drawn too
    assert obj.best() == ("cube", "small")


def test_a_speck_counted_as_a_body_does_not_make_the_other_body_a_pair() -> None:
    # an MPEG-4 copy shows a 20-px speck of brown for a few frames, enough to count two brown bodies; the brown
    # body's own blob (about 208 px) is not "both bodies together", so its track keeps it in every frame
    frames = 40
    found = [_blob(k, 214.0 - k, 169.0, 208.0) for k in range(frames)]
    found += [_blob(k, 38.0, 206.0, 20.0) for k in range(8)]
    tracks = track(found, frames, counts={1: 2})
    body = max(tracks, key=lambda o: len(o.seen()))
    assert body.seen() == list(range(frames))
    assert all(b is not None and b.area == 208.0 for b in body.blobs)


def test_two_bodies_touching_make_one_blob_that_neither_track_takes() -> None:
    frames = 30
    found = []
    for k in range(frames):
        if 10 <= k < 20:
            found.append(_blob(k, 100.0, 100.0, 300.0))  # the two together
        else:
            found += [_blob(k, 90.0, 100.0, 150.0), _blob(k, 110.0, 100.0, 150.0)]
    for obj in track(found, frames, counts={1: 2}):
        assert obj.seen() == [*range(10), *range(20, frames)]


def test_shapes_are_compared_on_the_frames_every_drawing_could_be_fitted_in() -> None:
    inf = np.inf
    # the cube fits the first frame best; the triangle's larger window left the picture in the frames where the
    # cube, cut by compression, fits badly: over its own frames the cube's median would lose (30 against 20)
    per_frame = {("cube", "small"): np.array([10.0, 50.0, inf]), ("triangle", "small"): np.array([20.0, inf, inf]),
                 ("circle", "large"): np.array([inf, inf, inf])}
    residual = compared_residuals(per_frame)
    assert residual == {("cube", "small"): 10.0, ("triangle", "small"): 20.0, ("circle", "large"): inf}
    # no frame that holds them all: each over its own frames
    apart = compared_residuals({("cube", "small"): np.array([10.0, inf, 30.0]),
                                ("triangle", "small"): np.array([inf, 20.0, inf])})
    assert apart == {("cube", "small"): 20.0, ("triangle", "small"): 20.0}
    # another quantile of the common frames, and a candidate with no frames at all
    low = compared_residuals({("cube", "small"): np.array([10.0, 20.0, 30.0, 40.0, 90.0]),
                              ("triangle", "small"): np.array([12.0, 13.0, 14.0, 15.0, inf]),
                              ("circle", "small"): np.zeros(0)}, quantile=0.0)
    assert low == {("cube", "small"): 10.0, ("triangle", "small"): 12.0, ("circle", "small"): inf}


def test_perimeters_of_the_three_shapes() -> None:
    assert perimeter("circle", math.pi * 4.0) == pytest.approx(4.0 * math.pi)
    assert perimeter("cube", 49.0) == pytest.approx(28.0)
    assert perimeter("triangle", math.sqrt(3.0) / 4.0 * 36.0) == pytest.approx(18.0)


def test_an_eroded_table_loses_its_perimeter_times_the_depth_in_area_only() -> None:
    table = eroded(SHAPE_FEATURES, 0.2)
    for key, (centre, spread) in SHAPE_FEATURES.items():
        assert table[key][0][0] == pytest.approx(centre[0] - 0.2 * perimeter(key[0], centre[0]))
        assert table[key][0][1:] == centre[1:] and table[key][1] == spread
    assert eroded(SHAPE_FEATURES, 0.0) == SHAPE_FEATURES


def _measured(colour: str, key: tuple[str, str], areas: list[float]) -> TrackedObject:
    obj = TrackedObject(COLORS.index(colour), [None] * len(areas), shape_size={key: 1.0})
    obj.measurements = {k: Measurement(a, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, None, None, True) for k, a in enumerate(areas)}
    return obj


def test_erosion_is_measured_on_the_large_bodies_read_surely() -> None:
    circle_area = SHAPE_FEATURES[("circle", "large")][0][0]
    shortfall = 0.16 * perimeter("circle", circle_area)  # an H.264 copy at crf 28: 0.16 px
    large = _measured("green", ("circle", "large"), [circle_area - shortfall] * 5)
    small = _measured("yellow", ("cube", "small"), [40.0] * 5)  # small bodies do not measure it
    unsure = _measured("red", ("cube", "large"), [300.0] * 5)
    unsure.shape_size = {("cube", "large"): 0.6, ("triangle", "large"): 0.4}
    assert erosion([large, small, unsure]) == pytest.approx(0.16)
    assert compression_depth([large, small, unsure]) == pytest.approx(0.16 - TABLE_EROSION)
    assert erosion([small, unsure]) is None and compression_depth([small, unsure]) == 0.0
    as_drawn = _measured("green", ("circle", "large"), [circle_area - ERODED_ABOVE * perimeter("circle", circle_area)
                                                        + 1.0] * 5)
    assert compression_depth([as_drawn]) == 0.0  # within what the tables' own videos show


def test_a_small_cube_faded_by_h264_reads_as_a_cube_against_the_eroded_table() -> None:
    """A small cube measuring 48 px² (its drawing 56.5 less 0.16 px of its outline and some noise) in a video whose
    large bodies measure 0.16 px eroded, as on H.264 copies at crf 28: a small circle's area on the tables as
    calibrated, a cube's on the tables eroded by the difference."""
    features = np.array([[48.0, 0.66, 0.200]] * 12)
    plain = _log_likelihoods(features)
    worn = _log_likelihoods(features, eroded(SHAPE_FEATURES, 0.16 - TABLE_EROSION))
    assert plain[("circle", "small")] > plain[("cube", "small")]
    assert worn[("cube", "small")] > worn[("circle", "small")]
