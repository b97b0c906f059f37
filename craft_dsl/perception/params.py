"""A body's state as six numbers of a flat parameter vector: position x, y, angle, velocity x, y, spin.

The start fit (:mod:`craft_dsl.perception.fit`) and the reader's restarts (:mod:`craft_dsl.reader.reconstruct`)
keep one such block per body, body ``i`` at ``SIZE * i``; these names address its components.
"""

from __future__ import annotations

import numpy as np

#: Component indices within one body's block.
X, Y, ANGLE, VX, VY, SPIN = range(6)
#: Numbers per body.
SIZE = 6
#: Position (x, y), velocity (vx, vy) and pose (x, y, angle) within one body's block.
POSITION = slice(X, Y + 1)
VELOCITY = slice(VX, VY + 1)
POSE = slice(X, ANGLE + 1)


def block(params: np.ndarray, i: int) -> np.ndarray:
    """Body ``i``'s six numbers of ``params`` (a view)."""
    return params[SIZE * i:SIZE * i + SIZE]


def pose(params: np.ndarray, i: int) -> np.ndarray:
    """Body ``i``'s pose (x, y, angle) of ``params`` (a view)."""
    return params[SIZE * i:SIZE * i + ANGLE + 1]


def per_component(pose_value: float, motion_value: float) -> np.ndarray:
    """One body's block with ``pose_value`` for x, y, angle and ``motion_value`` for vx, vy, spin."""
    return np.array([pose_value] * (ANGLE + 1) + [motion_value] * (SIZE - ANGLE - 1))
