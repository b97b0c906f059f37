"""Clean counterfactuals: unaffected bodies keep their factual events and trajectories exactly."""

from __future__ import annotations

import numpy as np
import pytest
from test_physics_micro import each_engine, world

from craft_dsl.errors import CounterfactualUnavailable
from craft_dsl.physics import simulate
from craft_dsl.physics.live import LiveSimulation
from craft_dsl.simulation import Simulation
from craft_dsl.world import make_dynamic, make_static

EventTuple = tuple[str, int, tuple[int, ...]]


def events_of(sim: Simulation, uid: int) -> list[EventTuple]:
    return [(e.type, e.step, e.objects) for e in sim.events if uid in e.objects]


def assert_clean(factual: LiveSimulation, removed: int) -> LiveSimulation:
    cf = factual.counterfactual(removed)
    assert isinstance(cf, LiveSimulation)
    assert not cf.has_object(removed) and cf.removed == factual.removed + (removed,)
    assert removed not in cf.affected
    f_tr, c_tr = factual.trajectory, cf.trajectory
    assert f_tr is not None and c_tr is not None
    for obj in cf.objects:
        if obj.id in cf.affected:
            assert obj.dynamic
            continue
        assert events_of(cf, obj.id) == [
            e for e in events_of(factual, obj.id) if removed not in e[2]
        ] or not obj.dynamic, (removed, obj.id)
        if obj.dynamic:
            assert events_of(cf, obj.id) == events_of(factual, obj.id), (removed, obj.id)
            a, b = f_tr.column(obj.id), c_tr.column(obj.id)
            for name in ("positions", "angles", "velocities", "angular_velocities"):
                assert np.array_equal(getattr(f_tr, name)[:, a], getattr(c_tr, name)[:, b]), (name, obj.id)
            assert obj.end == factual.object(obj.id).end
    # events between two unaffected bodies (statics included) are exactly the factual ones
    kept = set(cf.all_ids) - cf.affected
    pair_events = [(e.type, e.step, e.objects) for e in cf.events if e.objects and set(e.objects) <= kept]
    assert pair_events == [(e.type, e.step, e.objects) for e in factual.events
                           if e.objects and set(e.objects) <= kept]
    return cf


@each_engine
@pytest.mark.parametrize("scene", range(1, 21))
def test_every_removal_is_clean(scene: int, engine: str) -> None:
    for seed in (0, 1, 2):
        sim = simulate(scene, seed=seed, engine=engine)
        for uid in sorted(sim.dynamic_ids):
            cf = assert_clean(sim, uid)
            # the affected set is closed: every affected body was reached through contacts from `uid`
            assert all(0 <= a < sim.steps for a in cf.activation.values())


@each_engine
def test_counterfactual_is_deterministic_and_nested_counterfactuals_are_clean(engine: str) -> None:
    sim = simulate(18, seed=4, engine=engine)
    again = simulate(18, seed=4, engine=engine)
    for uid in sorted(sim.dynamic_ids):
        a, b = sim.counterfactual(uid), again.counterfactual(uid)
        assert a.events == b.events and a.activation == b.activation
        assert a.trajectory is not None and b.trajectory is not None
        assert np.array_equal(a.trajectory.positions, b.trajectory.positions)
        assert sim.counterfactual(uid) is a  # cached
    first = sorted(sim.dynamic_ids)[0]
    cf = sim.counterfactual(first)
    assert isinstance(cf, LiveSimulation)
    for uid in sorted(cf.dynamic_ids):
        nested = assert_clean(cf, uid)
        assert nested.removed == (first, uid)


@each_engine
def test_removing_an_untouched_object_changes_only_its_own_events(engine: str) -> None:
    # A small cube rests on a large cube; a circle far away falls on the ground by itself.
    sim = simulate(world(make_dynamic(0, "cube", "red", "large", (0.0, -2.8 + 0.02)),
                         make_dynamic(0, "cube", "blue", "small", (0.0, 3.0)),
                         make_dynamic(0, "circle", "green", "small", (-15.0, 6.0))), steps=300, engine=engine)
    loner = 0  # the circle, created last
    cf = sim.counterfactual(loner)
    assert cf.affected == frozenset()
    assert [(e.type, e.step, e.objects) for e in cf.events] == [
        (e.type, e.step, e.objects) for e in sim.events if loner not in e.objects
    ]


@each_engine
def test_removing_a_support_lets_the_body_above_fall_to_the_ground(engine: str) -> None:
    sim = simulate(world(make_dynamic(0, "cube", "red", "large", (0.0, -2.8 + 0.02)),
                         make_dynamic(0, "cube", "blue", "small", (0.0, 3.0)),
                         make_dynamic(0, "circle", "green", "small", (-15.0, 6.0))), steps=300, engine=engine)
    support, top, loner = 2, 1, 0
    assert not any(sim.ground_id in e.objects for e in sim.events if top in e.objects)
    cf = assert_clean(sim, support)
    assert cf.affected == frozenset({top})
    assert any(sim.ground_id in e.objects and top in e.objects for e in cf.events)
    assert events_of(cf, loner) == events_of(sim, loner)
    assert cf.object(top).end.position[1] < sim.object(top).end.position[1] - 3.0


@each_engine
def test_ground_and_basket_cannot_be_removed_but_a_platform_can(engine: str) -> None:
    platform = make_static(0, "platform", (0.0, 5.0))
    sim = simulate(world(make_dynamic(0, "cube", "red", "small", (0.0, 8.0)), statics=(platform,)), steps=200,
                   engine=engine)
    with pytest.raises(CounterfactualUnavailable):
        sim.counterfactual(sim.ground_id)
    with pytest.raises(CounterfactualUnavailable):
        sim.counterfactual(sim.basket_id)
    platform_id = next(o.id for o in sim.objects if o.shape == "platform")
    cf = sim.counterfactual(platform_id)
    assert any(sim.ground_id in e.objects for e in cf.events)
