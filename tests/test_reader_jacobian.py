"""Finite-difference Jacobians with several columns per physics run (craft_dsl.reader.jacobian), and the
interaction groups they rest on (craft_dsl.physics.reach)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from craft_dsl.physics.live import get_engine
from craft_dsl.physics.reach import REACH_MARGIN, interaction_groups
from craft_dsl.reader.jacobian import forward_jacobian, perturbation_rounds
from craft_dsl.world import WorldSpec, assign_uids, bounding_radius, make_dynamic, make_static


def test_bodies_whose_grown_circles_never_meet_are_apart() -> None:
    # three bodies on a line, radius 1: 0 and 1 come within reach at the last row, 2 stays 10 m away
    rows = np.array([[[0.0, 0.0], [6.0, 0.0], [20.0, 0.0]],
                     [[0.0, 0.0], [2.0 + 2 * REACH_MARGIN, 0.0], [20.0, 0.0]]])
    assert interaction_groups(rows, [1.0, 1.0, 1.0]) == [0, 0, 1]
    assert interaction_groups(rows[:1], [1.0, 1.0, 1.0]) == [0, 1, 2]  # the first row alone: all apart
    assert interaction_groups(rows[:1], [1.0, 1.0, 1.0], margin=2.0) == [0, 0, 1]


def test_groups_are_closed_transitively_and_numbered_by_their_first_body() -> None:
    # 3 touches 1, 1 touches 0 (through different rows); 2 is alone
    rows = np.array([[[0.0, 0.0], [50.0, 0.0], [100.0, 0.0], [200.0, 0.0]],
                     [[0.0, 0.0], [2.5, 0.0], [100.0, 0.0], [200.0, 0.0]],
                     [[0.0, 0.0], [50.0, 0.0], [100.0, 0.0], [52.0, 0.0]]])
    rows[2, 1] = [50.0, 0.0]
    assert interaction_groups(rows, [1.0] * 4) == [0, 0, 1, 0]
    assert interaction_groups(np.zeros((3, 0, 2)), []) == []


def test_rounds_take_one_column_of_each_group_and_shared_columns_alone() -> None:
    assert perturbation_rounds([0, 0, 1, 1, 1, 2]) == [[0, 2, 5], [1, 3], [4]]
    assert perturbation_rounds([0, None, 1, None]) == [[0, 2], [1], [3]]
    assert perturbation_rounds([]) == []
    # every column in one group: one run per column, as without compression
    assert perturbation_rounds([3, 3, 3]) == [[0], [1], [2]]


def _separable(calls: list[np.ndarray]):  # type: ignore[no-untyped-def]
    """Rows 0-2 depend on x0, x1 (body A); rows 3-4 on x2, x3 (body B); row 5 on x4 (body C)."""

    def f(x: np.ndarray) -> np.ndarray:
        calls.append(x.copy())
        return np.array([x[0] ** 2 + x[1], np.sin(x[1]), x[0] * x[1], np.exp(x[2]) - x[3], x[3] ** 3,
                         np.cos(x[4])])
    return f


def test_compressed_jacobian_equals_the_one_column_per_run_jacobian() -> None:
    x = np.array([0.3, -0.7, 0.2, 1.1, 0.5])
    steps = np.full(5, 1e-6)
    row_groups = np.array([0, 0, 0, 1, 1, 2])
    calls: list[np.ndarray] = []
    f = _separable(calls)
    r0 = f(x)
    full = forward_jacobian(f, x, r0, steps, [None] * 5, row_groups)
    assert len(calls) == 1 + 5
    compressed = forward_jacobian(f, x, r0, steps, [0, 0, 1, 1, 2], row_groups)
    assert len(calls) == 1 + 5 + 2
    np.testing.assert_allclose(compressed, full, rtol=1e-6, atol=1e-9)
    analytic = np.zeros((6, 5))
    analytic[0, :2] = [2 * x[0], 1.0]
    analytic[1, 1] = np.cos(x[1])
    analytic[2, :2] = [x[1], x[0]]
    analytic[3, 2:4] = [np.exp(x[2]), -1.0]
    analytic[4, 3] = 3 * x[3] ** 2
    analytic[5, 4] = -np.sin(x[4])
    np.testing.assert_allclose(compressed, analytic, rtol=1e-4, atol=1e-5)
    # the first compressed run nudged x0, x2 and x4 together
    assert np.count_nonzero(calls[-2] != x) == 3


def test_a_column_is_divided_by_its_nudge_as_stored() -> None:
    x = np.array([1.0 - 1e-6, 0.0])
    steps = np.array([-1e-5, 1e-5])  # a draw near its upper bound is nudged down
    jac = forward_jacobian(lambda v: np.array([3.0 * v[0], 5.0 * v[1]]), x, np.array([3.0 * x[0], 0.0]), steps,
                              [0, 1], np.array([0, 1]))
    np.testing.assert_allclose(jac, [[3.0, 0.0], [0.0, 5.0]], rtol=1e-6)


def _two_apart() -> WorldSpec:
    bodies = [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
              make_dynamic(0, "circle", "red", "large", (-12.0, 2.0), velocity=(1.0, 0.0)),
              make_dynamic(0, "cube", "blue", "small", (12.0, 6.0), velocity=(-0.5, 0.0))]
    return WorldSpec(bodies=assign_uids(bodies), scene_id=None, seed=0)


@pytest.mark.parametrize("engine", ["pymunk", "box2d"])
def test_nudging_a_body_leaves_a_body_out_of_its_reach_untouched(engine: str) -> None:
    """The premise of the compression: a body the grown circles keep apart runs bit for bit the same."""
    if engine == "box2d":
        pytest.importorskip("Box2D", reason="needs the box2d extra (pip install -e '.[box2d]')")
    eng = get_engine(engine)
    world = _two_apart()
    a, b = [body for body in world.bodies if body.dynamic]
    base = eng.run(world, 120)
    traj = base.trajectory
    cols = [traj.column(a.uid), traj.column(b.uid)]
    radii = [bounding_radius(a.geometry), bounding_radius(b.geometry)]
    assert interaction_groups(traj.positions[:, cols], radii) == [0, 1]
    nudged = replace(world, bodies=tuple(replace(body, position=(body.position[0] + 1e-4, body.position[1]),
                                                 velocity=(body.velocity[0] + 1e-3, body.velocity[1]))
                                         if body.uid == a.uid else body for body in world.bodies))
    run = eng.run(nudged, 120).trajectory
    assert not np.array_equal(run.positions[:, cols[0]], traj.positions[:, cols[0]])
    np.testing.assert_array_equal(run.positions[:, cols[1]], traj.positions[:, cols[1]])
    np.testing.assert_array_equal(run.angles[:, cols[1]], traj.angles[:, cols[1]])


def test_bounding_radius_holds_every_vertex() -> None:
    cube = make_dynamic(0, "cube", "red", "large", (0.0, 0.0))
    circle = make_dynamic(0, "circle", "red", "small", (0.0, 0.0))
    corners = [np.hypot(x, y) for poly in cube.geometry.polygons for x, y in poly]
    assert bounding_radius(cube.geometry) == pytest.approx(max(corners))
    assert bounding_radius(circle.geometry) == circle.geometry.circle_radius


def test_a_start_fit_ends_once_an_iteration_gains_less_than_its_tolerance() -> None:
    from craft_dsl.reader.reconstruct import FIT_TOLERANCE, fit_converged

    step = np.array([0.01, -0.02])
    # a tenth of the misfit gained: go on; a gain under the tolerance's share of the misfit, or none: stop
    assert not fit_converged(100.0, 90.0, step)
    assert not fit_converged(100.0, 100.0 * (1 - 2 * FIT_TOLERANCE), step)
    assert fit_converged(100.0, 100.0 * (1 - 0.5 * FIT_TOLERANCE), step)
    assert fit_converged(100.0, 100.0, step)
    # a negligible step ends the fit whatever it gained
    assert fit_converged(100.0, 50.0, np.array([1e-8, -1e-8]))
