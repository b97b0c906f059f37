"""Sub-pixel measurement of one body in a full-resolution window: coverage, centroid, moments, eyes.

Within the window the body's colour is read by the palette lookup (:func:`craft_dsl.reader.detect.lookup`). Its mask
is closed with a disk of radius :data:`CLOSING_RADIUS` and hole-filled: the bodies are convex, so the closing gives
back the parts the eyes cover (white sclera and black pupils, which may reach the outline of a small body) without
adding anything else. Pixels well inside the closed mask count fully; on its rim a pixel counts by the projection of
its colour on the line from the background colour to the body colour (the renderer blends exactly so), clipped to
[0, 1]. The coverage-weighted moments give the area, the centroid (the body's reference point: the centre of a cube
or circle, the circumcentre of a triangle) and the second moments; the largest distance from the centroid to the
closed mask is the body's radius (a large body's over the pixels clear of the statics, :data:`RADIUS_STATIC_MARGIN`);
the eye pixels give the body's angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage as ndi

from .detect import BLACK, GRAY, PALETTE, WHITE, clean_background, lookup
from .morphology import close_disk, fill_holes, grow, shrink

#: Radius (pixels) of the disk that closes the eye notches of a body's colour mask.
CLOSING_RADIUS = 4


#: A piece of another body colour this large (pixels) next to the body means another body touches it...
OTHER_BODY_PIXELS = 12
#: ...unless it lies within this many pixels of the body's outline: a thin band of another colour along a saturated
#: body's edge is the video's colour bleeding (4:2:0 chroma and compression shift a red edge to brown), not a body.
BLEED_WIDTH = 2
#: Pixels of a large body's mask nearer than this to a static (pixels) do not count for its largest radius: a lossy
#: copy smears the body's colour along a static it touches, and a few such pixels decide a feature taken as a maximum
#: (an MPEG-4 copy's large circle wedged between two bars measured 0.749 of the square root of its area, a cube's
#: 0.707, instead of 0.552; without them 0.566). Over the H.264 and MPEG-4 copies of five seeds' test videos (841)
#: four more large bodies were read right, none wrong; the objects read from those seeds' files (527 videos) and
#: three seeds' 128- and 512-px copies (628) did not change; on 296 videos of the original renderer one more large
#: body was read right and one wrong.
RADIUS_STATIC_MARGIN = 2
#: ...for bodies of at least this coverage (pixels²; large bodies are 300-420): a small body keeps too little outline
#: clear of a static it touches, and its radius feature does not tell its shapes apart anyway.
RADIUS_CLEAR_AREA = 200.0


@dataclass(frozen=True)
class Measurement:
    """One body in one frame (full-resolution pixels; pixel centres at +0.5)."""

    area: float
    x: float
    y: float
    mxx: float
    mxy: float
    myy: float
    radius: float  # largest distance from the centroid to a pixel of the closed mask (large: clear of statics; px)
    eye_x: float | None  # centroid of the eye pixels inside the body
    eye_y: float | None
    complete: bool  # the body does not reach the window's border (and is not cut by another body)

    def eye_angle(self) -> float | None:
        """The body's angle (radians, counter-clockwise as seen) from the direction of its eyes: they sit at local
        (0, -0.45) m on average, i.e. straight above the centre at the initial angle pi."""
        if self.eye_x is None or self.eye_y is None:
            return None
        dx, dy = self.eye_x - self.x, -(self.eye_y - self.y)  # world axes (y up)
        if math.hypot(dx, dy) < 0.3:
            return None
        # local (0, -1) rotated by theta is (sin theta, -cos theta)
        return math.atan2(dx, -dy)


def measure(window: np.ndarray, background: np.ndarray, color: int, origin: tuple[int, int],
            labels: np.ndarray | None = None, seed: tuple[int, int] | None = None, soft: bool = False
            ) -> Measurement | None:
    """Measure the body of palette colour ``color`` in ``window`` (uint8 [h, w, 3]) over ``background`` (the
    static layer's same window); ``origin`` = (row, column) of the window in the frame. With ``seed`` (row, column
    inside the window) only the connected piece nearest to it is measured. ``soft``: the frames are softer than the
    renderer draws them (colours read by :func:`~craft_dsl.reader.detect.soft_color_table`)."""
    if labels is None:
        labels = lookup(window, soft)
    # the antialiased rims of black statics read as gray: gray counts only over a flat background
    clean = clean_background(background)
    core = labels == color
    if color == GRAY:
        core &= clean
    if not core.any():
        return None
    closed = close_disk(core, CLOSING_RADIUS) | core
    filled = fill_holes(closed)
    pieces, n = ndi.label(filled)
    if n > 1:
        if seed is not None:
            ys, xs = np.nonzero(filled)
            k = int(np.argmin((ys - seed[0]) ** 2 + (xs - seed[1]) ** 2))
            keep = pieces[ys[k], xs[k]]
        else:
            keep = int(np.argmax(np.bincount(pieces.ravel())[1:])) + 1
        filled = pieces == keep
    interior = shrink(filled)
    rim = grow(filled) & ~interior
    c = PALETTE[color]
    b = background.astype(np.float32)
    cb = c[None, None, :] - b
    denom = np.maximum((cb * cb).sum(-1), 1.0)
    proj = ((window.astype(np.float32) - b) * cb).sum(-1) / denom
    eyes = (labels == WHITE) | (labels == BLACK)
    # another body's colour (compression rings of statics reach a pixel or two beyond their drawn rims)
    other = (labels >= 0) & (labels < WHITE) & (labels != color)
    other &= (labels != GRAY) | shrink(clean, 2)
    near = grow(filled, BLEED_WIDTH)
    touching_other = near & ~filled & other
    other_body = np.zeros_like(other)
    if touching_other.any():  # which pieces of other colours are bodies (see BLEED_WIDTH); the rest is this body's rim
        pieces, n = ndi.label(other)
        beyond = np.bincount(pieces[other & ~near], minlength=n + 1) > 0
        sizes = np.bincount(pieces.ravel(), minlength=n + 1)
        body = beyond & (sizes >= OTHER_BODY_PIXELS)
        body[0] = False
        other_body = body[pieces]
    alpha = interior.astype(np.float32)
    rim_ok = rim & ~other_body & ~(eyes & filled)
    alpha[rim_ok] = np.clip(proj[rim_ok], 0.0, 1.0)
    alpha[rim & filled & eyes] = 1.0
    area = float(alpha.sum())
    if area <= 0:
        return None
    h, w = alpha.shape
    rows = np.arange(h, dtype=np.float64)[:, None] + 0.5
    cols = np.arange(w, dtype=np.float64)[None, :] + 0.5
    cx = float((alpha * cols).sum() / area)
    cy = float((alpha * rows).sum() / area)
    dx, dy = cols - cx, rows - cy
    mxx = float((alpha * dx * dx).sum() / area)
    mxy = float((alpha * dx * dy).sum() / area)
    myy = float((alpha * dy * dy).sum() / area)
    outline = filled
    if area >= RADIUS_CLEAR_AREA:  # a lossy copy smears a body's colour along a static it touches (see the constant)
        clear = filled & shrink(clean, RADIUS_STATIC_MARGIN)
        outline = clear if clear.any() else filled
    radius = float(np.sqrt((dx * dx + dy * dy)[outline].max()))
    inner_eyes = eyes & interior
    eye_x: float | None = None
    eye_y: float | None = None
    if inner_eyes.any():
        ey, ex = np.nonzero(inner_eyes)
        eye_x, eye_y = float(ex.mean() + 0.5 + origin[1]), float(ey.mean() + 0.5 + origin[0])
    border = filled[0].any() or filled[-1].any() or filled[:, 0].any() or filled[:, -1].any()
    cut = bool((touching_other & other_body).any())  # another body touches (not eye-rim mixes, not bleeding)
    return Measurement(area, cx + origin[1], cy + origin[0], mxx, mxy, myy, radius, eye_x, eye_y,
                       not border and not cut)
