"""Render-and-compare near the picture's border: a drawing whose window leaves the picture is compared on its part
inside it where asked (``refine(..., clipped=True)``, the shape check), so a small circle at the bottom of the
picture is not judged only on the frames where a square's wider window fits."""

from __future__ import annotations

import math

import numpy as np

from craft_dsl.reader.refine import refine, window_px
from craft_dsl.render.raster import shade_body
from craft_dsl.vocabulary import COLORS
from craft_dsl.world import dynamic_geometry

SIZE = 256


def _window(shape: str) -> int:
    return window_px(shape, "small", SIZE)


def _frame_with(shape: str, color: str, cx: float, cy: float, angle: float) -> np.ndarray:
    """One frame: a small body drawn sharply at (cx, cy, angle) over white."""
    win = _window(shape)
    x0, y0 = np.array([int(cx) - win // 2]), np.array([int(cy) - win // 2])
    alpha, colour = shade_body(dynamic_geometry(shape, "small"), color, np.array([cx]), np.array([cy]),
                               np.array([angle]), x0, y0, win)
    frame = np.full((SIZE + win, SIZE + win, 3), 255.0, dtype=np.float32)  # room for the window below the picture
    window = frame[y0[0]:y0[0] + win, x0[0]:x0[0] + win]
    frame[y0[0]:y0[0] + win, x0[0]:x0[0] + win] = window * (1 - alpha[0][..., None]) + colour[0]
    return np.clip(frame[:SIZE, :SIZE], 0, 255).round().astype(np.uint8)[None]


def test_a_circle_at_the_bottom_is_told_from_a_cube_on_its_part_in_the_picture() -> None:
    circle_win, cube_win = _window("circle"), _window("cube")
    assert cube_win > circle_win
    cx, angle = 120.3, 0.3
    cy = SIZE - circle_win / 2 - 0.5  # the circle's window fits, the cube's leaves the picture
    assert int(math.floor(cy - cube_win / 2)) + cube_win > SIZE
    frames = _frame_with("circle", "brown", cx, cy, angle)
    background = np.full((SIZE, SIZE, 3), 255, dtype=np.uint8)
    brown = COLORS.index("brown")
    guess = (np.array([cx + 0.3]), np.array([cy - 0.2]), np.array([angle]))

    def residual(shape: str, clipped: bool) -> float:
        return float(refine(frames, background, shape, "small", brown, [0], *guess, clipped=clipped)[3][0])

    assert residual("circle", False) == residual("circle", True) < 5.0  # inside the picture: the same fit
    assert math.isinf(residual("cube", False))  # the square's window leaves the picture: not compared
    cube = residual("cube", True)
    assert math.isfinite(cube) and cube > 3 * residual("circle", True)  # compared on its part inside: wrong shape
    outside = (np.array([cx]), np.array([SIZE + 2.0]), np.array([angle]))  # a centre below the picture
    assert math.isinf(float(refine(frames, background, "cube", "small", brown, [0], *outside, clipped=True)[3][0]))
