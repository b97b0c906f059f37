"""Render and compare: a body's exact centre and angle in a frame, by fitting the renderer's own drawing of it.

The colour centroid of :mod:`craft_dsl.reader.measure` is biased where the eyes cover much of a small body, and the
bias depends on the compression. Here the body is drawn as the renderer draws it (:func:`craft_dsl.render.raster.
shade_body`: coverage, colour, eyes) over the static background, at a centre and angle, and the centre and angle are
moved by Gauss-Newton (finite differences, all frames at once, blurred images first) until the drawing matches the
decoded window in the least-squares sense. Pixels of other bodies' colours are given no weight. The result has no
eye bias and is as exact as the compression allows (a few hundredths of a pixel for a body seen alone).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import ndimage as ndi

from ..render.raster import shade_body
from ..vocabulary import COLORS
from ..world import bounding_radius, dynamic_geometry
from .detect import WHITE, lookup

#: Blur (pixels) of each Gauss-Newton iteration: coarse first, so that a guess two pixels off still sees the edges.
BLUR: tuple[float, ...] = (2.0, 1.0, 0.0, 0.0)
#: First angles of a small circle's or cube's pose in a soft video (see :func:`refine`'s ``starts``): only the eyes fix
#: those bodies' angles, and blurred eyes leave the fit from the eyes' own angle in a wrong minimum that the centre
#: pays for. On 25 development videos copied at 128 px the poses of small circles were off by 0.49 px at the median
#: from one start, 0.16 from four (quarter turns), 0.13 from eight; small cubes 0.33 -> 0.13 from four.
SOFT_ANGLE_STARTS = 4
#: Finite-difference steps: centre (pixels) and angle (radians).
_STEP_PX = 0.05
_DILATE = np.zeros((3, 3, 3), dtype=bool)
_DILATE[1] = True
_STEP_RAD = 0.01


def window_px(shape: str, size: str, width: int) -> int:
    """Side (pixels) of the square window a body of (shape, size) is drawn and compared in, in frames ``width``
    pixels wide: its bounding circle and a margin of 3 pixels a side."""
    return int(math.ceil(2 * bounding_radius(dynamic_geometry(shape, size)) * (width / 50.0))) + 6


def refine(frames: np.ndarray, background: np.ndarray, shape: str, size: str, color: int,
           which: Sequence[int], x: np.ndarray, y: np.ndarray, angle: np.ndarray, blur: float = 0.0,
           starts: int = 1, clipped: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Centre (pixels) and angle of the body in frames ``which`` from a first guess; also the RMS residual per frame
    (grey levels), which is small when the guessed shape and size are right. Frames whose window leaves the
    picture are returned unchanged with an infinite residual, or with ``clipped`` compared on their part inside the
    picture (a body whose centre is in it). ``blur``: Gaussian sigma (pixels) by which the
    frames are softer than the renderer draws (a video rescaled from a smaller size): the drawing is blurred as
    much before it is compared. ``starts``: each frame is fitted from that many first angles spread evenly over a
    turn (the guessed one first), and the fit with the least residual is kept (see :data:`SOFT_ANGLE_STARTS`)."""
    best = _refine_from(frames, background, shape, size, color, which, x, y, angle, blur, clipped)
    for j in range(1, starts):
        turned = np.asarray(angle, dtype=np.float64) + 2.0 * math.pi * j / starts
        other = _refine_from(frames, background, shape, size, color, which, x, y, turned, blur, clipped)
        better = other[3] < best[3]
        for mine, theirs in zip(best, other):
            mine[better] = theirs[better]
    return best


def _refine_from(frames: np.ndarray, background: np.ndarray, shape: str, size: str, color: int,
                 which: Sequence[int], x: np.ndarray, y: np.ndarray, angle: np.ndarray, blur: float,
                 clipped: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`refine` from one first guess."""
    n_frames, h, w_img = frames.shape[:3]
    geometry = dynamic_geometry(shape, size)
    win = window_px(shape, size, w_img)
    idx = np.asarray(list(which), dtype=np.int64)
    x = np.asarray(x, dtype=np.float64).copy()
    y = np.asarray(y, dtype=np.float64).copy()
    a = np.asarray(angle, dtype=np.float64).copy()
    x0 = np.floor(x - win / 2).astype(np.int64)
    y0 = np.floor(y - win / 2).astype(np.int64)
    if clipped:
        inside = (x >= 0) & (y >= 0) & (x < w_img) & (y < h)
    else:
        inside = (x0 >= 0) & (y0 >= 0) & (x0 + win <= w_img) & (y0 + win <= h)
    rms = np.full(idx.size, np.inf)
    if not inside.any():
        return x, y, a, rms
    k = np.nonzero(inside)[0]
    rows = y0[k, None] + np.arange(win)[None, :]
    cols = x0[k, None] + np.arange(win)[None, :]
    in_picture = None  # unclipped, every window lies in the picture
    if clipped:
        in_picture = ((rows >= 0) & (rows < h))[:, :, None] & ((cols >= 0) & (cols < w_img))[:, None, :]
        rows, cols = np.clip(rows, 0, h - 1), np.clip(cols, 0, w_img - 1)
    observed = frames[idx[k][:, None, None], rows[:, :, None], cols[:, None, :]].astype(np.float32)
    bg = background[rows[:, :, None], cols[:, None, :]].astype(np.float32)
    labels = lookup(observed.astype(np.uint8), soft=blur > 0)  # softer frames: their colours read softly too
    name = COLORS[color]
    # other bodies' colours do not count, except on the body itself (a small dark body partly reads as gray)
    footprint, _ = shade_body(geometry, name, x[k], y[k], a[k], x0[k], y0[k], win, w_img)
    footprint = ndi.binary_dilation(footprint > 0, structure=_DILATE, iterations=2)
    weight = ~((labels >= 0) & (labels < WHITE) & (labels != color) & ~footprint)
    if in_picture is not None:
        weight &= in_picture  # pixels outside the picture weigh nothing
    weight3 = weight[..., None].astype(np.float32)

    def draw(cx: np.ndarray, cy: np.ndarray, ang: np.ndarray) -> np.ndarray:
        alpha, base = shade_body(geometry, name, cx, cy, ang, x0[k], y0[k], win, w_img)
        drawn = bg * (1.0 - alpha[..., None]) + base
        return ndi.gaussian_filter(drawn, (0, blur, blur, 0)) if blur > 0 else drawn

    cx, cy, ang = x[k], y[k], a[k]
    for sigma in BLUR:
        def smooth(img: np.ndarray, sigma: float = sigma) -> np.ndarray:
            return ndi.gaussian_filter(img * weight3, (0, sigma, sigma, 0)) if sigma > 0 else img * weight3

        target = smooth(observed)
        model = smooth(draw(cx, cy, ang))
        r = (target - model).reshape(len(k), -1)
        jx = (smooth(draw(cx + _STEP_PX, cy, ang)) - model).reshape(len(k), -1) / _STEP_PX
        jy = (smooth(draw(cx, cy + _STEP_PX, ang)) - model).reshape(len(k), -1) / _STEP_PX
        ja = (smooth(draw(cx, cy, ang + _STEP_RAD)) - model).reshape(len(k), -1) / _STEP_RAD
        jac = np.stack([jx, jy, ja], axis=1)  # [n, 3, pixels]
        # normal equations per frame by matrix products (einsum's loops over the pixels take five times as long)
        jtj = jac @ jac.transpose(0, 2, 1) + np.eye(3)[None] * 1e-3
        jtr = (jac @ r[..., None])[..., 0]
        step = np.linalg.solve(jtj, jtr[..., None])[..., 0]
        step[:, :2] = np.clip(step[:, :2], -2.0, 2.0)
        step[:, 2] = np.clip(step[:, 2], -0.5, 0.5)
        cx, cy, ang = cx + step[:, 0], cy + step[:, 1], ang + step[:, 2]
    model = draw(cx, cy, ang)
    r = (observed - model) * weight3
    rms[k] = np.sqrt((r * r).sum(axis=(1, 2, 3)) / np.maximum(weight.sum(axis=(1, 2)) * 3, 1))
    x[k], y[k], a[k] = cx, cy, ang
    return x, y, a, rms
