"""What the reader learns from a video's look: aliased edges (the original CRAFT renderer) and the order in which
bodies falling in from above the picture enter it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from craft_dsl.reader.detect import WHITE, Blob, chroma, lookup
from craft_dsl.reader.layout import (
    ALIASED_EDGE_SHARE,
    ALIASED_OFFSET_M,
    STATIC_CHROMA,
    edge_share,
    fit_layout,
    observation,
)
from craft_dsl.reader.layout_model import layout_model
from craft_dsl.reader.reconstruct import assign_slots, first_sighting, first_window
from craft_dsl.reader.track import TrackedObject
from craft_dsl.render.raster import static_layer, world_to_pixel
from craft_dsl.scenes import sample_world
from craft_dsl.world import WorldSpec


def _background(aliased: bool) -> np.ndarray:
    image = static_layer(sample_world(12, seed=3))
    if aliased:  # every pixel dark or white, as a renderer without antialiasing draws the statics
        image = np.repeat(np.where(image.mean(axis=2, keepdims=True) < 128, 0, 255), 3, axis=2).astype(np.uint8)
    return image


@pytest.mark.parametrize("aliased", [False, True])
def test_edges_read_as_aliased_only_where_they_are(aliased: bool) -> None:
    share = edge_share(*observation(_background(aliased)))
    assert (share < ALIASED_EDGE_SHARE) is aliased


def test_a_picture_without_statics_is_not_aliased() -> None:
    white = np.full((64, 64, 3), 255, dtype=np.uint8)
    assert edge_share(*observation(white)) == 1.0


def _falling_in(frame: int, x_m: float, y_m: float, shape_size: tuple[str, str], frames: int = 200) -> TrackedObject:
    x, y = world_to_pixel(x_m, y_m)
    blobs: list[Blob | None] = [None] * frames
    for k in range(frame, frames):
        blobs[k] = Blob(k, 0, 60.0, float(x), float(y), False)
    return TrackedObject(0, blobs, {shape_size: 1.0})


@pytest.mark.parametrize("order", [(0, 1), (1, 0)])
def test_bodies_falling_in_take_the_slots_in_the_order_they_enter(order: tuple[int, int]) -> None:
    # scene 12: slot 2 starts at 49.5 m, slot 1 at 56.5 m, both above the picture (top at 45 m) and over the same
    # x range; dropped from rest, the lower one is seen first (a held-out original video had the two swapped:
    # by x alone, the slots tie)
    model = layout_model(12)
    values = model.from_unit({d.path: 0.5 for d in model.draws})
    early = _falling_in(50, -2.35, 49.5 - 7.5 * (51 / 60) ** 2, ("triangle", "small"))
    late = _falling_in(80, -1.98, 56.5 - 7.5 * (81 / 60) ** 2, ("circle", "large"))
    objects = [(early, late)[i] for i in order]
    slots = dict(zip([id(o) for o in objects], assign_slots(model, values, objects)))
    assert (slots[id(early)], slots[id(late)]) == (2, 1)


def test_the_first_fit_sees_a_late_body_for_a_while() -> None:
    rows = np.arange(1, 601)
    seen_late = np.full((600, 3), np.nan)
    seen_late[90:] = 1.0
    seen_early = np.zeros((600, 3))
    assert first_window({0: seen_early}, rows) == 40
    assert first_window({0: seen_early, 1: seen_late}, rows) == 110
    assert first_window({1: np.full((600, 3), np.nan)}, rows) == 40  # never seen: nothing to wait for


def test_a_ghost_away_from_the_statics_does_not_make_aliased_edges_antialiased() -> None:
    # a body resting for part of a video leaves a washed-out ghost (mid greys) in the median background; only the
    # pixels near the fitted statics tell how their edges are drawn
    background = _background(aliased=True)
    yy, xx = np.mgrid[: background.shape[0], : background.shape[1]]
    ghost = (yy - 40) ** 2 + (xx - 200) ** 2 < 12**2
    assert not (background[ghost] < 250).any()  # the ghost lies away from every static
    background[ghost] = 170
    assert edge_share(*observation(background)) > ALIASED_EDGE_SHARE  # over the whole picture it would read antialiased
    fit = fit_layout(np.repeat(background[None], 8, axis=0), scene=12)
    assert fit.aliased


def test_a_body_first_seen_late_leaves_the_slot_of_one_seen_there_from_the_start() -> None:
    # scene 2 (a held-out H.264 copy): a small circle seen from the first frame in slot 8's start range, and a
    # small circle whose colour was not read for 170 frames, first seen inside the same x range; by distance alone
    # the late one took slot 8 and pushed the early one 29 m away to slot 6
    model = layout_model(2)
    values = model.from_unit({d.path: 0.5 for d in model.draws})

    def seen_from(frame: int, x_m: float, y_m: float, shape_size: tuple[str, str]) -> TrackedObject:
        x, y = world_to_pixel(x_m, y_m)
        blobs: list[Blob | None] = [None] * frame + [Blob(k, 0, 60.0, float(x), float(y), False)
                                                     for k in range(frame, 600)]
        return TrackedObject(0, blobs, {shape_size: 1.0})

    early = seen_from(0, -4.06, 8.0, ("circle", "small"))
    late = seen_from(170, -8.5, 6.0, ("circle", "small"))
    others = [seen_from(0, -22.0, 33.96, ("circle", "large")), seen_from(0, 22.0, 8.0, ("circle", "large"))]
    slots = assign_slots(model, values, [early, late, *others])
    assert slots[2:] == [7, 9]
    assert (slots[0], slots[1]) == (8, 6)


def test_a_washed_out_body_in_the_median_background_does_not_count_as_static() -> None:
    # a body resting for most of a lossy copy, washed pale in the median: no body colour reads it, its chroma does
    background = _background(aliased=False).copy()
    pale = np.array([250, 238, 150], dtype=np.uint8)
    label = lookup(pale[None, None])[0, 0]
    assert label < 0 or label >= WHITE
    assert chroma(pale) > STATIC_CHROMA
    background[200:210, 20:30] = pale
    _lum, weight = observation(background)
    assert not weight[200:210, 20:30].any()
    assert float(np.max(chroma(_background(aliased=False)))) < STATIC_CHROMA  # the statics themselves are grey


def _sighted(x_m: float, y_m: float, shape_size: dict[tuple[str, str], float], first: int = 0,
             frames: int = 60) -> TrackedObject:
    x, y = world_to_pixel(x_m, y_m)
    blobs: list[Blob | None] = [None] * first + [Blob(k, 0, 60.0, float(x), float(y), False)
                                                 for k in range(first, frames)]
    return TrackedObject(0, blobs, dict(shape_size))


_STACK = [(3.0, 20.0), (5.2, 20.0), (7.4, 20.0), (4.0, 22.0), (6.2, 22.0), (5.0, 24.0)]  # scene 2's six cubes
_CIRCLES = [(22.0, 20.0), (-22.0, 30.0), (-8.0, 8.0), (22.0, 8.0)]  # its four circles' starts (slots 6-9)
_CUBE = {("cube", "small"): 1.0}
_CIRCLE = {("circle", "small"): 1.0}


def test_a_stacked_cube_read_late_or_off_in_its_first_frame_keeps_its_slot() -> None:
    # scene 2 (an original-sampled video): specks of the other cubes' outlines joined the gray cube's piece in the
    # first frame (its centroid 8 px, 1.6 m, above it), and the cube above it was first read in the fourth frame; by
    # the first sighting alone and x alone the two took each other's slots
    model = layout_model(2)
    values = model.from_unit({d.path: 0.5 for d in model.draws})
    objects = [_sighted(x, y, _CUBE, first=3 if slot == 4 else 0) for slot, (x, y) in enumerate(_STACK)]
    objects += [_sighted(x, y, _CIRCLE) for x, y in _CIRCLES]
    gray = objects[1].blobs[0]
    assert gray is not None
    objects[1].blobs[0] = Blob(0, 0, 60.0, gray.x, gray.y - 8.0, False)
    assert assign_slots(model, values, objects) == list(range(10))


def test_a_stacked_cube_read_as_a_circle_stays_in_the_stack() -> None:
    # scene 2: a small red cube among touching cubes read as a circle with probability 1.0 (and first seen in the
    # second frame), and a small circle read as a cube (0.865): the cube took the circle's slot 16 m away
    model = layout_model(2)
    values = model.from_unit({d.path: 0.5 for d in model.draws})
    objects = [_sighted(x, y, {("circle", "small"): 1.0 - 1e-9, ("cube", "small"): 1e-9} if slot == 3 else _CUBE,
                        first=1 if slot == 3 else 0) for slot, (x, y) in enumerate(_STACK)]
    objects += [_sighted(x, y, {("cube", "small"): 0.865, ("circle", "small"): 0.135} if slot == 8 else _CIRCLE)
                for slot, (x, y) in enumerate(_CIRCLES, 6)]
    assert assign_slots(model, values, objects) == list(range(10))


def test_the_first_sighting_is_read_on_a_line_that_one_stray_sighting_does_not_move() -> None:
    rows = np.arange(1, 61)
    moving = TrackedObject(0, [None, None] + [Blob(k, 0, 60.0, 100.0 + 2.0 * k, 50.0, False) for k in range(2, 60)],
                           {})
    first = moving.blobs[2]
    assert first is not None
    moving.blobs[2] = Blob(2, 0, 60.0, first.x, first.y + 9.0, False)  # a speck joined in its first sighting
    x, y = first_sighting(moving, rows) or (0.0, 0.0)
    assert abs(x - 104.0) < 1e-6 and abs(y - 50.0) < 1e-6
    x, y = first_sighting(moving, rows, step=1) or (0.0, 0.0)  # carried back to the first frame's step
    assert abs(x - 100.0) < 1e-6
    few = TrackedObject(0, [Blob(0, 0, 60.0, 7.0, 8.0, False)] + [None] * 59, {})
    assert first_sighting(few, rows) == (7.0, 8.0)
    assert first_sighting(TrackedObject(0, [None] * 60, {}), rows) is None


# -- the original renderer's offset -------------------------------------------------------------------------------

_OFFSET = (0.023, -0.072)


def _translated(world: WorldSpec, d: tuple[float, float]) -> WorldSpec:
    return replace(world, bodies=tuple(replace(b, position=(b.position[0] + d[0], b.position[1] + d[1]))
                                       for b in world.bodies))


# scene -> the draws that are places along an axis (a picture drawn with an offset shows them moved by it)
_PLACE_DRAWS = {
    2: {"basket.position[0]": 0, "static[4].position[1]": 1, "static[5].position[1]": 1,
        "dynamic[7].position[1]": 1, "dynamic[8].position[0]": 0},
    4: {"variables.h1": 1, "variables.h2": 1, "variables.h3": 1, "variables.h4": 1, "dynamic[0].position[0]": 0,
        "dynamic[1].position[0]": 0, "dynamic[2].position[0]": 0},
    18: {"basket.position[0]": 0, "static[0].position[0]": 0, "static[0].position[1]": 1, "static[1].position[0]": 0,
         "static[1].position[1]": 1, "static[2].position[1]": 1, "dynamic[0].position[0]": 0,
         "dynamic[1].position[0]": 0, "dynamic[3].position[1]": 1},
}


@pytest.mark.parametrize("scene", sorted(_PLACE_DRAWS))
def test_a_world_drawn_with_an_offset_reads_as_the_same_world_moved(scene: int) -> None:
    # the draws fitted to a picture drawn with an offset carry it; the model moves what no draw moves (walls,
    # ground, constant places) by it too, so the world is the true one moved whole, which runs the same physics
    model = layout_model(scene)
    shifted = layout_model(scene, (), _OFFSET)
    values = model.from_unit({d.path: 0.3 for d in model.draws})
    attributes = [(s.shape if s.shape != "random" else "cube", s.color if s.color != "random" else "red",
                   s.size if s.size != "random" else "small") for s in model.layout.dynamic]
    seen = dict(values)
    for path, axis in _PLACE_DRAWS[scene].items():
        seen[path] = values[path] + _OFFSET[axis]
    expected = _translated(model.world(values, attributes), _OFFSET)
    got = shifted.world(seen, attributes)
    assert [b.uid for b in got.bodies] == [b.uid for b in expected.bodies]
    for a, b in zip(got.bodies, expected.bodies):
        assert a.position == pytest.approx(b.position, abs=1e-9), (a.shape, a.uid)
        assert (a.angle, a.velocity, a.shape) == (b.angle, b.velocity, b.shape)


def test_only_places_no_draw_moves_are_fixed() -> None:
    fixed = dict(layout_model(1).fixed_positions)
    assert fixed["basket.position[1]"] == 1 and "basket.position[0]" not in fixed  # the basket's x is drawn
    assert "static[0].position[0]" not in fixed and "static[2].position[0]" in fixed
    fixed_15 = dict(layout_model(15).fixed_positions)  # expressions of draws (bx, yr) and of constants alone
    assert "static[0].position[0]" not in fixed_15 and "static[1].position[1]" not in fixed_15
    assert "static[3].position[0]" in fixed_15
    assert layout_model(1, (), _OFFSET).fixed_start(2, {}) == pytest.approx(
        tuple(a + b for a, b in zip(layout_model(1).fixed_start(2, {}) or (), _OFFSET)))


@pytest.mark.parametrize("aliased", [False, True])
def test_only_the_original_look_carries_the_renderers_offset(aliased: bool) -> None:
    fit = fit_layout(np.repeat(_background(aliased)[None], 8, axis=0), scene=12)
    assert fit.aliased is aliased
    assert fit.offset == (ALIASED_OFFSET_M if aliased else (0.0, 0.0))
