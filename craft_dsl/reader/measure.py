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
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage as ndi

from .detect import BLACK, GRAY, PALETTE, WHITE, clean_background, lookup
from .morphology import close_disk, fill_holes, grow, plane_cross, shrink

#: Radius (pixels) of the disk that closes the eye notches of a body's colour mask.
CLOSING_RADIUS = 4
#: A gray piece smaller than this (pixels, 8-connected) is a speck of another body's outline or eye rim.
GRAY_SPECK_PIXELS = 8
#: 8-connectivity within each window of a stack, none between windows.
_PLANE_SQUARE = np.zeros((3, 3, 3), dtype=bool)
_PLANE_SQUARE[1] = True


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
    return measure_many(window[None], background[None], color, [origin], None if labels is None else labels[None],
                        None if seed is None else [seed], soft)[0]


def _gray_specks(labels: np.ndarray, gray: np.ndarray) -> np.ndarray:
    """The pixels of ``gray`` (bool [n, h, w]) that are another body's, not a gray body's: another body's outline and
    eye rims read gray in places (its colour mixed with black or white), next to its colour or in specks of fewer
    than :data:`GRAY_SPECK_PIXELS`. The mask's closing would join such pixels to a gray body they touch or nearly
    touch (a large gray circle resting on a small blue cube measured 427 px² instead of its 330)."""
    other = (labels >= 0) & (labels < WHITE) & (labels != GRAY)
    beside = gray & grow(other)
    pieces, _ = ndi.label(gray & ~beside, structure=_PLANE_SQUARE)
    small = np.bincount(pieces.ravel()) < GRAY_SPECK_PIXELS
    small[0] = False
    return beside | small[pieces]


def measure_many(windows: np.ndarray, backgrounds: np.ndarray, color: int, origins: Sequence[tuple[int, int]],
                 labels: np.ndarray | None = None, seeds: Sequence[tuple[int, int]] | None = None,
                 soft: bool = False) -> list[Measurement | None]:
    """:func:`measure` of each window of a stack (uint8 [n, h, w, 3], over ``backgrounds`` [n, h, w, 3]): the same
    measurements, the masks of all windows made at once."""
    if labels is None:
        labels = lookup(windows, soft)
    # the antialiased rims of black statics read as gray: gray counts only over a flat background
    clean = clean_background(backgrounds)
    core = labels == color
    if color == GRAY:
        core &= clean & ~_gray_specks(labels, core)
    present = core.any(axis=(1, 2))
    out: list[Measurement | None] = [None] * len(windows)
    if not present.any():
        return out
    closed = close_disk(core, CLOSING_RADIUS) | core
    filled = fill_holes(closed)
    pieces, _ = ndi.label(filled, structure=plane_cross(3))
    # each window's pieces are numbered after the windows' before it (no connection between windows)
    last = pieces.reshape(len(pieces), -1).max(axis=1)
    before = np.concatenate([[0], np.maximum.accumulate(last)[:-1]])
    for i in np.nonzero(last - before > 1)[0].tolist():  # several pieces: the one nearest the seed, else the largest
        frame = pieces[i]
        if seeds is not None:
            ys, xs = np.nonzero(frame)
            k = int(np.argmin((ys - seeds[i][0]) ** 2 + (xs - seeds[i][1]) ** 2))
            keep = frame[ys[k], xs[k]]
        else:
            keep = int(np.argmax(np.bincount(frame.ravel())[before[i] + 1:])) + before[i] + 1
        filled[i] = frame == keep
    interior = shrink(filled)
    rim = grow(filled) & ~interior
    c = PALETTE[color]
    b = backgrounds.astype(np.float32)
    cb = c[None, None, None, :] - b
    denom = np.maximum((cb * cb).sum(-1), 1.0)
    proj = ((windows.astype(np.float32) - b) * cb).sum(-1) / denom
    eyes = (labels == WHITE) | (labels == BLACK)
    # another body's colour (compression rings of statics reach a pixel or two beyond their drawn rims)
    other = (labels >= 0) & (labels < WHITE) & (labels != color)
    inner = {margin: shrink(clean, margin) for margin in {2, RADIUS_STATIC_MARGIN}}  # the flat background, eroded
    other &= (labels != GRAY) | inner[2]
    near = grow(filled, BLEED_WIDTH)
    touching_other = near & ~filled & other
    other_body = np.zeros_like(other)
    for i in np.nonzero(touching_other.any(axis=(1, 2)))[0].tolist():
        # which pieces of other colours are bodies (see BLEED_WIDTH); the rest is this body's rim
        parts, n = ndi.label(other[i])
        beyond = np.bincount(parts[other[i] & ~near[i]], minlength=n + 1) > 0
        sizes = np.bincount(parts.ravel(), minlength=n + 1)
        body = beyond & (sizes >= OTHER_BODY_PIXELS)
        body[0] = False
        other_body[i] = body[parts]
    alpha = interior.astype(np.float32)
    rim_ok = rim & ~other_body & ~(eyes & filled)
    alpha[rim_ok] = np.clip(proj[rim_ok], 0.0, 1.0)
    alpha[rim & filled & eyes] = 1.0
    h, w = alpha.shape[1:]
    rows = np.arange(h, dtype=np.float64)[:, None] + 0.5
    cols = np.arange(w, dtype=np.float64)[None, :] + 0.5
    clear = filled & inner[RADIUS_STATIC_MARGIN]
    inner_eyes = eyes & interior
    has_eyes = inner_eyes.any(axis=(1, 2))
    border = filled[:, 0].any(axis=1) | filled[:, -1].any(axis=1) | filled[:, :, 0].any(axis=1) | \
        filled[:, :, -1].any(axis=1)
    cut = (touching_other & other_body).any(axis=(1, 2))  # another body touches (not eye-rim mixes, not bleeding)
    complete = (~border & ~cut).tolist()
    for i in np.nonzero(present)[0].tolist():
        a = alpha[i]
        area = float(a.sum())
        if area <= 0:
            continue
        cx = float((a * cols).sum() / area)
        cy = float((a * rows).sum() / area)
        dx, dy = cols - cx, rows - cy
        mxx = float((a * dx * dx).sum() / area)
        mxy = float((a * dx * dy).sum() / area)
        myy = float((a * dy * dy).sum() / area)
        # a lossy copy smears a body's colour along a static it touches (see RADIUS_STATIC_MARGIN)
        outline = clear[i] if area >= RADIUS_CLEAR_AREA and clear[i].any() else filled[i]
        radius = float(np.sqrt((dx * dx + dy * dy)[outline].max()))
        eye_x: float | None = None
        eye_y: float | None = None
        if has_eyes[i]:
            ey, ex = np.nonzero(inner_eyes[i])
            eye_x, eye_y = float(ex.mean() + 0.5 + origins[i][1]), float(ey.mean() + 0.5 + origins[i][0])
        out[i] = Measurement(area, cx + origins[i][1], cy + origins[i][0], mxx, mxy, myy, radius, eye_x, eye_y,
                             complete[i])
    return out
