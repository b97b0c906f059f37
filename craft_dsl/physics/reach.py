"""Which bodies of a run can act on which: bodies whose bounding circles, grown by a margin, never meet over the
rows of a run cannot touch there, so they move independently of each other."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Metres added to each body's bounding radius (so two bodies closer than twice this are said to meet).
REACH_MARGIN = 0.5


def interaction_groups(positions: np.ndarray, radii: Sequence[float], margin: float = REACH_MARGIN) -> list[int]:
    """A group number per body (0, 1, ... in the order of each group's first body): bodies whose circles of
    ``radii + margin`` about ``positions`` ([rows, bodies, 2], metres) overlap at some row share a group, and so do
    the groups they join (transitively)."""
    n = len(radii)
    if n == 0:
        return []
    p = np.asarray(positions, dtype=float)
    gaps = np.hypot(p[:, :, None, 0] - p[:, None, :, 0], p[:, :, None, 1] - p[:, None, :, 1]).min(axis=0)
    reach = np.asarray(radii, dtype=float) + margin
    near = gaps <= reach[:, None] + reach[None, :]
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            i = parent[i]
        return i

    for a, b in zip(*np.nonzero(np.triu(near, 1))):
        ra, rb = root(int(a)), root(int(b))
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    labels: dict[int, int] = {}
    return [labels.setdefault(root(i), len(labels)) for i in range(n)]
