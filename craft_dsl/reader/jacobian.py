"""Forward-difference Jacobians of a physics residual, with several columns measured by one run.

A reconstruction fits the start (or a restart) of a run to the video by Gauss-Newton, and each column of the
Jacobian costs one physics run: the run again with one parameter nudged. A parameter of one body changes only the
residuals of the bodies it can reach; two bodies that never come near each other within the fitted window run
independently, so their parameters can be nudged in the same run and each column read off its own bodies' rows
(the Curtis-Powell-Reid compression of a sparse Jacobian). Which bodies can reach which is read from the run the
Jacobian is taken at (:func:`craft_dsl.physics.reach.interaction_groups`: bounding circles grown by half a metre,
compared at every recorded row, closed transitively). The nudges are far smaller than the margin, so no nudged run
brings together bodies the unnudged run kept apart.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np


def perturbation_rounds(column_groups: Sequence[int | None]) -> list[list[int]]:
    """The columns nudged together, run by run: the k-th column of every group in run k; a column of no group
    (None: a parameter that moves several bodies) in a run of its own, after them."""
    grouped: list[list[int]] = []
    alone: list[list[int]] = []
    seen: dict[int, int] = {}
    for j, g in enumerate(column_groups):
        if g is None:
            alone.append([j])
            continue
        k = seen.get(g, 0)
        seen[g] = k + 1
        if k == len(grouped):
            grouped.append([])
        grouped[k].append(j)
    return grouped + alone


def forward_jacobian(residual: Callable[[np.ndarray], np.ndarray], x: np.ndarray, r0: np.ndarray,
                     steps: np.ndarray, column_groups: Sequence[int | None], row_groups: np.ndarray) -> np.ndarray:
    """The forward-difference Jacobian of ``residual`` at ``x`` (where it is ``r0``), column ``j`` from a nudge of
    ``steps[j]`` divided by the nudge as stored; one evaluation per run of :func:`perturbation_rounds`.

    ``column_groups[j]``: the interaction group of the body parameter ``j`` moves (None: it moves several);
    ``row_groups[i]``: the group of the body residual ``i`` measures. A run that nudges several columns gives each
    the difference on its own group's rows (zero elsewhere); a run of one column gives it every row."""
    jac = np.zeros((r0.size, x.size))
    for cols in perturbation_rounds(column_groups):
        moved = x.copy()
        moved[cols] += steps[cols]
        diff = residual(moved) - r0
        if len(cols) == 1:
            j = cols[0]
            jac[:, j] = diff / (moved[j] - x[j])
            continue
        for j in cols:
            rows = row_groups == column_groups[j]
            jac[rows, j] = diff[rows] / (moved[j] - x[j])
    return jac
