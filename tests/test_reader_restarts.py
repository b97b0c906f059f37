"""Restarts of straying bodies (re-anchoring) stay physical: no restart sinks a body into another one."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from craft_dsl.physics import simulate
from craft_dsl.physics.live import LiveSimulation, get_engine
from craft_dsl.reader import reconstruct as R
from craft_dsl.render.raster import world_to_pixel
from craft_dsl.simulation import Simulation
from craft_dsl.world import WorldSpec, assign_uids, make_dynamic, make_static

pytest.importorskip("Box2D", reason="needs the box2d extra (pip install -e '.[box2d]')")

FRAMES = 120


def _basket_world() -> WorldSpec:
    bodies = [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
              make_static(0, "basket", (0.0, -1.2)),
              make_dynamic(0, "cube", "red", "large", (0.0, 0.0))]
    return WorldSpec(bodies=assign_uids(bodies), scene_id=None, seed=0)


def _lowest(world: WorldSpec, uid: int) -> float:
    body = next(b for b in world.bodies if b.uid == uid)
    return min(y for poly in body.geometry.polygons for _x, y in poly) + body.position[1]


def test_overlaps_measures_how_deep_a_body_sinks_into_the_others() -> None:
    world = _basket_world()
    cube = next(b for b in world.bodies if b.dynamic)
    floor = -1.2 - 3.5  # the basket's floor
    resting = replace(world, bodies=tuple(
        replace(b, position=(0.0, floor - _lowest(world, b.uid) + b.position[1])) if b.dynamic else b
        for b in world.bodies))
    assert R.overlaps(resting, [cube.uid])[0] <= 0.021  # touching: the two 0.01 m skins
    sunk = replace(resting, bodies=tuple(
        replace(b, position=(b.position[0], b.position[1] - 0.3)) if b.dynamic else b for b in resting.bodies))
    assert R.overlaps(sunk, [cube.uid])[0] == pytest.approx(0.32, abs=0.02)
    high = replace(world, bodies=tuple(replace(b, position=(0.0, 20.0)) if b.dynamic else b for b in world.bodies))
    assert R.overlaps(high, [cube.uid])[0] == 0.0


def _ground_hits(sim: Simulation, uid: int) -> list[int]:
    return [e.step for e in sim.events if e.type == "Collision" and uid in e.objects and sim.ground_id in e.objects]


def _restart_on_a_bad_track(world: WorldSpec) -> tuple[LiveSimulation, LiveSimulation | None, int]:
    """A cube resting on the basket's floor, tracked 0.7 m too low from frame 80 on: the base run and its restart."""
    sim = simulate(world, engine="box2d", steps=FRAMES)
    uid = next(b.uid for b in world.bodies if b.dynamic)
    traj = sim.trajectory
    assert traj is not None
    col = traj.column(uid)
    rows = np.arange(1, FRAMES + 1)
    px, py = world_to_pixel(traj.positions[rows, col, 0], traj.positions[rows, col, 1], 256)
    observed = np.stack([px, py, np.zeros(FRAMES)], axis=1)
    observed[80:, 1] += 0.7 * 256 / 50
    fit = SimpleNamespace(rows=rows, observed={0: observed}, uids=[uid], attributes=[("cube", "red", "large")],
                          size=256)
    return sim, R.reanchor(sim, fit, FRAMES, 86, get_engine("box2d"), None), uid  # type: ignore[arg-type]


def test_a_restart_does_not_sink_a_resting_body_into_the_basket_floor_to_follow_a_bad_track() -> None:
    """The basket's floor is 0.1 m above the ground: a restart that followed the bad track into the floor would
    make the cube hit the ground below it, a collision the video never showed."""
    sim, restarted, uid = _restart_on_a_bad_track(_basket_world())
    assert not _ground_hits(sim, uid)
    if restarted is not None:  # a restart, if any, keeps the cube out of the floor
        start = 86 - R.ANCHOR_BACK
        assert restarted.trajectory is not None
        there = R._state_world(_basket_world(), restarted.trajectory, start, {})
        assert R.overlaps(there, [uid])[0] <= R.OVERLAP_SLACK + 0.01
        assert not _ground_hits(restarted, uid)


def test_without_the_overlap_allowance_the_restart_sinks_the_body_and_it_hits_the_ground(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """What the overlap allowance prevents (the test above would fail without it)."""
    monkeypatch.setattr(R, "OVERLAP_SLACK", 10.0)  # any overlap allowed
    _sim, restarted, uid = _restart_on_a_bad_track(_basket_world())
    assert restarted is not None and _ground_hits(restarted, uid)


def _empty_world(x: float, vx: float = 0.0) -> WorldSpec:
    body = replace(make_dynamic(0, "cube", "red", "large", (x, 30.0)), velocity=(vx, 0.0))
    bodies = [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
              make_static(0, "basket", (-18.0, -1.2)), body]
    return WorldSpec(bodies=assign_uids(bodies), scene_id=None, seed=0)


def _restart_far_from_the_track() -> tuple[LiveSimulation | None, SimpleNamespace, int]:
    """A falling cube whose run is 4 m (20 px) left of its track and slower by 3 m/s: the restart at frame 30."""
    sim = simulate(_empty_world(0.0), engine="box2d", steps=FRAMES)
    truth = simulate(_empty_world(4.0, 3.0), engine="box2d", steps=FRAMES)
    uid = next(b.uid for b in _empty_world(0.0).bodies if b.dynamic)
    traj = truth.trajectory
    assert traj is not None
    col = traj.column(uid)
    rows = np.arange(1, FRAMES + 1)
    px, py = world_to_pixel(traj.positions[rows, col, 0], traj.positions[rows, col, 1], 256)
    fit = SimpleNamespace(rows=rows, observed={0: np.stack([px, py, np.zeros(FRAMES)], axis=1)}, uids=[uid],
                          attributes=[("cube", "red", "large")], size=256)
    restarted = R.reanchor(sim, fit, FRAMES, 36, get_engine("box2d"), None)  # type: ignore[arg-type]
    return restarted, fit, uid


def test_a_restart_far_from_the_track_starts_where_the_frames_show_the_body() -> None:
    """The fit's steps could not cross 20 px in its iterations; started from the line through the first frames of
    its window (position and velocity), the restarted run follows the track to the end."""
    restarted, fit, _uid = _restart_far_from_the_track()
    assert restarted is not None
    worst, first = R.stray(restarted, fit, FRAMES, start=36)  # type: ignore[arg-type]
    assert not first and max(worst.values()) > 20  # before the restart the run was 20+ px off


def test_without_the_guess_the_restart_cannot_catch_up(monkeypatch: pytest.MonkeyPatch) -> None:
    """What the guess adds (the test above would fail without it)."""
    monkeypatch.setattr(R, "GUESS_PX", float("inf"))
    restarted, fit, _uid = _restart_far_from_the_track()
    if restarted is not None:
        _worst, first = R.stray(restarted, fit, FRAMES, start=36)  # type: ignore[arg-type]
        assert first
