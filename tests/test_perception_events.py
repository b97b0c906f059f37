"""Events from tracks and geometry (measured against the simulator on exact tracks), and contact logs from perceived
events (the counterfactual base of the replay mode)."""

from __future__ import annotations

from collections import Counter

import pytest
from test_physics_micro import BASKET_AT, world

from craft_dsl.perception import ExecutionOptions, SceneModel, export_perceived
from craft_dsl.physics import events_from_log, simulate
from craft_dsl.physics.live import LiveSimulation
from craft_dsl.world import make_dynamic

Key = tuple[str, int, frozenset[int]]


def _keys(events: object) -> Counter[Key]:
    return Counter((e.type, e.step, frozenset(e.objects)) for e in events  # type: ignore[attr-defined]
                   if e.type not in ("Start", "End"))


#: The engine these precision tests run: the derivation's tolerance and the fit's sub-pixel drift were measured on
#: pymunk's runs (true circles, one contact); on Box2D's (the default), whose circles' contacts flicker, the
#: figures are in docs/perception.md.
PRECISION_ENGINE = "pymunk"


def _derived(sim: LiveSimulation) -> Counter[Key]:
    model = SceneModel(export_perceived(sim), ExecutionOptions(events="derived"))
    return _keys(events_from_log(model.derived_log))


def test_a_drop_bounce_and_roll_into_the_basket_is_derived_exactly() -> None:
    sim = simulate(world(make_dynamic(0, "circle", "red", "small", (-10.0, 15.0), velocity=(6.0, 0.0)),
                         make_dynamic(0, "cube", "blue", "large", (BASKET_AT[0], 8.0))), steps=240,
                   engine=PRECISION_ENGINE)
    truth = _keys(sim.events)
    assert {k[0] for k in truth} >= {"Collision", "EnterBasket"}
    assert _derived(sim) == truth


def test_derived_events_of_a_box2d_run_flicker_as_the_engine_s_contacts_do() -> None:
    """Box2D's circles' contacts with statics break and begin again as the original's 128-gons' do; the log derived
    from the tracks is split the same way, so a circle rolling on a platform collides with it as often in both
    (22 times here; 2 Collisions and one long touch for pymunk's true circle)."""
    sim = simulate(world(make_dynamic(0, "circle", "red", "small", (-10.0, 15.0), velocity=(6.0, 0.0)),
                         make_dynamic(0, "cube", "blue", "large", (BASKET_AT[0], 8.0))), steps=240, engine="box2d")
    model = SceneModel(export_perceived(sim), ExecutionOptions(events="derived"))

    def kinds(events: object) -> Counter[tuple[str, frozenset[int]]]:
        return Counter((e.type, frozenset(e.objects)) for e in events  # type: ignore[attr-defined]
                       if e.type not in ("Start", "End"))

    truth = kinds(sim.events)
    assert max(n for (kind, _), n in truth.items() if kind == "Collision") >= 10  # the flicker is there
    assert kinds(events_from_log(model.derived_log)) == truth


@pytest.mark.parametrize("scene, seed", [(3, 7), (13, 0)])
def test_derived_events_match_the_simulator_within_the_documented_tolerance(scene: int, seed: int) -> None:
    sim = simulate(scene, seed, engine=PRECISION_ENGINE)
    truth, derived = _keys(sim.events), _derived(sim)
    total = sum(truth.values())
    exact = truth & derived
    left = derived - exact
    near = 0
    for (kind, step, objs), n in (truth - exact).items():
        for shift in (-2, -1, 1, 2):
            k = (kind, step + shift, objs)
            take = min(n, left[k])
            near += take
            n -= take
            left[k] -= take
    assert sum(exact.values()) / total >= 0.85
    assert (sum(exact.values()) + near) / total >= 0.9
    assert sum(left.values()) / total <= 0.1  # spurious events
    enter = {k for k in truth if k[0] == "EnterBasket"}
    assert enter == {k for k in derived if k[0] == "EnterBasket"}


@pytest.mark.parametrize("scene, seed", [(3, 7), (9, 0)])
def test_perceived_events_imply_a_log_that_gives_them_back(scene: int, seed: int) -> None:
    sim = simulate(scene, seed, engine=PRECISION_ENGINE)
    model = SceneModel(export_perceived(sim))
    back = events_from_log(model.base_run.log)
    assert [(e.type, e.step, e.objects) for e in back] == [(e.type, e.step, e.objects) for e in sim.events]
    # a collision's duration is not an event: it comes from the geometry, within a frame of the simulator's
    for key, intervals in model.base_run.log.contacts.items():
        true = sim.raw.log.contacts[key]
        assert [s for s, _ in intervals] == [s for s, _ in true], key
        assert all(abs(e - f) <= 1 for (_, e), (_, f) in zip(intervals, true)), key


def test_a_pair_s_touching_parts_need_only_the_pair_placed_and_are_kept() -> None:
    """The pair geometry places only the pair's own bodies and keeps each (pair, frame) answer: every answer equals
    the one a probe with every body placed gives, asked in another order and asked again."""
    from craft_dsl.perception.events import GeometryProbe, _free_flight, _PairGeometry, _row

    sim = simulate(3, 7, engine=PRECISION_ENGINE)
    model = SceneModel(export_perceived(sim))
    world, states = model.physics.world, model.states
    geometry = _PairGeometry(world, states, 0.02)
    full = GeometryProbe(world, 0.02)
    columns = {b.uid: i for i, b in enumerate(world.bodies)}
    pairs = sorted({(e.objects[0], e.objects[1]) for e in sim.events if len(e.objects) == 2})
    assert pairs
    met = 0
    for frame in list(range(0, states.steps, 7)) + list(range(states.steps - 1, 0, -11)):
        for a, b in pairs:
            mover = a if a in full.plain_shapes else b
            expected: set[tuple[int, int, int, int]] = set()
            for pos, ang in (_row(states, frame + 1), _free_flight(states, frame, world.gravity)):
                full.place(pos, ang, columns)
                expected |= {k for k in full.touching([mover]) if {k[0], k[2]} == {a, b}}
            assert geometry.touching_parts(a, b, frame) == expected, (a, b, frame)
            met += bool(expected)
    assert met  # some pairs do touch in the frames asked
    assert geometry.touching_parts(*pairs[0], states.steps) == frozenset()
