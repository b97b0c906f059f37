"""Helpers of the reader's tests."""

from __future__ import annotations

import numpy as np

from craft_dsl.reader.perceive import Perception
from craft_dsl.render.raster import world_to_pixel


def tracks_px(perception: Perception) -> dict[tuple[str, str, str], np.ndarray]:
    """Each dynamic body's reconstructed path in pixels ([steps, 2], from step 1), by (shape, colour, size)."""
    traj = perception.reconstruction.simulation.trajectory
    out = {}
    for b in perception.reconstruction.simulation.world_spec.bodies:
        if b.dynamic:
            pos = traj.positions[1:, traj.column(b.uid)]
            out[(b.shape, b.color, b.size)] = np.stack(world_to_pixel(pos[:, 0], pos[:, 1]), axis=1)
    return out
