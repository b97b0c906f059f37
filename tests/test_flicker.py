"""The contact flicker of the original's 128-gon circles, as added to Box2D runs' contact logs."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from test_physics_micro import world

from craft_dsl.physics import simulate
from craft_dsl.physics.box2d_engine import Box2DEngine
from craft_dsl.physics.engine import ContactLog
from craft_dsl.physics.flicker import FLICKER_STEP_METRES, MIN_PERIOD, MIN_SPEED, add_flicker
from craft_dsl.simulation import Trajectory
from craft_dsl.world import WorldSpec, make_dynamic


def _trajectory(speed: float, steps: int = 120) -> Trajectory:
    """Body 0 moving along x at ``speed`` m/s."""
    velocities = np.zeros((steps + 1, 1, 2))
    velocities[:, 0, 0] = speed
    zeros = np.zeros((steps + 1, 1))
    return Trajectory((0,), np.zeros((steps + 1, 1, 2)), zeros, velocities, zeros)


def _log(*keys: tuple[int, int, int, int], interval: tuple[int, int] = (10, 110)) -> ContactLog:
    return ContactLog(120, {key: (interval,) for key in keys})


def test_a_rolling_circles_contact_with_a_static_begins_again_every_few_centimetres() -> None:
    log = add_flicker(_log((5, 0, 0, 0)), _trajectory(2.0), circles=[0], statics=[5])
    pieces = log.contacts[(5, 0, 0, 0)]
    assert pieces[0][0] == 10 and pieces[-1][1] == 110
    lengths = [e - s for s, e in pieces]
    gaps = [b[0] - a[1] for a, b in zip(pieces, pieces[1:])]
    assert set(gaps) == {1}  # the manifold is found again one step later
    expected = FLICKER_STEP_METRES / (2.0 / 60.0)  # steps to roll that far
    assert all(abs(n - expected) <= 1 for n in lengths[:-1])
    assert all(n <= 20 for n in lengths)  # every piece is a Collision in the original's rules


def test_fast_circles_flicker_at_most_every_few_steps_and_slow_ones_not_at_all() -> None:
    fast = add_flicker(_log((5, 0, 0, 0)), _trajectory(30.0), circles=[0], statics=[5]).contacts[(5, 0, 0, 0)]
    assert min(e - s for s, e in fast[:-1]) >= MIN_PERIOD
    slow = add_flicker(_log((5, 0, 0, 0)), _trajectory(0.9 * MIN_SPEED), circles=[0], statics=[5])
    assert slow.contacts[(5, 0, 0, 0)] == ((10, 110),)


def test_only_contacts_of_circles_with_statics_flicker() -> None:
    log = _log((5, 0, 0, 0), (1, 0, 0, 0), (5, 0, 3, 0))  # circle-static, circle-dynamic, polygon-static
    out = add_flicker(log, _trajectory(2.0), circles=[0], statics=[5])
    assert len(out.contacts[(5, 0, 0, 0)]) > 1
    assert out.contacts[(1, 0, 0, 0)] == ((10, 110),) and out.contacts[(5, 0, 3, 0)] == ((10, 110),)
    assert add_flicker(log, _trajectory(2.0), circles=[], statics=[5]) is log


def _rolling_world(shape: str, speed: float) -> tuple[WorldSpec, int]:
    body = make_dynamic(0, shape, "red", "small", (-20.0, -3.79), (speed, 0.0))
    if shape == "circle":
        body = replace(body, angular_velocity=-speed)
    w = world(body)
    return w, w.dynamic_uids[0]


def test_a_circle_rolling_on_the_ground_collides_with_it_again_and_again() -> None:
    w, uid = _rolling_world("circle", 2.0)
    sim = simulate(w, steps=120, engine="box2d")
    ground = sim.ground_id
    hits = [e.step for e in sim.events if e.type == "Collision" and set(e.objects) == {uid, ground}]
    assert len(hits) >= 10 and max(np.diff(hits)) <= 10
    whole = simulate(w, steps=120, engine=Box2DEngine(flicker=False))
    assert not [e for e in whole.events if e.type == "Collision" and set(e.objects) == {uid, ground}]
    assert (sim.traj.positions == whole.traj.positions).all()  # the motion is the same: only the log differs
    w, uid = _rolling_world("cube", 2.0)
    slide = simulate(w, steps=120, engine="box2d")
    assert [e.type for e in slide.events if uid in slide.events[0].objects or uid in e.objects] == ["TouchStart"]


def test_counterfactuals_keep_the_factual_runs_flicker_for_unaffected_bodies() -> None:
    sim = simulate(3, seed=1, engine="box2d")
    factual = {(e.type, e.step, frozenset(e.objects)) for e in sim.events}
    for uid in sorted(sim.dynamic_ids):
        cf = sim.counterfactual(uid)
        affected = set(cf.activation) | {uid}
        kept = {(e.type, e.step, frozenset(e.objects)) for e in cf.events
                if e.objects and not affected & set(e.objects)}
        assert kept <= factual
