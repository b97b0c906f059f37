"""A video's colours measured against the CRAFT palette, and a graded video's frames brought back to it.

A CRAFT picture holds few colours: the white background, the black statics, the sensor's grey and the eight body
colours. A video that passed through an editor, a player or a converter may show them otherwise: a full-range video
read as limited range (washed out: white at 235, black at 16), a gamma, brightness or contrast change, a saturation
change. The reader reads colours against the palette, so such a video loses its bodies' colours, and with them
their shapes and sizes.

:func:`measure_tone` measures the grading in a few frames spread over the video, as a map of the palette to what
the frames show, in luma and chroma (ITU-R BT.601, full range) as video tools grade them: luma
``Y' = offset + scale * 255 * (Y / 255) ** gamma`` and chroma ``C' = k C`` (``k`` a complex gain on ``Cb + i Cr``:
a saturation change and a hue turned). It is fitted to the frames' flat colours (pixels equal to their neighbours:
the inside of bodies, statics and the background, not their edges), each paired with the palette colour the map
sends nearest to it, and fitted again until the pairing stands; it starts from the background's luma as white and
the darkest large colour's as black. :func:`calibrated` undoes a grading that moves some palette colour's luma by more
than :data:`LUMA_TOLERANCE` levels or scales chroma by more than :data:`CHROMA_TOLERANCE`, and leaves the frames as
they are otherwise (the same array: a video as the renderer wrote it, or re-encoded by a lossy codec, which pales
small bodies a little, reads as before).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..render.raster import BACKGROUND, SENSOR_GREY
from ..vocabulary import COLOR_RGB, COLORS

#: A fitted grading is undone where it moves the luma of some palette colour other than black by more than this many
#: levels (:attr:`Tone.luma_shift`), or changes chroma by more than this share (``|k - 1|``). The renderer's own
#: videos and lossy copies of them (H.264 at crf 28, MPEG-4 at q 8, rescaled to 128 px) measure luma within 13 levels
#: and chroma within 0.30 (a lossy codec pales a small body's few flat pixels); a limited-range video read as full
#: range 20 levels and 0.15, ffmpeg's ``eq=gamma=1.2:saturation=0.85`` 19 and 0.17.
LUMA_TOLERANCE = 16.0
CHROMA_TOLERANCE = 0.4
#: The frames the grading is measured in, spread over the video.
TONE_FRAMES = 16
#: A flat pixel differs from its right, lower and lower-right neighbours by at most this much in every channel.
FLAT_LEVELS = 3
#: Flat colours are binned this many levels wide per channel; a bin of fewer pixels than :data:`MIN_BIN` is not a
#: colour of the picture (a mix at an edge, a compression artefact).
BIN_LEVELS = 6
MIN_BIN = 6
#: Every this-many-th pixel of a row and of a column is looked at (the colours of a picture are many pixels
#: each).
STRIDE = 2
#: A bin farther than this (luma-chroma distance, levels) from every palette colour's image is left out of a fit.
PAIR_DISTANCE = 40.0
#: Gamma values tried in the luma fit (each with its offset and scale by least squares).
GAMMAS = np.exp(np.linspace(np.log(0.4), np.log(2.5), 73))
#: Starting chroma gains: a strong desaturation may pair colours wrongly from the identity; each start is fitted, and
#: a paler one kept where it leaves the flat colours clearly nearer the palette (:data:`START_MARGIN`).
CHROMA_STARTS = (1.0, 0.75, 0.55, 0.4)
#: A paler start is kept over the first one only where its fit's cost is below this share of the first's.
START_MARGIN = 0.8
ITERATIONS = 8
#: Black's first guess: the luma under which this share of the flat pixels lie (the statics' colour), where it is
#: at most :data:`DARKEST_BLACK` levels (0 otherwise).
LARGE_SHARE = 0.002
DARKEST_BLACK = 100.0
#: The chroma gain is measured where the paired body colours hold at least this many flat pixels (of those
#: looked at); with fewer it is taken as 1 (a few pixels of one body say little about the whole picture).
CHROMA_PIXELS = 60
#: The gradings measured at all: the luma offset and scale, the chroma gain's size. A fit outside them paired the
#: colours wrongly, and the frames are read as they are.
PLAUSIBLE = {"offset": (-30.0, 40.0), "scale": (0.5, 1.6), "gain": (0.3, 1.8)}

#: The picture's colours: the body colours, the background, the statics (black) and the sensor's grey.
PICTURE_RGB = np.array([COLOR_RGB[c] for c in COLORS] + [BACKGROUND, (0, 0, 0), SENSOR_GREY], dtype=np.float64)

_NOT_BLACK = PICTURE_RGB.sum(axis=1) > 0

_TO_YCC = np.array([[0.299, 0.587, 0.114],
                    [-0.168736, -0.331264, 0.5],
                    [0.5, -0.418688, -0.081312]])
_FROM_YCC = np.linalg.inv(_TO_YCC)


def to_ycc(rgb: np.ndarray) -> np.ndarray:
    """float [..., 3]: luma and chroma (Y, Cb, Cr; BT.601 full range, chroma centred on 0) of RGB values [..., 3]."""
    out: np.ndarray = np.asarray(rgb, dtype=np.float64) @ _TO_YCC.T
    return out


def from_ycc(ycc: np.ndarray) -> np.ndarray:
    """float [..., 3]: RGB of luma-chroma values [..., 3] (:func:`to_ycc`'s inverse)."""
    out: np.ndarray = np.asarray(ycc) @ _FROM_YCC.T
    return out


@dataclass(frozen=True)
class Tone:
    """A measured grading of the palette: luma ``offset + scale * 255 * (Y / 255) ** gamma``, chroma ``matrix @ C``.

    ``residual``: the RMS luma-chroma distance (levels) of the flat colours from the palette's images (one no
    palette colour pairs with counted at :data:`PAIR_DISTANCE`);
    ``deviation``: the most the grading moves a palette colour (RGB distance, levels); ``pairs``: the flat colours
    it was fitted to."""

    offset: float
    scale: float
    gamma: float
    matrix: tuple[float, float, float, float]
    residual: float
    deviation: float
    pairs: int

    @property
    def luma_shift(self) -> float:
        """The most the grading moves the luma of a palette colour other than black (levels). Black is left out: a
        rescale blurs the thin black statics, whose flat pixels then read lifted, where a grading shows at white and
        in the mid-tones too."""
        ycc = to_ycc(PICTURE_RGB[_NOT_BLACK])
        return float(np.abs(self.apply(ycc)[:, 0] - ycc[:, 0]).max())

    @property
    def gain(self) -> complex:
        """The chroma's complex gain ``k`` (``matrix`` is its 2x2 form)."""
        return complex(self.matrix[0], self.matrix[2])

    @property
    def chroma_change(self) -> float:
        """``|k - 1|``: how much the grading changes chroma (0: not at all)."""
        return abs(self.gain - 1.0)

    @property
    def graded(self) -> bool:
        """Whether the grading is over :data:`LUMA_TOLERANCE` or :data:`CHROMA_TOLERANCE`: frames to correct."""
        return self.luma_shift > LUMA_TOLERANCE or self.chroma_change > CHROMA_TOLERANCE

    @property
    def chroma(self) -> np.ndarray:
        return np.array(self.matrix, dtype=np.float64).reshape(2, 2)

    def apply(self, ycc: np.ndarray) -> np.ndarray:
        """The graded image of luma-chroma values [..., 3]."""
        y = np.clip(ycc[..., 0], 0.0, 255.0)
        out = np.empty_like(ycc, dtype=np.float64)
        out[..., 0] = self.offset + self.scale * 255.0 * (y / 255.0) ** self.gamma
        out[..., 1:] = ycc[..., 1:] @ self.chroma.T
        return out

    def to_json(self) -> dict[str, Any]:
        return {"offset": round(self.offset, 3), "scale": round(self.scale, 4), "gamma": round(self.gamma, 4),
                "chroma": [round(v, 4) for v in self.matrix], "residual": round(self.residual, 3),
                "deviation": round(self.deviation, 2), "luma_shift": round(self.luma_shift, 2),
                "chroma_change": round(self.chroma_change, 4), "pairs": self.pairs}


def flat_colours(frames: np.ndarray, count: int = TONE_FRAMES) -> tuple[np.ndarray, np.ndarray]:
    """The flat colours of ``count`` frames spread over ``frames`` uint8 [T, H, W, 3], every :data:`STRIDE`-th
    pixel of each row and column: their mean RGB float [K, 3] and pixel counts int [K], a bin
    (:data:`BIN_LEVELS` wide) each, bins of fewer than :data:`MIN_BIN` left out."""
    picks = np.unique(np.linspace(0, len(frames) - 1, min(count, len(frames))).round().astype(int))
    sample = frames[picks]
    h, w = sample.shape[1] - 1, sample.shape[2] - 1
    centre = [np.ascontiguousarray(sample[:, 0:h:STRIDE, 0:w:STRIDE, c]) for c in range(3)]
    flat = np.ones(centre[0].shape, dtype=bool)
    for dy, dx in ((0, 1), (1, 0), (1, 1)):
        for c in range(3):
            other = sample[:, dy:h + dy:STRIDE, dx:w + dx:STRIDE, c]
            flat &= (np.maximum(centre[c], other) - np.minimum(centre[c], other)) <= FLAT_LEVELS
    pixels = np.stack([plane[flat] for plane in centre], axis=1).astype(np.int64)
    if not len(pixels):
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    q = pixels // BIN_LEVELS
    keys = (q[:, 0] * 64 + q[:, 1]) * 64 + q[:, 2]
    counts = np.bincount(keys, minlength=64 ** 3)
    kept = np.flatnonzero(counts >= MIN_BIN)
    sums = np.stack([np.bincount(keys, weights=pixels[:, c], minlength=64 ** 3)[kept] for c in range(3)], axis=1)
    return sums / counts[kept, None], counts[kept]


def _fit_luma(source: np.ndarray, seen: np.ndarray, weight: np.ndarray) -> tuple[float, float, float]:
    """Offset, scale and gamma of ``seen ~ offset + scale * 255 * (source / 255) ** gamma``, weighted least
    squares over :data:`GAMMAS`."""
    x = np.clip(source, 0.0, 255.0) / 255.0
    basis = 255.0 * x[None, :] ** GAMMAS[:, None]  # [G, N]
    w = weight / weight.sum()
    mb, my = basis @ w, float(seen @ w)
    var = (basis ** 2) @ w - mb ** 2
    cov = basis @ (w * seen) - mb * my
    scale = np.where(var > 1e-9, cov / np.maximum(var, 1e-9), 0.0)
    offset = my - scale * mb
    cost = ((offset[:, None] + scale[:, None] * basis - seen[None]) ** 2) @ w
    cost[scale <= 0] = np.inf
    if not np.isfinite(cost).any():
        return 0.0, 1.0, 1.0
    g = int(np.argmin(cost))
    return float(offset[g]), float(scale[g]), float(GAMMAS[g])


def _chroma_gain(source: np.ndarray, seen: np.ndarray, weight: np.ndarray) -> complex:
    """The complex gain ``k`` (a saturation change and a hue rotation) of ``seen ~ k * source``, chroma as ``Cb + i
    Cr``, by weighted least squares (1 where the source colours hold no chroma)."""
    zs = source[:, 0] + 1j * source[:, 1]
    zo = seen[:, 0] + 1j * seen[:, 1]
    power = float((weight * np.abs(zs) ** 2).sum())
    if power <= 0.0:
        return complex(1.0)
    return complex((weight * np.conj(zs) * zo).sum() / power)


def _fit(colours: np.ndarray, counts: np.ndarray, weight: np.ndarray, start: float, white: float, black: float
         ) -> Tone:
    palette = to_ycc(PICTURE_RGB)
    seen = to_ycc(colours)
    scale = max(white - black, 1.0) / 255.0
    tone = Tone(black, scale, 1.0, (start, 0.0, 0.0, start), 0.0, 0.0, 0)
    pairing: tuple[np.ndarray, np.ndarray] | None = None
    for _ in range(ITERATIONS):
        image = tone.apply(palette)
        dist = np.linalg.norm(seen[:, None, :] - image[None], axis=-1)
        nearest = dist.argmin(axis=1)
        near = dist[np.arange(len(seen)), nearest] <= PAIR_DISTANCE
        if near.sum() < 3 or len(np.unique(nearest[near])) < 3:
            break
        if pairing is not None and np.array_equal(near, pairing[0]) and np.array_equal(nearest, pairing[1]):
            break
        pairing = (near, nearest)
        src, obs, w = palette[nearest[near]], seen[near], weight[near]
        offset, scale, gamma = _fit_luma(src[:, 0], obs[:, 0], w)
        chromatic = np.hypot(src[:, 1], src[:, 2]) > 1.0
        evidence = int(counts[near][chromatic].sum())
        gain = _chroma_gain(src[:, 1:], obs[:, 1:], w) if evidence >= CHROMA_PIXELS else complex(1.0)
        matrix = (gain.real, -gain.imag, gain.imag, gain.real)
        tone = Tone(offset, scale, gamma, matrix, 0.0, 0.0, int(near.sum()))
    image = tone.apply(palette)
    dist = np.minimum(np.linalg.norm(seen[:, None, :] - image[None], axis=-1).min(axis=1), PAIR_DISTANCE)
    cost = float(np.sqrt((dist ** 2 * weight).sum() / weight.sum()))  # unpaired colours count at the pairing limit
    deviation = float(np.linalg.norm(from_ycc(image) - PICTURE_RGB, axis=1).max())
    return Tone(tone.offset, tone.scale, tone.gamma, tone.matrix, cost, deviation, tone.pairs)


def measure_tone(frames: np.ndarray) -> Tone | None:
    """The grading of the palette that ``frames`` uint8 [T, H, W, 3] show (None: too few flat colours to say)."""
    colours, counts = flat_colours(frames)
    if len(colours) < 3:
        return None
    weight = np.sqrt(counts.astype(np.float64))  # the background's many pixels anchor, and do not outweigh, the rest
    luma = to_ycc(colours)[:, 0]
    white = float(luma[np.argmax(counts)])  # the background: most of a CRAFT picture
    order = np.argsort(luma)  # the statics: the luma under which LARGE_SHARE of the flat pixels lie
    darkest = float(luma[order][np.searchsorted(np.cumsum(counts[order]), LARGE_SHARE * counts.sum())])
    black = darkest if darkest <= DARKEST_BLACK else 0.0  # no black to be seen: taken as drawn
    fits = [_fit(colours, counts, weight, start, white, black) for start in CHROMA_STARTS]
    fits = [f for f in fits if f.pairs >= 3]
    if not fits:
        return None
    # the start whose fit leaves the flat colours nearest the palette's images (its residual, an unpaired one at the
    # limit); a paler start only where it fits clearly better than the first (one body's colour can pair either way)
    best = fits[0]
    for tone in fits[1:]:
        if tone.residual < START_MARGIN * best.residual:
            best = tone
    return best if plausible(best) else None


def plausible(tone: Tone) -> bool:
    """Whether ``tone`` is a grading a video tool makes (:data:`PLAUSIBLE`), not a pairing gone wrong."""
    gain = abs(tone.gain)
    return (PLAUSIBLE["offset"][0] <= tone.offset <= PLAUSIBLE["offset"][1]
            and PLAUSIBLE["scale"][0] <= tone.scale <= PLAUSIBLE["scale"][1]
            and PLAUSIBLE["gain"][0] <= gain <= PLAUSIBLE["gain"][1])


def correct(frames: np.ndarray, tone: Tone, chunk: int = 8) -> np.ndarray:
    """``frames`` uint8 [T, H, W, 3] with ``tone`` undone (a new array). The inverse grading is linear in RGB but for
    the luma curve: ``rgb' = L rgb + c g(Y)``, ``L`` the chroma's inverse gain through BT.601, ``c`` the luma column
    of its inverse and ``g`` the inverse luma curve, tabulated in quarter levels; computed channel by channel."""
    inverse = np.zeros((3, 3))
    inverse[1:, 1:] = np.linalg.inv(tone.chroma)
    linear = (_FROM_YCC @ inverse @ _TO_YCC).astype(np.float32)  # the chroma part, row c: channel c's weights
    column = _FROM_YCC[:, 0].astype(np.float32)
    levels = np.arange(0, 4 * 255 + 2, dtype=np.float64) / 4.0
    curve = 255.0 * np.clip((levels - tone.offset) / (tone.scale * 255.0), 0.0, None) ** (1.0 / tone.gamma)
    curve = curve.astype(np.float32)
    luma = (_TO_YCC[0] * 4.0).astype(np.float32)
    out = np.empty_like(frames)
    for start in range(0, len(frames), chunk):
        r, g, b = (frames[start:start + chunk, ..., i].astype(np.float32) for i in range(3))
        y = curve[(r * luma[0] + g * luma[1] + b * luma[2] + 0.5).astype(np.int32)]
        for c in range(3):
            value = r * linear[c, 0]
            value += g * linear[c, 1]
            value += b * linear[c, 2]
            value += y * column[c]
            value += 0.5
            np.clip(value, 0.0, 255.0, out=value)
            out[start:start + chunk, ..., c] = value
    return out


def calibrated(frames: np.ndarray) -> tuple[np.ndarray, Tone | None]:
    """``frames`` with a measured grading undone where it is over the tolerances (:attr:`Tone.graded`), and that
    grading; the same array and None where it is within them (or cannot be measured)."""
    tone = measure_tone(frames)
    if tone is None or not tone.graded:
        return frames, None
    return correct(frames, tone), tone
