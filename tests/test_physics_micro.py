"""Engine behaviour on hand-built micro-scenes (no scene sampler needed)."""

from __future__ import annotations

import numpy as np
import pytest

from craft_dsl.physics import simulate
from craft_dsl.physics.live import LiveSimulation
from craft_dsl.world import BodySpec, Point, WorldSpec, assign_uids, make_dynamic, make_static

BASKET_AT: Point = (15.0, -1.2)

#: Every engine-independent physics test runs on both engines.
ENGINES = ("pymunk", "box2d")
each_engine = pytest.mark.parametrize("engine", ENGINES)


def world(*dynamic: BodySpec, statics: tuple[BodySpec, ...] = (), basket: Point = BASKET_AT) -> WorldSpec:
    bodies = [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
              make_static(0, "basket", basket), *statics, *dynamic]
    return WorldSpec(assign_uids(bodies))


def kinds(sim: LiveSimulation, uid: int, other: int | None = None) -> list[tuple[str, int]]:
    return [(e.type, e.step) for e in sim.events
            if uid in e.objects and (other is None or other in e.objects)]


@each_engine
def test_fast_landing_bounces_as_a_collision_then_rests(engine: str) -> None:
    sim = simulate(world(make_dynamic(0, "circle", "red", "small", (-10.0, 15.0))), steps=300, engine=engine)
    ground = kinds(sim, 0, sim.ground_id)
    assert ground[0][0] == "Collision"  # ~17 m/s impact, restitution 0.2: it leaves the ground
    assert ground[-1][0] == "TouchStart"
    # the bounce happened: the body moved up after the first contact
    col = sim.traj.column(0)
    first = ground[0][1]
    assert sim.traj.velocities[first + 3, col, 1] > 1.0


@each_engine
def test_gentle_landing_is_a_touch_start_without_collision(engine: str) -> None:
    # 2 cm above the ground: approach speed far below 1 m/s, no restitution, no bounce
    sim = simulate(world(make_dynamic(0, "cube", "red", "small", (0.0, -4.8 + 1.0 + 0.04))), steps=120,
                   engine=engine)
    assert kinds(sim, 0) == [("TouchStart", 0)] or kinds(sim, 0)[0][0] == "TouchStart"
    assert not any(e.type == "Collision" for e in sim.events)


@each_engine
def test_body_at_rest_is_not_moving_and_asleep_at_the_end(engine: str) -> None:
    sim = simulate(world(make_dynamic(0, "cube", "red", "large", (0.0, 3.0)),
                         make_dynamic(0, "triangle", "blue", "small", (-12.0, 2.0))), steps=400, engine=engine)
    for uid in sim.dynamic_ids:
        obj = sim.object(uid)
        assert obj.end.velocity == (0.0, 0.0) and obj.end.angular_velocity == 0.0
        assert not obj.end.awake
        assert not obj.is_moving(-1)
        assert obj.is_moving(0) is False  # started at rest too
    assert sim.moving(-1) == frozenset()


@each_engine
def test_drop_into_basket_is_one_enter_basket(engine: str) -> None:
    sim = simulate(world(make_dynamic(0, "circle", "red", "small", (BASKET_AT[0], 12.0))), steps=300,
                   engine=engine)
    enters = [e for e in sim.events if e.type == "EnterBasket"]
    assert [(e.objects, len(enters)) for e in enters] == [((sim.basket_id, 0), 1)]
    assert not any(sim.ground_id in e.objects for e in sim.events)  # it stayed in the basket


@each_engine
def test_reentry_fires_twice_and_step_zero_overlap_fires_at_zero(engine: str) -> None:
    # floating basket; a ball starts inside the sensor and is thrown straight up, then falls back in
    basket = (0.0, 10.0)
    sim = simulate(world(make_dynamic(0, "circle", "red", "small", (0.0, 8.0), velocity=(0.0, 15.0)),
                         basket=basket), steps=240, engine=engine)
    enters = [e.step for e in sim.events if e.type == "EnterBasket"]
    assert len(enters) == 2 and enters[0] == 0 and enters[1] > 60


@each_engine
def test_fast_body_does_not_tunnel_through_a_basket_wall(engine: str) -> None:
    for speed in (40.0, 55.0):
        sim = simulate(world(make_dynamic(0, "circle", "red", "small", (BASKET_AT[0] - 12.0, 0.0),
                                          velocity=(speed, 0.0))), steps=60, engine=engine)
        assert not any(e.type == "EnterBasket" for e in sim.events), speed
        assert any(e.type == "Collision" and sim.basket_id in e.objects for e in sim.events)
        col = sim.traj.column(0)
        assert sim.traj.positions[-1, col, 0] < BASKET_AT[0] - 2.5


@each_engine
def test_initial_overlap_is_pushed_out_without_launching(engine: str) -> None:
    platform = make_static(0, "platform", (0.0, 10.0))  # top at 10.5
    sim = simulate(world(make_dynamic(0, "cube", "red", "small", (-5.0, 11.0)),   # 0.5 m inside
                         make_dynamic(0, "cube", "blue", "large", (0.0, 11.5)),   # 1 m inside
                         make_dynamic(0, "circle", "green", "large", (5.0, 11.5)),  # 1 m inside
                         statics=(platform,)), steps=120, engine=engine)
    tr = sim.traj
    speed = np.hypot(tr.velocities[..., 0], tr.velocities[..., 1])
    assert speed.max() < 0.05
    tops = {0: 10.5 + 2.0, 1: 10.5 + 2.0, 2: 10.5 + 1.0}
    for uid, top in tops.items():
        y = float(tr.positions[-1, tr.column(uid), 1])
        assert top - 0.01 < y < top + 0.03, (uid, y)
    assert all(e.type in ("Start", "End", "TouchStart") for e in sim.events)
