"""Video pixels <-> simulator metres, and video frames <-> physics steps (the renderer's geometry and timing).

The video shows x in [-25, 25] m and y in [-5, 45] m (y up) on a square frame; pixel column ``px`` grows to the
right and row ``py`` downwards, so ``px = (x + 25) * size / 50`` and ``py = (45 - y) * size / 50``. Angles are the
same number in both (counter-clockwise as seen). Frame ``k`` of a video at ``fps`` shows the state after
``frame_steps(steps, fps)[k]`` steps; an event stamped step ``s`` (the physics frame in which it began) is first
seen in the state after ``s + 1`` steps, i.e. in the first frame showing a state at or after ``s + 1``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..render.raster import VIEW_SIZE, X_MIN, Y_MAX, frame_steps

__all__ = ["event_frame", "event_step", "frame_rows", "metres_per_pixel", "to_metres", "to_pixels"]


def metres_per_pixel(size: int) -> float:
    return VIEW_SIZE / size


def to_pixels(x: ArrayLike, y: ArrayLike, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel (column, row) of world points (metres, y up)."""
    s = size / VIEW_SIZE
    return (np.asarray(x, dtype=np.float64) - X_MIN) * s, (Y_MAX - np.asarray(y, dtype=np.float64)) * s


def to_metres(px: ArrayLike, py: ArrayLike, size: int) -> tuple[np.ndarray, np.ndarray]:
    """World point (metres, y up) of pixel (column, row)."""
    s = size / VIEW_SIZE
    return np.asarray(px, dtype=np.float64) / s + X_MIN, Y_MAX - np.asarray(py, dtype=np.float64) / s


def frame_rows(steps: int, fps: float) -> np.ndarray:
    """The physics step (trajectory row) each frame of a video at ``fps`` shows."""
    return frame_steps(steps, fps)


def event_frame(step: int, rows: np.ndarray) -> int:
    """The first frame (index into ``rows``) showing an event stamped ``step``."""
    k = int(np.searchsorted(rows, step + 1, side="left"))
    return min(k, len(rows) - 1)


def event_step(frame: int, rows: np.ndarray) -> int:
    """The step stamp of an event first seen in ``frame`` (exact at 60 fps, within a frame otherwise)."""
    return int(rows[min(max(frame, 0), len(rows) - 1)]) - 1
