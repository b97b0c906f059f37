"""Perceived tracks -> motion at the simulator's step rate (rows 0..steps, metres, radians, SI velocities).

For each track:

1. frames map to trajectory rows by the renderer's rule (:func:`~craft_dsl.perception.coords.frame_rows`); pixels
   become metres; angles are unwrapped (a model may report them modulo 2 pi);
2. the position noise is estimated from the second differences of the observed frames (median absolute
   deviation / 0.6745 / sqrt(6); below :data:`EXACT_SIGMA_PX` the track counts as exact). A noisy track is
   smoothed by a centred local quadratic fit over a window that grows with the noise (:func:`window_for`);
3. frames not seen (``visible`` false or null values) and the rows between frames of a subsampled track are
   filled by linear interpolation; rows before the first or after the last seen frame hold the nearest value;
4. velocities are the track's own if it gives them; otherwise each row's velocity comes from a local quadratic
   fit over the ``w`` rows *ending* at that row (the rows starting at it for the first rows), corrected for
   the engine's integrator: pymunk advances a frame in ``n`` sub-steps, each moving the position with the
   current velocity and then accelerating (x += v dt; v += a dt), so under a constant acceleration ``a`` the
   velocity at row r is ``p'(r) - (c - 1/2) a h`` with ``c = (n-1)/(2n)`` and ``h = 1/60 s``, exact for free
   flight; ``n`` follows the engine's sub-step rule for the fastest body of the previous frame. Windows end at
   the row because a body's velocity just before something happens to it is what a re-simulation needs;
5. a noisy track's last state is judged by the slope of a straight line over its last :data:`END_ROWS` rows;
6. row 0, the initial state, is never in a video: it is extrapolated here (constant acceleration) and fitted by
   :mod:`craft_dsl.perception.fit`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..physics.pymunk_engine import PymunkEngine
from ..vocabulary import MOVING_THRESHOLD
from ..world import INITIAL_ANGLE, STEPS_PER_SECOND
from .coords import frame_rows, metres_per_pixel, to_metres
from .schema import PerceivedScene, Track

#: Tracks whose estimated position noise is below this (pixels) are treated as exact.
EXACT_SIGMA_PX = 0.02
#: Sub-steps per frame assumed by the integrator correction (the pymunk engine's minimum).
ASSUMED_SUBSTEPS = 8
_H = 1.0 / STEPS_PER_SECOND
#: x(r+1) = x(r) + h v(r) + C h^2 a over one frame of sub-stepped integration.
INTEGRATOR_C = (ASSUMED_SUBSTEPS - 1) / (2 * ASSUMED_SUBSTEPS)
_C = INTEGRATOR_C


def window_for(sigma_px: float) -> int:
    """Rows of the local quadratic fits: 3 for an exact track, else odd 8 sigma + 5 (at most 41)."""
    if sigma_px < EXACT_SIGMA_PX:
        return 3
    w = int(round(8 * sigma_px + 5))
    w += 1 - w % 2
    return max(5, min(41, w))


@dataclass(frozen=True)
class Motion:
    """One object's motion at the simulator's step rate: row r is the state after r steps."""

    positions: np.ndarray  # [T+1, 2] metres
    angles: np.ndarray  # [T+1] radians
    velocities: np.ndarray  # [T+1, 2] m/s
    angular_velocities: np.ndarray  # [T+1] rad/s
    sigma_px: float  # estimated position noise of the track (pixels; 0 = exact)
    velocity_sigma: float  # standard deviation of an estimated velocity component (m/s; 0 = exact)
    given_velocities: bool
    has_angle: bool
    end_velocity: np.ndarray  # [2] the velocity the last state is judged by (m/s)
    end_velocity_sigma: float  # its standard deviation per component (m/s; 0 = exact)

    @property
    def steps(self) -> int:
        return int(self.positions.shape[0]) - 1


# -- local quadratic fits -----------------------------------------------------------------------------------


@lru_cache(maxsize=64)
def _quadratic_operators(w: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For a window of ``w`` samples: rows j give the value, first and second derivative (per sample step) at
    sample j of the least-squares quadratic through the window. Shapes [w, w]."""
    t = np.arange(w, dtype=np.float64)
    design = np.stack([np.ones(w), t, t * t], axis=1)
    pinv = np.linalg.pinv(design)  # [3, w]
    value = np.stack([np.array([1.0, j, j * j]) @ pinv for j in range(w)])
    first = np.stack([np.array([0.0, 1.0, 2.0 * j]) @ pinv for j in range(w)])
    second = np.stack([np.array([0.0, 0.0, 2.0]) @ pinv for _ in range(w)])
    return value, first, second


def _windows(values: np.ndarray, w: int) -> np.ndarray:
    """Sliding windows [n - w + 1, w, ...] over axis 0."""
    view = np.lib.stride_tricks.sliding_window_view(values, w, axis=0)  # [n-w+1, ..., w]
    return np.moveaxis(view, -1, 1)


def smooth(values: np.ndarray, w: int) -> np.ndarray:
    """Centred local quadratic smoothing over ``w`` samples (one-sided at the ends); identity for w <= 3."""
    n = values.shape[0]
    if w <= 3 or n < w:
        return values.copy()
    value, _, _ = _quadratic_operators(w)
    out = np.empty_like(values)
    win = _windows(values, w)
    half = w // 2
    out[half:n - half] = np.einsum("j,kj...->k...", value[half], win)
    out[:half] = np.einsum("ij,j...->i...", value[:half], values[:w])
    out[n - half:] = np.einsum("ij,j...->i...", value[half + 1:], values[n - w:])
    return out


def estimate_rates(values: np.ndarray, w: int, c: float | np.ndarray = INTEGRATOR_C) -> np.ndarray:
    """Per-row rate of change (per second) of ``values`` [n, ...] sampled every step, from the local quadratic over
    the ``w`` rows ending at each row (starting at it for the first ``w - 1`` rows), corrected for an integrator
    with constant ``c`` (a number, or one per row; 1/2 means no correction; see the module docstring)."""
    n = values.shape[0]
    if n < 3:
        return np.zeros_like(values)
    w = min(w, n)
    _, first, second = _quadratic_operators(w)
    slope = np.empty_like(values)
    curvature = np.empty_like(values)
    slope[w - 1:] = np.einsum("j,kj...->k...", first[w - 1], _windows(values, w))
    curvature[w - 1:] = np.einsum("j,kj...->k...", second[w - 1], _windows(values, w))
    slope[: w - 1] = np.einsum("ij,j...->i...", first[: w - 1], values[:w])
    curvature[: w - 1] = np.einsum("ij,j...->i...", second[: w - 1], values[:w])
    correction = np.asarray(c, dtype=np.float64) - 0.5
    if correction.ndim:
        correction = correction.reshape((n,) + (1,) * (values.ndim - 1))
    return (slope - correction * curvature) / _H


def rate_sigma(sigma: float, w: int) -> float:
    """Standard deviation of :func:`estimate_rates` at a row, for independent noise ``sigma`` per sample."""
    if sigma <= 0:
        return 0.0
    _, first, second = _quadratic_operators(w)
    op = first[w - 1] - (_C - 0.5) * second[w - 1]
    return float(sigma * np.sqrt(np.sum(op * op)) / _H)


def integrator_constants(max_speed: np.ndarray) -> np.ndarray:
    """Per row r >= 1: the integrator constant of frame r - 1, from the fastest body's speed at row r - 1 by the
    pymunk engine's sub-step rule (at least 8 sub-steps, more so that nothing moves 0.03 m per sub-step)."""
    engine = _default_engine()
    out = np.full(max_speed.shape, _C)
    for r in range(1, max_speed.size):
        n = engine.substeps_for(float(max_speed[r - 1]) ** 2, STEPS_PER_SECOND)
        out[r] = (n - 1) / (2 * n)
    return out


@lru_cache(maxsize=1)
def _default_engine() -> PymunkEngine:
    return PymunkEngine()


# -- noise ---------------------------------------------------------------------------------------------------


def second_differences(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Second differences of ``values`` [n] over consecutive valid samples."""
    ok = valid[2:] & valid[1:-1] & valid[:-2]
    d2 = values[2:] - 2 * values[1:-1] + values[:-2]
    return d2[ok]


def noise_sigma(d2: np.ndarray) -> float:
    """Robust noise estimate from second differences (noise adds variance 6 sigma^2 to them)."""
    if d2.size < 5:
        return 0.0
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return mad / 0.6745 / math.sqrt(6.0)


def track_noise_px(track: Track) -> float:
    """Estimated position noise of a track (pixels)."""
    x, y, valid = _xy(track)
    return noise_sigma(np.concatenate([second_differences(x, valid), second_differences(y, valid)]))


# -- tracks to motion -----------------------------------------------------------------------------------------


def _column(values: list[float | None] | None, n: int) -> tuple[np.ndarray, np.ndarray]:
    if values is None:
        return np.zeros(n), np.zeros(n, dtype=bool)
    arr = np.array([np.nan if v is None else v for v in values], dtype=np.float64)
    ok = np.isfinite(arr)
    return np.where(ok, arr, 0.0), ok


def _xy(track: Track) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = track.length
    x, okx = _column(track.x, n)
    y, oky = _column(track.y, n)
    visible = np.array(track.visible, dtype=bool) if track.visible is not None else np.ones(n, dtype=bool)
    return x, y, okx & oky & visible


def _fill(rows: np.ndarray, values: np.ndarray, valid: np.ndarray, steps: int) -> np.ndarray:
    """Values at rows 1..steps (index 0 = row 1): linear interpolation between valid samples, held at the ends."""
    target = np.arange(1, steps + 1, dtype=np.float64)
    src = rows[valid].astype(np.float64)
    if values.ndim == 1:
        return np.interp(target, src, values[valid])
    return np.stack([np.interp(target, src, values[valid, d]) for d in range(values.shape[1])], axis=1)


def _prepend_row_zero(values: np.ndarray, order: int) -> np.ndarray:
    """Prepend row 0 by extrapolation from rows 1.. (order 2: constant acceleration; 1: constant rate)."""
    if order == 2 and len(values) >= 3:
        first = 3 * values[0] - 3 * values[1] + values[2]
    elif len(values) >= 2:
        first = 2 * values[0] - values[1]
    else:
        first = values[0]
    return np.concatenate([first[None], values])


@dataclass(frozen=True)
class _TrackRows:
    """A track at rows 1..steps (index 0 = row 1), before velocities are estimated."""

    positions: np.ndarray
    angles: np.ndarray
    velocities: np.ndarray | None
    angular_velocities: np.ndarray | None
    sigma_px: float
    window: int
    has_angle: bool


def _track_rows(track: Track, scene: PerceivedScene) -> _TrackRows | None:
    steps = scene.steps
    size = scene.video.width
    fps = track.fps or scene.video.fps
    rows = frame_rows(steps, fps)
    px, py, valid = _xy(track)
    if not valid.any() or steps < 3:
        return None
    sigma_px = noise_sigma(np.concatenate([second_differences(px, valid), second_differences(py, valid)]))
    if sigma_px < EXACT_SIGMA_PX:
        sigma_px = 0.0
    w = window_for(sigma_px)
    mx, my = to_metres(px, py, size)
    xy = np.stack([mx, my], axis=1)
    angle_raw, ok_angle = _column(track.angle, track.length)
    ok_angle &= valid
    has_angle = bool(ok_angle.any())
    if has_angle:
        angle_raw[ok_angle] = np.unwrap(angle_raw[ok_angle])
    if w > 3:
        xy[valid] = smooth(xy[valid], w)
        if has_angle:
            angle_raw[ok_angle] = smooth(angle_raw[ok_angle], w)
    scale = metres_per_pixel(size)
    velocities = angular = None
    vx, okvx = _column(track.vx, track.length)
    vy, okvy = _column(track.vy, track.length)
    okv = okvx & okvy & valid
    if track.vx is not None and track.vy is not None and okv.any():
        velocities = _fill(rows, np.stack([vx * scale, -vy * scale], axis=1), okv, steps)
    av, okav = _column(track.angular_velocity, track.length)
    if track.angular_velocity is not None and (okav & valid).any():
        angular = _fill(rows, av, okav & valid, steps)
    return _TrackRows(
        positions=_fill(rows, xy, valid, steps),
        angles=_fill(rows, angle_raw, ok_angle, steps) if has_angle else np.full(steps, INITIAL_ANGLE),
        velocities=velocities, angular_velocities=angular, sigma_px=sigma_px, window=w, has_angle=has_angle)


def scene_motions(scene: PerceivedScene) -> dict[int, Motion]:
    """The motion of every object with a usable track (velocities estimated jointly: the integrator constant of
    a frame depends on the fastest body in it)."""
    rows = {}
    for obj in scene.objects:
        if obj.track is not None:
            tr = _track_rows(obj.track, scene)
            if tr is not None:
                rows[obj.id] = tr
    if not rows:
        return {}
    first_pass = {uid: tr.velocities if tr.velocities is not None else estimate_rates(tr.positions, tr.window)
                  for uid, tr in rows.items()}
    speed = np.max(np.stack([np.hypot(v[:, 0], v[:, 1]) for v in first_pass.values()]), axis=0)
    c = integrator_constants(np.concatenate([[speed[0]], speed]))[1:]
    scale = metres_per_pixel(scene.video.width)
    out = {}
    for uid, tr in rows.items():
        velocities = tr.velocities if tr.velocities is not None else estimate_rates(tr.positions, tr.window, c)
        angular = (tr.angular_velocities if tr.angular_velocities is not None
                   else estimate_rates(tr.angles, tr.window, c))
        end_velocity, end_sigma = _end_velocity(tr, velocities, scale)
        out[uid] = Motion(
            positions=_prepend_row_zero(tr.positions, 2),
            angles=_prepend_row_zero(tr.angles, 2),
            velocities=_prepend_row_zero(velocities, 1),
            angular_velocities=_prepend_row_zero(angular, 1),
            sigma_px=tr.sigma_px,
            velocity_sigma=0.0 if tr.velocities is not None else rate_sigma(tr.sigma_px * scale, tr.window),
            given_velocities=tr.velocities is not None,
            has_angle=tr.has_angle,
            end_velocity=end_velocity,
            end_velocity_sigma=end_sigma,
        )
    return out


#: Rows of the straight-line fit that judges whether a noisy track still moves at the end (half a second).
END_ROWS = 30


def _end_velocity(tr: _TrackRows, velocities: np.ndarray, scale: float) -> tuple[np.ndarray, float]:
    """Exact tracks: the last row's velocity. Noisy tracks (without given velocities): the slope of a straight line
    fitted to the last :data:`END_ROWS` rows, whose noise is far smaller than a single row's derivative."""
    if tr.velocities is not None or tr.sigma_px <= 0:
        return velocities[-1].copy(), 0.0
    n = min(END_ROWS, tr.positions.shape[0])
    t = np.arange(n, dtype=np.float64) / STEPS_PER_SECOND
    t -= t.mean()
    tail = tr.positions[-n:]
    slope = (t @ (tail - tail.mean(axis=0))) / float(t @ t)
    sigma = tr.sigma_px * scale / math.sqrt(float(t @ t))
    return slope, sigma


# -- moving or not --------------------------------------------------------------------------------------------

#: Prior probability that a body is at rest, and the spread (m/s) of the velocities of moving bodies, used to
#: decide "moving" from a velocity estimate whose noise is far above the 0.001 m/s threshold.
REST_PRIOR = 0.5
MOVING_SPEED_SCALE = 2.0


def moving_probability(velocity: np.ndarray, sigma: float) -> float:
    """P(|vx| > 0.001 or |vy| > 0.001 m/s) given a velocity estimate with per-component noise ``sigma`` (m/s).

    Exact estimates (``sigma`` below a third of the threshold) decide by the threshold itself. Otherwise a body is
    at rest (velocity 0, prior :data:`REST_PRIOR`) or moving (velocity ~ N(0, MOVING_SPEED_SCALE^2) per
    component), and the probability is the posterior of moving given the estimate.
    """
    vx, vy = float(velocity[0]), float(velocity[1])
    if sigma < MOVING_THRESHOLD / 3:
        return 1.0 if abs(vx) > MOVING_THRESHOLD or abs(vy) > MOVING_THRESHOLD else 0.0
    r2 = vx * vx + vy * vy
    s_rest = sigma * sigma
    s_move = s_rest + MOVING_SPEED_SCALE ** 2
    log_rest = math.log(REST_PRIOR) - math.log(s_rest) - r2 / (2 * s_rest)
    log_move = math.log(1 - REST_PRIOR) - math.log(s_move) - r2 / (2 * s_move)
    top = max(log_rest, log_move)
    return math.exp(log_move - top) / (math.exp(log_rest - top) + math.exp(log_move - top))
