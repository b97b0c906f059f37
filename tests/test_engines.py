"""The Box2D engine's specifics, engine selection, and the engine comparison (``engines compare``)."""

from __future__ import annotations

import math
import sys

import pytest
from test_physics_micro import BASKET_AT, world

from craft_dsl.analysis.engines import (
    CATEGORIES,
    EVENT_STEP_TOLERANCE,
    compare_engines,
    format_comparison,
    match_events,
    merge_stats,
    same_answer,
    wilson_halfwidth,
)
from craft_dsl.analysis.scene_stats import scene_stats
from craft_dsl.cli import main
from craft_dsl.physics import get_engine, simulate
from craft_dsl.physics.box2d_engine import Box2DEngine
from craft_dsl.physics.recording import FrameIntervalRecorder as _IntervalRecorder
from craft_dsl.templates import templates
from craft_dsl.types import INVALID
from craft_dsl.world import WorldSpec, make_dynamic

# -- the Box2D engine ----------------------------------------------------------------------------------


def test_pybox2d_is_built_with_the_original_settings() -> None:
    import Box2D

    assert Box2D.b2_linearSlop == pytest.approx(0.005)
    assert Box2D.b2_polygonRadius == pytest.approx(0.01)
    assert Box2D.b2_velocityThreshold == pytest.approx(1.0)
    assert Box2D.b2_timeToSleep == pytest.approx(0.5)
    assert Box2D.b2_linearSleepTolerance == pytest.approx(0.01)
    assert Box2D.b2_angularSleepTolerance == pytest.approx(2 * math.pi / 180)
    assert Box2D.b2_maxTranslation == pytest.approx(2.0)
    eng = Box2DEngine()
    assert (eng.velocity_iterations, eng.position_iterations) == (8, 3)
    b2w, bodies = eng.build_world(simulate(3, seed=0, steps=1, engine="box2d").world_spec)
    assert b2w.warmStarting and b2w.continuousPhysics and not b2w.subStepping and b2w.allowSleeping
    for body in bodies.values():
        for fixture in body.fixtures:
            if not fixture.sensor:
                assert (fixture.friction, fixture.restitution) == (pytest.approx(0.1), pytest.approx(0.2))
                assert fixture.density == 50.0


def test_engine_selection_and_names() -> None:
    assert get_engine("box2d").name == "box2d" and get_engine("pymunk").name == "pymunk"
    eng = Box2DEngine()
    assert get_engine(eng) is eng
    sim = simulate(3, seed=1, steps=30, engine=eng)
    assert sim.engine is eng and sim.meta["engine"] == "box2d"
    assert sim.world == simulate(3, seed=1, steps=30).world  # the sampler does not know the engine


def test_missing_box2d_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "Box2D", None)  # makes `import Box2D` fail
    monkeypatch.delitem(sys.modules, "craft_dsl.physics.box2d_engine")
    with pytest.raises(ModuleNotFoundError, match=r"pip install 'craft-dsl\[box2d\]'"):
        get_engine("box2d")
    assert get_engine("pymunk").name == "pymunk"  # the core works without the extra


def test_recorder_keeps_a_contact_that_begins_and_ends_within_one_step() -> None:
    rec = _IntervalRecorder()
    rec.begin("a", 10)
    rec.end("a", 10)  # a TOI touch: began and ended during step 10
    rec.begin("b", 5)
    rec.end("b", 9)
    rec.begin("b", 9)  # ended and began again at the same counter: a new contact, as in the original
    rec.begin("c", 50)
    assert rec.result(60) == {"a": ((10, 11),), "b": ((5, 9), (9, 60)), "c": ((50, 60),)}


def test_basket_edges_are_separate_parts_of_the_contact_log() -> None:
    # a large circle dropped into the basket near its floor's right corner touches the floor and a wall
    sim = simulate(world(make_dynamic(0, "circle", "red", "large", (BASKET_AT[0] + 1.0, 6.0))), steps=240,
                   engine="box2d")
    parts = {key[1] for key in sim.raw.log.contacts if key[0] == sim.basket_id}
    assert 1 in parts and len(parts) >= 2 and parts <= {0, 1, 2}
    assert len({e.id for e in sim.events if e.type in ("Collision", "TouchStart") and sim.basket_id in e.objects}) >= 2
    assert [e.objects for e in sim.events if e.type == "EnterBasket"] == [(sim.basket_id, 0)]


def test_sleeping_bodies_report_zero_velocity_and_stay_asleep() -> None:
    sim = simulate(world(make_dynamic(0, "cube", "red", "small", (0.0, -2.0))), steps=200, engine="box2d")
    col = sim.traj.column(0)
    asleep = ~sim.raw.awake[:, col]
    assert asleep[-1] and asleep.sum() > 50
    first = int(asleep.argmax())
    assert (sim.traj.velocities[first:, col] == 0).all() and (sim.traj.angular_velocities[first:, col] == 0).all()


@pytest.mark.parametrize(("scene", "seed"), [(1, 0), (3, 1)])  # scene 3: circles rolling on platforms
def test_replayed_bodies_follow_the_base_rows_exactly(scene: int, seed: int) -> None:
    sim = simulate(scene, seed=seed, engine="box2d")
    for uid in sorted(sim.dynamic_ids):
        cf = sim.counterfactual(uid)
        for other in cf.dynamic_ids:
            a = cf.activation.get(other, sim.steps)
            i, j = sim.traj.column(other), cf.traj.column(other)
            assert (sim.traj.positions[: a + 1, i] == cf.traj.positions[: a + 1, j]).all()


def test_box2d_and_pymunk_agree_on_simple_physics() -> None:
    # a ball dropped into the basket: same events (up to a frame of timing) on both engines
    drop = world(make_dynamic(0, "circle", "red", "small", (BASKET_AT[0], 12.0)))
    a, b = simulate(drop, steps=300, engine="pymunk"), simulate(drop, steps=300, engine="box2d")
    enter_a = [e.step for e in a.events if e.type == "EnterBasket"]
    enter_b = [e.step for e in b.events if e.type == "EnterBasket"]
    assert len(enter_a) == len(enter_b) == 1 and abs(enter_a[0] - enter_b[0]) <= 1
    ya, yb = a.object(0).end.position[1], b.object(0).end.position[1]
    assert ya == pytest.approx(yb, abs=0.03)


# -- the comparison ------------------------------------------------------------------------------------


def test_compare_on_a_tiny_run() -> None:
    cmp = compare_engines([3], range(2))
    assert cmp.reference == "pymunk" and cmp.runs == ("box2d",)
    assert len(cmp.templates) == 67 and sum(t.paper for t in cmp.templates) == 48
    assert 0.0 <= cmp.agreement() <= 1.0
    for row in cmp.templates:
        assert 0 <= row.agree[0] <= row.questions <= 2 and row.invalid[0] <= row.questions - row.agree[0]
        assert (row.questions == 0) == (row.majority == 0) and row.majority <= row.questions
        assert row.category in CATEGORIES
    cats = cmp.categories()
    assert [c.category for c in cats] == [*CATEGORIES, "all"]
    assert cats[-1].questions == sum(c.questions for c in cats[:-1]) > 0
    assert all(0.0 <= c.rate() <= 1.0 for c in cats if c.questions)
    paper = cmp.paper_categories()
    assert [c.category for c in paper][:3] == ["C", "CF", "D"] and paper[-1].category == "all"
    assert paper[-1].questions == sum(c.questions for c in paper[:3]) == sum(c.questions for c in paper[3:-1])
    (sa, sb), = cmp.scene_rows()
    assert (sa.runs, sb.runs) == (2, 2) and sa.dynamic_objects == sb.dynamic_objects == 3.0
    text = format_comparison(cmp, markdown=True)
    assert sum(1 for line in text.splitlines() if line.startswith("| descriptive_")) == 40
    assert sum(1 for line in text.splitlines() if line.startswith(("| counterfactual_", "| cause_", "| enable_",
                                                                    "| prevent_", "| descriptive_"))) == 67


def test_an_engine_compared_with_itself_agrees_everywhere() -> None:
    cmp = compare_engines([3], [0], engines=("box2d", "box2d"))
    assert cmp.agreement() == 1.0
    assert all(t.rate() == 1.0 for t in cmp.templates if t.questions)
    assert all(t.invalid == (0,) for t in cmp.templates)
    (sa, sb), = cmp.scene_rows()
    assert (sa.basket_share, sa.ground_share, sa.events_per_run) == (sb.basket_share, sb.ground_share,
                                                                     sb.events_per_run)
    counts = cmp.event_counts()
    assert all(c.reference == c.compared == c.matched for c in counts.values())
    assert cmp.position_errors() == [0.0] * 3


def test_three_engines_against_one_reference() -> None:
    cmp = compare_engines([3], [0], engines=("pymunk", "box2d", "pymunk"), reference="box2d", perturb=0.02,
                          steps=300)
    assert cmp.reference == "box2d" and cmp.runs == ("pymunk", "pymunk", "box2d~0.02")
    assert cmp.agreement(0) == cmp.agreement(1)  # the same engine twice: the same answers
    assert all(len(t.agree) == 3 for t in cmp.templates)
    text = format_comparison(cmp)
    assert "agreement box2d~0.02 (%, 95% CI)" in text and "reference box2d against pymunk, pymunk, box2d~0.02" in text


def test_events_match_one_to_one_within_the_tolerance() -> None:
    a, b = frozenset({1, 2}), frozenset({1, 3})
    ref = [(a, 10), (a, 20), (b, 50)]
    assert match_events(ref, [(a, 12), (a, 12), (b, 80)]) == 2  # b is 30 steps late
    assert match_events([(a, 10)], [(a, 11), (a, 12)]) == 1  # one run event pairs with one reference event
    assert match_events([(a, 10)], [(b, 10)]) == 0  # other objects
    assert match_events([(a, 10)], [(a, 10 + EVENT_STEP_TOLERANCE + 1)]) == 0
    assert match_events(ref, []) == 0 and match_events([], ref) == 0
    assert wilson_halfwidth(50, 100) == pytest.approx(0.0962, abs=1e-3) and wilson_halfwidth(0, 0) != 0.0


def test_parallel_comparison_gives_the_same_table() -> None:
    one = compare_engines([3], range(2), jobs=1)
    two = compare_engines([3], range(2), jobs=2)
    assert one.templates == two.templates


def test_merged_stats_equal_one_scene_stats_call() -> None:
    per_seed = [scene_stats(3, [s], engine="box2d", steps=200) for s in range(2)]
    pooled, merged = scene_stats(3, range(2), engine="box2d", steps=200), merge_stats(per_seed)
    assert merged.runs == pooled.runs
    for name in ("dynamic_objects", "basket_share", "ground_share", "events_per_run"):
        assert getattr(merged, name) == pytest.approx(getattr(pooled, name))


def test_answers_compare_by_type_and_value() -> None:
    assert same_answer(INVALID, INVALID) and same_answer("red", "red") and same_answer(2, 2)
    assert not same_answer(True, 1) and not same_answer(INVALID, False) and not same_answer(0, False)
    assert len(templates()) == 67


def test_engines_compare_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["engines", "compare", "--scenes", "3", "--seeds", "1", "--markdown"]) == 0
    captured = capsys.readouterr()
    assert "| category | templates | questions | agreement box2d |" in captured.out
    assert "| descriptive_0 | D/2Q | yes |" in captured.out
    assert "| template | category | paper | questions | agreement box2d | majority answer | INVALID on box2d |" \
        in captured.out
    assert "| paper category | questions | agreement box2d (%, 95% CI) |" in captured.out
    assert "basket pymunk | basket box2d" in captured.out
    assert "[1/1] scene 3 seed 0" in captured.err
    assert main(["engines", "compare", "--scenes", "3", "--seeds", "1", "--engines", "pymunk"]) == 2


def test_perturbed_baseline_compares_a_run_with_its_perturbation() -> None:
    cmp = compare_engines([10], [0], engines=("pymunk", "pymunk"), steps=300, perturb=0.02)
    assert cmp.meta == {"perturb": 0.02} and 0.0 <= cmp.agreement() <= 1.0
    assert cmp.runs == ("pymunk", "pymunk~0.02")
    (sa, sb, sc), = cmp.scene_rows()
    assert sa.scene == sb.scene == sc.scene == 10 and sa.runs == sb.runs == sc.runs == 1
    assert "reference pymunk against pymunk, pymunk~0.02" in format_comparison(cmp)


def test_pymunk_can_build_circles_as_the_original_128_gons() -> None:
    """circle_sides=128: circles become the original's regular 128-gons (its mass and inertia, plus the 0.01 m skin
    every pymunk polygon carries), and still roll."""
    from craft_dsl.physics.pymunk_engine import PymunkEngine

    ball = make_dynamic(0, "circle", "red", "large", (-10.0, 10.0), (6.0, 0.0))
    engine = PymunkEngine(circle_sides=128)
    space, bodies, _ = engine.build_space(world(ball))
    body = bodies[0]
    assert body.mass == pytest.approx(628.07, rel=0.015) and body.moment == pytest.approx(1255.63, rel=0.025)
    assert len(body.shapes) == 1 and len(next(iter(body.shapes)).get_vertices()) == 128
    sim = simulate(world(ball), steps=240, engine=engine)
    assert sim.object(0).end.position[0] > -10.0 + 6.0  # rolled to the right along the ground
    assert simulate(world(ball), steps=240, engine=PymunkEngine()).object(0).end.position != sim.object(0).end.position


# -- rolling: the original's 128-gon circles slow down as they roll ---------------------------------------------


def _roller(size: str, speed: float, angular: bool = True, height: float = 0.0) -> tuple[WorldSpec, int, float]:
    """A world with one circle rolling (or only sliding, ``angular`` False) right at ``speed`` on the ground, or
    flying ``height`` m above it."""
    from dataclasses import replace

    radius = 1.0 if size == "small" else 2.0
    body = make_dynamic(0, "circle", "red", size, (-20.0, -4.8 + radius + 0.01 + height), (speed, 0.0))
    if angular:
        body = replace(body, angular_velocity=-speed / radius)
    w = world(body)
    return w, w.dynamic_uids[0], radius


@pytest.mark.parametrize("size", ["small", "large"])
def test_a_rolling_circle_slows_down_as_the_originals_128_gons_do(size: str) -> None:
    from craft_dsl.physics.box2d_engine import rolling_deceleration

    w, uid, radius = _roller(size, 2.0)
    a = rolling_deceleration(radius)
    assert 0.1 < a < 0.3
    sim = simulate(w, steps=120, engine="box2d")  # two seconds
    assert sim.object(uid).end.velocity[0] == pytest.approx(2.0 - 2 * a, abs=0.02)
    true_circle = simulate(w, steps=120, engine=Box2DEngine(rolling_deceleration=(0.0, 0.0)))
    assert true_circle.object(uid).end.velocity[0] == pytest.approx(2.0, abs=0.01)


def test_a_slowly_rolling_circle_stops_and_sleeps() -> None:
    w, uid, _ = _roller("small", 0.3)
    sim = simulate(w, steps=180, engine="box2d")
    assert not sim.object(uid).end.is_moving() and not sim.raw.awake[-1, sim.traj.column(uid)]
    assert simulate(w, steps=180, engine=Box2DEngine(rolling_deceleration=(0.0, 0.0))).object(uid).end.is_moving()


def test_rolling_loss_leaves_flying_circles_and_polygons_alone() -> None:
    w, uid, _ = _roller("small", 2.0, height=30.0)  # in the air for the whole second
    a, b = (simulate(w, steps=60, engine=e) for e in ("box2d", Box2DEngine(rolling_deceleration=(0.0, 0.0))))
    assert (a.traj.positions == b.traj.positions).all()
    assert (a.traj.angular_velocities == b.traj.angular_velocities).all()
    slide = world(make_dynamic(0, "cube", "red", "small", (-20.0, -3.79), (4.0, 0.0)),
                  make_dynamic(0, "triangle", "blue", "small", (0.0, -3.3), (-3.0, 0.0)))
    a, b = (simulate(slide, steps=120, engine=e) for e in ("box2d", Box2DEngine(rolling_deceleration=(0.0, 0.0))))
    assert (a.traj.positions == b.traj.positions).all()

