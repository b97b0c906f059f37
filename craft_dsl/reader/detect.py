"""Per-frame detection of the coloured (dynamic) bodies of a CRAFT video.

The renderer draws flat shapes in a known palette (``craft_dsl.vocabulary.COLOR_RGB``) over a white background with
black statics and a light-grey basket sensor, so detection is colour arithmetic, not learning:

1. **Colour lookup.** Every pixel of a half-resolution grid is classified by a lookup table over RGB quantised to 5
   bits per channel: the nearest palette colour if within :data:`COLOR_RADIUS` (MPEG artefacts and antialiased
   edges fall outside and stay unlabelled), built once. Where the static background is not a flat colour (the
   antialiased rims of statics, whose greys would read as "gray") gray is not read. A video drawn smaller than it is
   read (its bodies softened into their eyes and the background) reads colours softly: :func:`soft_color_table`.
2. **Blobs.** Connected pieces of each body colour, per frame (one labelling call over the whole video), with their
   grid area and centroid: a :class:`Blob`. Two touching bodies of one colour make one blob; the tracker
   (:mod:`craft_dsl.reader.track`) notices it by its area.

The sub-pixel measurement of a body (coverage-weighted centroid, eyes, angle) is done per object on full-resolution
windows by :mod:`craft_dsl.reader.measure`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import ndimage as ndi

from ..render.raster import SENSOR_GREY
from ..vocabulary import COLOR_RGB, COLORS

#: A pixel takes a palette colour when within this RGB distance of it.
COLOR_RADIUS = 60.0
#: Palette rows: the 8 body colours (indices 0-7 as in ``COLORS``), then white, black and the sensor grey.
PALETTE = np.array([COLOR_RGB[c] for c in COLORS] + [(255, 255, 255), (0, 0, 0), SENSOR_GREY], dtype=np.float32)
WHITE, BLACK, SENSOR = len(COLORS), len(COLORS) + 1, len(COLORS) + 2
GRAY = COLORS.index("gray")
UNLABELLED = -1
#: The grid step of the colour lookup (pixels).
GRID = 2
#: Blobs smaller than this many grid pixels are noise (pupil rims read as gray; the smallest body, a small circle,
#: covers about 20).
MIN_GRID_AREA = 4
#: A colour's part of a piece holding other colours too counts only from this many grid pixels, or this share of
#: the piece (the eyes' rims of a small body read as other colours).
MIN_MIXED_AREA = 10
MIN_MIXED_SHARE = 0.35
_TIME_SEPARATE = np.zeros((3, 3, 3), dtype=bool)
_TIME_SEPARATE[1] = ndi.generate_binary_structure(2, 2)


@dataclass(frozen=True)
class Blob:
    """One connected piece of one body colour in one frame, on the detection grid (full-resolution pixel
    coordinates: column x, row y; pixel centres at +0.5)."""

    frame: int
    color: int  # index into COLORS
    area: float  # full-resolution pixels (grid pixels x GRID^2)
    x: float
    y: float
    touches_edge: bool  # reaches the frame border (maybe cut off)
    touches_static: bool = False  # a gray piece next to a static's rim, where gray is not read (maybe cut off)
    on_floor: bool = False  # reaches the border only along the ground line at the frame's bottom (lies on the ground)


@lru_cache(maxsize=1)
def color_table() -> np.ndarray:
    """int8 [32768]: palette index (or -1) of each RGB quantised to 5 bits per channel (bin centres)."""
    levels = (np.arange(32, dtype=np.float32) * 8 + 3.5)
    r, g, b = np.meshgrid(levels, levels, levels, indexing="ij")
    rgb = np.stack([r, g, b], axis=-1).reshape(-1, 3)
    d2 = ((rgb[:, None, :] - PALETTE[None]) ** 2).sum(-1)
    best = d2.argmin(1)
    ok = d2[np.arange(best.size), best] <= COLOR_RADIUS ** 2
    return np.where(ok, best, UNLABELLED).astype(np.int8)


#: Soft frames (a video drawn smaller than it is read, its edges and eyes blurred into its colour): a pixel takes a
#: body colour P when it is a mix a*P + b*white + (1 - a - b)*black with a colour share ``a`` of at least
#: :data:`SOFT_SHARE`, within :data:`SOFT_RESIDUAL` (RGB distance) of that mix. Mixing with white and black keeps a
#: colour's hue, so a small red body softened with its eyes' white and black stays red (its core reads 60-70 from
#: red itself and nearer brown, the nearest palette colour).
SOFT_SHARE = 0.35
SOFT_RESIDUAL = 12.0


def cb_cr(rgb: np.ndarray) -> np.ndarray:
    """float [..., 2]: the chroma (Cb, Cr; ITU-R BT.601, full range) of RGB values [..., 3]; zero for any grey."""
    r, g, b = (np.asarray(rgb, dtype=np.float64)[..., i] for i in range(3))
    return np.stack([-0.168736 * r - 0.331264 * g + 0.5 * b, 0.5 * r - 0.418688 * g - 0.081312 * b], axis=-1)


def chroma(rgb: np.ndarray) -> np.ndarray:
    """float [...]: the chroma magnitude of RGB values [..., 3] (:func:`cb_cr`)."""
    out: np.ndarray = np.linalg.norm(cb_cr(rgb), axis=-1)
    return out


def mix_residual(rgb: np.ndarray, color: int) -> tuple[np.ndarray, np.ndarray]:
    """For RGB values float [N, 3]: the share of palette colour ``color`` in the nearest mix of it with white and
    black, and the RGB distance to that mix (both float [N])."""
    basis = np.stack([PALETTE[color].astype(np.float64), np.full(3, 255.0)], axis=1)  # the colour, white; black is 0
    share = np.clip(np.linalg.lstsq(basis, rgb.T, rcond=None)[0].T, 0.0, None)  # [N, 2]
    total = share.sum(axis=1)
    over = total > 1.0
    share[over] /= total[over, None]
    residual: np.ndarray = np.linalg.norm(share @ basis.T - rgb, axis=1)
    return share[:, 0], residual


@lru_cache(maxsize=1)
def soft_color_table() -> np.ndarray:
    """:func:`color_table` for soft frames: each bin within :data:`SOFT_RESIDUAL` of a mix of a body colour other
    than gray (whose mixes with white and black are the grey axis that static rims also lie on) with white and black,
    at a share of at least :data:`SOFT_SHARE`, takes the nearest such colour; the other bins keep their label."""
    out = color_table().copy()
    levels = (np.arange(32, dtype=np.float64) * 8 + 3.5)
    r, g, b = np.meshgrid(levels, levels, levels, indexing="ij")
    rgb = np.stack([r, g, b], axis=-1).reshape(-1, 3)
    best_residual = np.full(len(rgb), np.inf)
    best = np.full(len(rgb), UNLABELLED)
    for i in range(len(COLORS)):
        if i == GRAY:
            continue
        share, residual = mix_residual(rgb, i)
        better = (share >= SOFT_SHARE) & (residual < best_residual)
        best_residual[better] = residual[better]
        best[better] = i
    take = (best != UNLABELLED) & (best_residual <= SOFT_RESIDUAL)
    out[take] = best[take]
    return out


def lookup(pixels: np.ndarray, soft: bool = False) -> np.ndarray:
    """Palette index (int8, -1 unlabelled) of uint8 RGB pixels [..., 3] (``soft``: by :func:`soft_color_table`)."""
    q = pixels >> 3  # one pass over the contiguous pixels, then the channels packed in place
    idx = q[..., 0].astype(np.uint16)
    idx <<= 5
    idx |= q[..., 1]
    idx <<= 5
    idx |= q[..., 2]
    out: np.ndarray = (soft_color_table() if soft else color_table())[idx]
    return out


def clean_background(background: np.ndarray) -> np.ndarray:
    """bool [H, W]: background pixels of a flat colour (white or sensor grey), where a body colour can be read."""
    flat = lookup(background)
    return (flat == WHITE) | (flat == SENSOR)


def grid_rims(background: np.ndarray) -> np.ndarray:
    """bool [H/GRID, W/GRID]: grid pixels where the background is not flat (statics and their rims)."""
    out: np.ndarray = ~clean_background(background)[::GRID, ::GRID]
    return out


def grid_floor(background: np.ndarray) -> np.ndarray:
    """bool [W/GRID]: grid columns where a static is drawn along the frame's bottom edge (the ground line), so a body
    reaching that edge rests on it rather than leaving the picture."""
    out: np.ndarray = ~clean_background(background[-1:, ::GRID])[0]
    return out


def grid_labels(frames: np.ndarray, background: np.ndarray, soft: bool = False) -> np.ndarray:
    """Palette index per grid pixel, int8 [T, H/GRID, W/GRID]; body colours only over a clean background (``soft``:
    the frames are softer than the renderer draws them, see :func:`soft_color_table`)."""
    labels = lookup(frames[:, ::GRID, ::GRID], soft)
    labels[labels >= WHITE] = UNLABELLED
    labels[(labels == GRAY) & grid_rims(background)[None]] = UNLABELLED
    return labels


def blobs(labels: np.ndarray, rims: np.ndarray | None = None, floor: np.ndarray | None = None) -> list[Blob]:
    """Connected pieces of each body colour in each frame of grid labels.

    One labelling of every body-colour pixel; a piece holding two colours (bodies of different colours touching)
    is split by colour. ``rims`` (bool [H/GRID, W/GRID]): where gray is not read; a gray piece next to them is
    flagged as maybe cut off. ``floor`` (bool [W/GRID], :func:`grid_floor`): where the frame's bottom edge is a static;
    a piece that reaches the border only at the bottom edge and only above it is flagged ``on_floor``: a soft or
    rescaled video blurs a body lying on the ground into the ground line, the frame's last row. It still
    ``touches_edge``: its centroid takes in blurred ground, but it moves only as the body does."""
    mask = labels >= 0
    pieces, n = ndi.label(mask, structure=_TIME_SEPARATE)
    if n == 0:
        return []
    t, y, x = np.nonzero(pieces)
    piece = pieces[t, y, x]
    color = labels[t, y, x].astype(np.int64)
    key = piece * WHITE + color  # one entry per (piece, colour)
    counts = np.bincount(key)
    # in a piece of several colours, a small part is the rim of an eye or of a neighbour, not a body
    piece_total = np.bincount(piece)
    owner = np.arange(counts.size) // WHITE
    share = counts / np.maximum(piece_total[np.minimum(owner, piece_total.size - 1)], 1)
    present = np.nonzero((counts >= MIN_GRID_AREA) & ((share >= MIN_MIXED_SHARE) | (counts >= MIN_MIXED_AREA)))[0]
    if present.size == 0:
        return []
    sums_x = np.bincount(key, x)[present]
    sums_y = np.bincount(key, y)[present]
    sums_t = np.bincount(key, t)[present]
    n_keys = counts.size
    low_x = np.full(n_keys, 1 << 30)
    np.minimum.at(low_x, key, x)
    high_x = np.zeros(n_keys, dtype=np.int64)
    np.maximum.at(high_x, key, x)
    low_y = np.full(n_keys, 1 << 30)
    np.minimum.at(low_y, key, y)
    high_y = np.zeros(n_keys, dtype=np.int64)
    np.maximum.at(high_y, key, y)
    near_rim = np.zeros(counts.size, dtype=bool)
    if rims is not None:
        grown = ndi.binary_dilation(rims, iterations=2)
        hits = key[grown[y, x] & (color == GRAY)]
        near_rim[np.unique(hits)] = True
    h, w = labels.shape[1:]
    out: list[Blob] = []
    for i, k in enumerate(present.tolist()):
        c = counts[k]
        sides = low_x[k] == 0 or low_y[k] == 0 or high_x[k] == w - 1
        bottom = high_y[k] == h - 1
        on_floor = bool(bottom and not sides and floor is not None and floor[low_x[k]:high_x[k] + 1].all())
        out.append(Blob(int(round(sums_t[i] / c)), k % WHITE, float(c) * GRID * GRID, GRID * sums_x[i] / c + 0.5,
                        GRID * sums_y[i] / c + 0.5, bool(sides or bottom), bool(near_rim[k]), on_floor))
    out.sort(key=lambda b: (b.frame, b.color, b.x))
    return out
