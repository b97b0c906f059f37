"""Which of the 20 scene layouts a video shows, and where its static elements are, to a fraction of a pixel.

The statics never move, so the per-pixel median of a few dozen frames spread over the video shows them without
the moving bodies (a body resting for most of the video stays in it: pixels of a body colour are given no weight).
Every layout is a function of a few random draws (:mod:`craft_dsl.reader.layout_model`); its static layer is drawn
exactly as the renderer draws it (:func:`craft_dsl.render.raster.static_body_layers`) and compared with the median
image in luminance:

1. **Identification**: each layout drawn at the middle of its ranges, both images blurred (sigma 3 px), summed
   squared difference; the best :data:`CANDIDATES` layouts are fitted and the one with the smallest residual wins.
2. **Fit**: Gauss-Newton over the static draws (normalised to [0, 1] over their ranges, finite differences,
   backtracking, clipped to the ranges), coarse to fine (blur 4, 2, 1, 0 px), so that a platform several pixels from
   its guess still pulls the fit towards it. Only the elements a draw moves are redrawn.

The fitted draws place every static element as the simulator placed it (sub-pixel: the residual is compression
noise), so re-simulated counterfactuals collide with the right geometry.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import ndimage as ndi

from ..render.raster import DEFAULT_SIZE, static_body_layers, static_layer
from ..scenes import Uniform, list_scenes
from ..world import BodySpec, WorldSpec
from .detect import WHITE, chroma, lookup
from .layout_model import LayoutModel, layout_model

#: Frames whose median is the background image.
MEDIAN_FRAMES = 31
#: Layouts fitted after the blurred comparison.
CANDIDATES = 3
#: Blur (pixels), downsampling and Gauss-Newton iterations of each level of the fit.
LEVELS: tuple[tuple[float, int, int], ...] = ((2.0, 2, 3), (1.0, 1, 3), (0.0, 1, 3))
#: Coordinate searches before Gauss-Newton (places per draw, rounds over all draws): the next is tried while the fit
#: is poor.
SEARCHES: tuple[tuple[int, int], ...] = ((9, 2), (17, 4))
#: Candidates whose blurred comparison is more than this many times the best one's are not fitted.
RANK_MARGIN = 2.0
#: A fit with a residual above this (grey levels, root mean square) tries the next candidate layout.
GOOD_FIT_RMS = 4.0
#: Of the statics' pixels in the median background (within :data:`EDGE_BAND` pixels of the fitted statics' drawing),
#: the share of mid greys (luminance 40-215) below which the edges are aliased. Measured: 0.06-0.20 on craft_dsl's
#: antialiased videos (also re-encoded to H.264 or MPEG-4, or rescaled to 512 px), 0.00-0.009 on the original CRAFT
#: renderer's (also re-encoded to H.264); rescaled to 128 px both read as antialiased (0.39-0.52).
ALIASED_EDGE_SHARE = 0.05
#: Where the original CRAFT renderer puts the world in its pictures, against craft_dsl's drawing (metres, x and y): its
#: statics fit 0.023 m right of and 0.072 m below where its own sampler drew them, in every layout and on every seed
#: (static balls: dy -0.073 m, sd 0.006, on two seeds of the original's own sampler; baskets: dx +0.019 to +0.027 m),
#: about 1/8 pixel right and 3/8 down at 256 px; its bodies, drawn by the same transform, with them.
ALIASED_OFFSET_M: tuple[float, float] = (0.023, -0.072)
#: Pixels further than this from the fitted statics' drawing do not count in the edge share: a body resting for
#: part of the video leaves a washed-out ghost in the median background, mid greys that are no edge (an original
#: video with a ghost read 0.054 over the whole picture, 0.003 near its statics).
EDGE_BAND = 2
_FD = 1e-4
#: Statics are drawn in greys (black, the basket's light grey, white): a pixel of the median background with more
#: chroma than this belongs to a body, whatever its colour reads as. A small yellow triangle resting for most of a
#: H.264 copy, washed pale in the median, matches no body colour; unmasked, its pale pixels drew the basket 17 px
#: aside to cover them.
STATIC_CHROMA = 12.0
#: After Gauss-Newton, the fit's WEAK_DIRECTIONS least determined directions are searched along at WEAK_SEARCH_POINTS
#: places each (blurred, at a quarter of the resolution), and the fit redone from the best; its result is kept when
#: its residual is under WEAK_SEARCH_GAIN times the first fit's.
WEAK_DIRECTIONS = 2
WEAK_SEARCH_POINTS = 17
WEAK_SEARCH_GAIN = 0.9


@dataclass(frozen=True)
class StaticFit:
    """The layout, its fitted static draws, and the root-mean-square residual (grey levels) of the fit."""

    scene: int
    values: dict[str, float]
    rms: float
    candidates: dict[int, float]  # scene -> rms of its fit (the fitted candidates)
    statics: tuple[BodySpec, ...]
    edge_share: float = 1.0  # share of mid greys among the statics' pixels (:func:`edge_share`)

    @property
    def aliased(self) -> bool:
        """The statics' edges are aliased, as the original CRAFT renderer draws them (:data:`ALIASED_EDGE_SHARE`)."""
        return self.edge_share < ALIASED_EDGE_SHARE

    @property
    def offset(self) -> tuple[float, float]:
        """Where the renderer that drew the video puts the world against craft_dsl's drawing (metres): the original
        CRAFT renderer's (:data:`ALIASED_OFFSET_M`) where the edges are aliased, else none. The draws fitted here carry
        it; :class:`~craft_dsl.reader.layout_model.LayoutModel` moves the places no draw moves by it too."""
        return ALIASED_OFFSET_M if self.aliased else (0.0, 0.0)


def median_background(frames: np.ndarray, count: int = MEDIAN_FRAMES) -> np.ndarray:
    """uint8 [H, W, 3]: the per-pixel median of ``count`` frames spread evenly over the video."""
    idx = np.unique(np.linspace(0, len(frames) - 1, min(count, len(frames))).round().astype(int))
    return np.median(frames[idx], axis=0).astype(np.uint8)


def edge_share(lum: np.ndarray, weight: np.ndarray) -> float:
    """Of the statics' pixels of a median background (luminance, pixel weights), the share of mid greys: the
    pixels an antialiased edge leaves between dark and white (1.0 where no static is seen)."""
    seen = weight > 0
    dark = int(np.count_nonzero(seen & (lum < 250)))
    mid = int(np.count_nonzero(seen & (lum > 40) & (lum < 215)))
    return mid / dark if dark else 1.0


def _luminance(rgb: np.ndarray) -> np.ndarray:
    return np.asarray(rgb, dtype=np.float32).mean(axis=-1)


def observation(median: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Luminance of the median image and the weight of each pixel (0 on and around bodies: their colours, and any
    pixel with more than :data:`STATIC_CHROMA` of chroma, which no static has)."""
    labels = lookup(median)
    body = ((labels >= 0) & (labels < WHITE)) | (chroma(median) > STATIC_CHROMA)
    body = ndi.binary_opening(body, iterations=1)  # thin grey rims of statics are not bodies
    weight = (~ndi.binary_dilation(body, iterations=3)).astype(np.float32)
    return _luminance(median), weight


class StaticRenderer:
    """The static layer's luminance for draw values, redrawing only the elements a change moves."""

    def __init__(self, model: LayoutModel, size: int = DEFAULT_SIZE) -> None:
        self.model = model
        self.size = size
        self._cache: dict[tuple[str, tuple[float, float], float], tuple[tuple[int, int], list[tuple[np.ndarray,
                                                                                                       float]]]] = {}

    def _layers(self, body: BodySpec) -> tuple[tuple[int, int], list[tuple[np.ndarray, float]]]:
        key = (body.shape, body.position, body.angle)
        hit = self._cache.get(key)
        if hit is None:
            origin, layers = static_body_layers(body, self.size)
            hit = (origin, [(cov, float(np.mean(rgb))) for cov, rgb in layers])
            if len(self._cache) > 512:
                self._cache.clear()
            self._cache[key] = hit
        return hit

    def render(self, values: Mapping[str, float]) -> np.ndarray:
        img = np.full((self.size, self.size), 255.0, dtype=np.float32)
        for body in self.model.statics(values):
            (y0, x0), layers = self._layers(body)
            for cov, lum in layers:
                h, w = cov.shape
                region = img[y0:y0 + h, x0:x0 + w]
                region *= 1.0 - cov
                region += cov * lum
        return img


def _blur(img: np.ndarray, sigma: float) -> np.ndarray:
    return ndi.gaussian_filter(img, sigma, mode="nearest") if sigma > 0 else img


@lru_cache(maxsize=32)
def _middle_image(scene: int, size: int) -> np.ndarray:
    model = layout_model(scene)
    out = _blur(StaticRenderer(model, size).render({}), 3.0)
    out.setflags(write=False)
    return out


def rank_layouts(lum: np.ndarray, weight: np.ndarray) -> list[tuple[int, float]]:
    """Every layout with the weighted mean squared difference of its middle-of-range drawing (blurred)."""
    size = lum.shape[0]
    obs = _blur(lum, 3.0)
    w = _blur(weight, 3.0)
    scores = [(s, float(np.sum(w * (_middle_image(s, size) - obs) ** 2) / max(float(w.sum()), 1.0)))
              for s in list_scenes() if s <= 20]
    return sorted(scores, key=lambda t: t[1])


def _downsample(img: np.ndarray, factor: int) -> np.ndarray:
    while factor > 1:
        img = 0.25 * (img[::2, ::2] + img[1::2, ::2] + img[::2, 1::2] + img[1::2, 1::2])
        factor //= 2
    return img


def fit_statics(model: LayoutModel, lum: np.ndarray, weight: np.ndarray, search_points: int = 9,
                search_rounds: int = 2) -> tuple[dict[str, float], float]:
    """Static draws of ``model`` that best explain the luminance image, and the final RMS residual (grey levels).

    First a coordinate search (each draw over ``search_points`` places in its range, ``search_rounds`` times round,
    on images blurred by 4 px at a quarter of the resolution), then Gauss-Newton at each level of :data:`LEVELS`,
    then a search along the fit's least determined directions (:data:`WEAK_DIRECTIONS`) and Gauss-Newton again from
    the best place found, kept where it explains the picture better."""
    size = lum.shape[0]
    renderers = {f: StaticRenderer(model, size // f) for f in (1, 2, 4)}
    paths = [p for p in model.static_paths
             if isinstance(next(d for d in model.draws if d.path == p).quantity, Uniform)]
    u = np.full(len(paths), 0.5)

    def to_values(u: np.ndarray) -> dict[str, float]:
        return model.from_unit(dict(zip(paths, u.tolist())))

    def make_residual(sigma: float, factor: int) -> tuple[Callable[[np.ndarray], np.ndarray], float]:
        obs = _blur(_downsample(lum, factor), sigma / factor)
        sw = np.sqrt(_downsample(weight, factor))

        def residual(u: np.ndarray) -> np.ndarray:
            # drawn directly at the lower resolution (the renderer's coverage is an area average, like the
            # downsampling of the observation)
            drawn = renderers[factor].render(to_values(u))
            return ((_blur(drawn, sigma / factor) - obs) * sw).ravel()

        return residual, float((sw * sw).sum())

    coarse, _ = make_residual(4.0, 4)  # the searches' picture: blurred by 4 px, a quarter of the resolution
    cost = float(np.sum(coarse(u) ** 2))
    for _ in range(search_rounds):
        for j in range(len(paths)):
            for value in np.linspace(0.0, 1.0, search_points):
                trial = u.copy()
                trial[j] = value
                c = float(np.sum(coarse(trial) ** 2))
                if c < cost:
                    u, cost = trial, c
    u, rms, jtj = _gauss_newton_levels(make_residual, u, len(paths))
    if jtj is not None and WEAK_SEARCH_POINTS:
        # Gauss-Newton stops where one edge of a static is all the picture says about a draw (an incline of two
        # overlapping platforms whose far end leaves the picture: where the upper one starts): the least
        # determined directions are searched along whole, and the fit redone from the best place found
        start_cost = float(np.sum(coarse(u) ** 2))
        found, found_cost = u, start_cost
        for v in _weak_directions(jtj):
            for t in np.linspace(-1.0, 1.0, WEAK_SEARCH_POINTS):
                trial = np.clip(u + t * v, 0.0, 1.0)
                c = float(np.sum(coarse(trial) ** 2))
                if c < found_cost:
                    found, found_cost = trial, c
        if found_cost < start_cost:
            u2, rms2, _ = _gauss_newton_levels(make_residual, found, len(paths))
            if rms2 < WEAK_SEARCH_GAIN * rms:
                u, rms = u2, rms2
    return to_values(u), rms


def _gauss_newton_levels(make_residual: Callable[[float, int], tuple[Callable[[np.ndarray], np.ndarray], float]],
                         u: np.ndarray, n: int) -> tuple[np.ndarray, float, np.ndarray | None]:
    """Gauss-Newton at each level of :data:`LEVELS` from ``u``: the units, the final RMS residual and the normal
    matrix of the last level's last Jacobian (None when nothing was fitted)."""
    rms = float("inf")
    jtj: np.ndarray | None = None
    for sigma, factor, iterations in LEVELS:
        residual, total_weight = make_residual(sigma, factor)
        r = residual(u)
        cost = float(r @ r)
        for _ in range(iterations):
            if not n:
                break
            jac = np.empty((r.size, n), dtype=np.float64)
            for j in range(n):
                du = u.copy()
                du[j] += _FD if du[j] + _FD <= 1.0 else -_FD
                jac[:, j] = (residual(du) - r) / (du[j] - u[j])
            # einsum, not BLAS: a multithreaded BLAS on a busy machine spends seconds on these tall products
            jtj = np.einsum("ij,ik->jk", jac, jac)
            jtr = np.einsum("ij,i->j", jac, r)
            step = np.clip(np.linalg.solve(jtj + np.diag(1e-3 * np.diag(jtj) + 1e-6), -jtr), -0.2, 0.2)
            improved = False
            for alpha in (1.0, 0.5, 0.25, 0.1):
                trial = np.clip(u + alpha * step, 0.0, 1.0)
                rt = residual(trial)
                ct = float(rt @ rt)
                if ct < cost:
                    u, r, cost, improved = trial, rt, ct, True
                    break
            if not improved or float(np.max(np.abs(step))) < 1e-5:
                break
        rms = float(np.sqrt(cost / max(total_weight, 1.0)))
    return u, rms, jtj


def _weak_directions(jtj: np.ndarray) -> list[np.ndarray]:
    """The :data:`WEAK_DIRECTIONS` least determined directions of a fit (eigenvectors of its normal matrix with the
    smallest eigenvalues), scaled so that their largest component is 1 (a whole range of that draw)."""
    _values, vectors = np.linalg.eigh(jtj)
    out = []
    for k in range(min(WEAK_DIRECTIONS, vectors.shape[1])):
        v = vectors[:, k]
        out.append(v / max(float(np.max(np.abs(v))), 1e-12))
    return out


def fit_layout(frames: np.ndarray, candidates: int = CANDIDATES, scene: int | None = None) -> StaticFit:
    """Identify the layout of a video (or take ``scene``) and fit its static draws."""
    lum, weight = observation(median_background(frames))
    if scene is not None:
        ranked = [scene]
    else:
        scores = rank_layouts(lum, weight)
        # a layout far behind the best drawing (blurred) is not tried
        ranked = [s for s, v in scores[:candidates] if v <= RANK_MARGIN * scores[0][1]]
    fits: dict[int, tuple[dict[str, float], float]] = {}
    for s in ranked:
        for points, rounds in SEARCHES:
            fit = fit_statics(layout_model(s), lum, weight, points, rounds)
            if s not in fits or fit[1] < fits[s][1]:
                fits[s] = fit
            if fits[s][1] <= GOOD_FIT_RMS:
                break
        if fits[s][1] <= GOOD_FIT_RMS:
            break
    best = min(fits, key=lambda s: fits[s][1])
    values, rms = fits[best]
    statics = tuple(layout_model(best).statics(values))
    drawn = _luminance(static_layer(WorldSpec(bodies=statics), frames.shape[1]))
    near = ndi.binary_dilation(drawn < 250, iterations=EDGE_BAND)
    return StaticFit(best, values, rms, {s: f[1] for s, f in fits.items()}, statics, edge_share(lum, weight * near))


def static_values_error(model: LayoutModel, fitted: Mapping[str, float], truth: Mapping[str, float]
                        ) -> dict[str, float]:
    """Per static draw, fitted minus true value (for benchmarks)."""
    return {p: float(fitted[p] - truth[p]) for p in model.static_paths if p in fitted and p in truth}


def element_errors(fitted: Sequence[BodySpec], truth: Sequence[BodySpec]) -> list[tuple[str, float, float]]:
    """Per static element: shape, position error (m) and angle error (rad)."""
    out = []
    for a, b in zip(fitted, truth):
        out.append((a.shape, float(np.hypot(a.position[0] - b.position[0], a.position[1] - b.position[1])),
                    float(abs(a.angle - b.angle))))
    return out
