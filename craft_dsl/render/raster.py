"""Pure-numpy rasteriser reproducing the look of the original CRAFT videos.

Every shape is drawn from a signed distance (metres, negative inside) turned into pixel coverage by
``clamp(0.5 - d * px_per_m)``, which antialiases an edge over one pixel. The static layer (walls, ground,
platforms, ramps, static balls, the basket) is drawn once per scene at 4x supersampling, so the basket's
0.1 m (half-pixel) outline comes out as a faint grey line; it is cached per static layout. Dynamic bodies
are drawn per frame inside a small window around each body, vectorised over a chunk of frames.

Draw order follows the original's "first drawn wins" depth test: statics first (in creation order, the
basket sensor over the basket outline), then dynamic bodies from the earliest created (largest uid) to
the latest (uid 0), so later-created bodies cover earlier ones.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import CraftError
from ..simulation import Simulation, Trajectory
from ..vocabulary import COLOR_RGB
from ..world import BodySpec, Geometry, WorldSpec

#: Visible world: x in [X_MIN, X_MIN + VIEW_SIZE], y in [Y_MAX - VIEW_SIZE, Y_MAX] (metres).
X_MIN = -25.0
Y_MAX = 45.0
VIEW_SIZE = 50.0
DEFAULT_SIZE = 256
#: Simulation steps per second: one frame per step at 60 fps.
SIM_FPS = 60

BACKGROUND = (255, 255, 255)
SENSOR_GREY = (229, 229, 229)
#: The basket's chain edges are drawn as strips this wide (metres).
BASKET_LINE_WIDTH = 0.1
#: Eyes: centres in the body's local frame, sclera and pupil radii (metres).
EYE_CENTRES: tuple[tuple[float, float], ...] = ((-0.45, -0.45), (0.45, -0.45))
SCLERA_RADIUS = 0.45
PUPIL_RADIUS = 0.22
#: Supersampling factor of the (once per scene) static layer.
STATIC_SUPERSAMPLE = 4
#: Frames rasterised together in :func:`iter_frames`.
CHUNK = 120


class RenderError(CraftError, ValueError):
    """A simulation or request the renderer cannot draw."""


def px_per_metre(size: int) -> float:
    return size / VIEW_SIZE


def world_to_pixel(x: float, y: float, size: int = DEFAULT_SIZE) -> tuple[float, float]:
    """Continuous pixel coordinates (column, row; row 0 at the top) of a world point."""
    s = px_per_metre(size)
    return (x - X_MIN) * s, (Y_MAX - y) * s


# -- shape distance functions ---------------------------------------------------------------------


@dataclass(frozen=True)
class _ConvexPolygon:
    """Edges as outward unit normals (nx, ny) and offsets c: signed distance = max(nx*x + ny*y - c)."""

    normals: np.ndarray  # [k, 2]
    offsets: np.ndarray  # [k]


def _convex(poly: Sequence[tuple[float, float]]) -> _ConvexPolygon:
    pts = np.asarray(poly, dtype=np.float64)
    if len(pts) < 3:
        raise RenderError(f"a polygon needs at least 3 vertices, got {len(pts)}")
    nxt = np.roll(pts, -1, axis=0)
    area2 = float(np.sum(pts[:, 0] * nxt[:, 1] - nxt[:, 0] * pts[:, 1]))
    d = nxt - pts
    normals = np.stack([d[:, 1], -d[:, 0]], axis=1)  # outward for counter-clockwise polygons
    if area2 < 0:
        normals = -normals
    lengths = np.hypot(normals[:, 0], normals[:, 1])
    keep = lengths > 1e-12
    normals = normals[keep] / lengths[keep, None]
    offsets = np.sum(normals * pts[keep], axis=1)
    return _ConvexPolygon(normals, offsets)


def _polygon_sd(poly: _ConvexPolygon, lx: np.ndarray, ly: np.ndarray) -> np.ndarray:
    out: np.ndarray | None = None
    for (nx, ny), c in zip(poly.normals.tolist(), poly.offsets.tolist(), strict=True):
        d = lx * np.float32(nx) + ly * np.float32(ny) - np.float32(c)
        out = d if out is None else np.maximum(out, d, out=out)
    assert out is not None
    return out


def _segment_sd(a: tuple[float, float], b: tuple[float, float], half_width: float,
                lx: np.ndarray, ly: np.ndarray) -> np.ndarray:
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    length2 = dx * dx + dy * dy
    px, py = lx - ax, ly - ay
    t = np.clip((px * dx + py * dy) / length2, 0.0, 1.0) if length2 > 0 else np.zeros_like(px)
    return np.hypot(px - t * dx, py - t * dy) - half_width


def _geometry_sd(geom: Geometry, lx: np.ndarray, ly: np.ndarray, line_half_width: float) -> np.ndarray | None:
    """Signed distance to the union of a body's solid parts (None if it has none)."""
    parts: list[np.ndarray] = [_polygon_sd(_convex(p), lx, ly) for p in geom.polygons]
    if geom.circle_radius is not None:
        parts.append(np.hypot(lx, ly) - geom.circle_radius)
    parts.extend(_segment_sd(a, b, line_half_width, lx, ly) for a, b in geom.segments)
    if not parts:
        return None
    out = parts[0]
    for p in parts[1:]:
        out = np.minimum(out, p)
    return out


def _coverage(sd: np.ndarray, ppm: float) -> np.ndarray:
    """Pixel coverage from a signed distance in metres (one pixel wide antialiasing ramp)."""
    cov = np.multiply(sd, -ppm, dtype=np.float32)
    cov += 0.5
    return np.clip(cov, 0.0, 1.0, out=cov)


def _extent(geom: Geometry) -> float:
    """Largest distance of any drawn point from the local origin (metres)."""
    r = 0.0
    pts: list[tuple[float, float]] = [p for poly in geom.polygons for p in poly]
    pts += [p for seg in geom.segments for p in seg]
    if geom.sensor is not None:
        pts += list(geom.sensor)
    for x, y in pts:
        r = max(r, math.hypot(x, y))
    if geom.circle_radius is not None:
        r = max(r, geom.circle_radius)
    return r + BASKET_LINE_WIDTH


def _rgb(color: str) -> np.ndarray:
    try:
        return np.asarray(COLOR_RGB[color], dtype=np.float32)
    except KeyError:
        raise RenderError(f"no RGB for colour {color!r}; known: {sorted(COLOR_RGB)}") from None


# -- static layer ---------------------------------------------------------------------------------


def _local_grid(x0: int, y0: int, w: int, h: int, ss: int, size: int, position: tuple[float, float],
                angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Local-frame coordinates of the sample centres of a pixel window (ss x ss samples per pixel)."""
    ppm = px_per_metre(size)
    cols = x0 + (np.arange(w * ss, dtype=np.float64) + 0.5) / ss
    rows = y0 + (np.arange(h * ss, dtype=np.float64) + 0.5) / ss
    wx = cols / ppm + X_MIN - position[0]
    wy = Y_MAX - rows / ppm - position[1]
    c, s = math.cos(angle), math.sin(angle)
    # rotate by -angle: local = R(-a) @ world-offset
    lx = c * wx[None, :] + s * wy[:, None]
    ly = -s * wx[None, :] + c * wy[:, None]
    return lx.astype(np.float32), ly.astype(np.float32)


def static_body_layers(body: BodySpec, size: int = DEFAULT_SIZE
                       ) -> tuple[tuple[int, int], list[tuple[np.ndarray, np.ndarray]]]:
    """How the static layer draws one body: the (row, column) of its pixel window and, in drawing order, each
    layer's coverage [h, w] (float32 in [0, 1]) with its RGB (the solid parts, then the basket's sensor). Painting a
    layer is ``img = img * (1 - coverage) + coverage * rgb``. No layer when the body is outside the frame."""
    geom = body.geometry
    ppm = px_per_metre(size)
    ss = STATIC_SUPERSAMPLE
    # bounding window of the body's drawn parts, in pixels
    (wx0, wy0), (wx1, wy1) = _world_bounds(body)
    px0, py1 = world_to_pixel(wx0, wy0, size)
    px1, py0 = world_to_pixel(wx1, wy1, size)
    x0 = max(0, int(math.floor(px0)) - 2)
    y0 = max(0, int(math.floor(py0)) - 2)
    x1 = min(size, int(math.ceil(px1)) + 2)
    y1 = min(size, int(math.ceil(py1)) + 2)
    if x1 <= x0 or y1 <= y0:
        return (y0, x0), []
    w, h = x1 - x0, y1 - y0
    lx, ly = _local_grid(x0, y0, w, h, ss, size, body.position, body.angle)
    layers: list[tuple[np.ndarray, np.ndarray]] = []
    sd = _geometry_sd(geom, lx, ly, BASKET_LINE_WIDTH / 2)
    if sd is not None:
        layers.append((sd, _rgb(body.color)))
    if geom.sensor is not None:
        layers.append((_polygon_sd(_convex(geom.sensor), lx, ly), np.asarray(SENSOR_GREY, np.float32)))
    return (y0, x0), [(_coverage(sd_layer, ppm * ss).reshape(h, ss, w, ss).mean(axis=(1, 3)), rgb)
                      for sd_layer, rgb in layers]


def _paint_static(img: np.ndarray, body: BodySpec, size: int) -> None:
    (y0, x0), layers = static_body_layers(body, size)
    for cov, rgb in layers:
        h, w = cov.shape
        region = img[y0:y0 + h, x0:x0 + w]
        region *= 1.0 - cov[..., None]
        region += cov[..., None] * rgb


def _world_bounds(body: BodySpec) -> tuple[tuple[float, float], tuple[float, float]]:
    """World-space bounding box (min corner, max corner) of everything drawn for a body."""
    geom = body.geometry
    c, s = math.cos(body.angle), math.sin(body.angle)
    px, py = body.position
    pad = geom.segment_radius + BASKET_LINE_WIDTH if geom.segments else 0.0
    pts = [p for poly in geom.polygons for p in poly] + [p for seg in geom.segments for p in seg]
    if geom.sensor is not None:
        pts += list(geom.sensor)
    if geom.circle_radius is not None:
        r = geom.circle_radius
        pts += [(-r, -r), (r, r), (-r, r), (r, -r)]
    xs = [px + c * x - s * y for x, y in pts]
    ys = [py + s * x + c * y for x, y in pts]
    return (min(xs) - pad, min(ys) - pad), (max(xs) + pad, max(ys) + pad)


def _static_key(world: WorldSpec) -> tuple[BodySpec, ...]:
    return tuple(b for b in world.bodies if not b.dynamic)


@lru_cache(maxsize=16)
def _static_layer_cached(statics: tuple[BodySpec, ...], size: int) -> np.ndarray:
    img = np.empty((size, size, 3), dtype=np.float32)
    img[:] = np.asarray(BACKGROUND, dtype=np.float32)
    for body in statics:  # creation order: later-created statics cover earlier ones
        _paint_static(img, body, size)
    out = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    out.setflags(write=False)
    return out


def static_layer(world: WorldSpec, size: int = DEFAULT_SIZE) -> np.ndarray:
    """The background with every static body drawn, uint8 [size, size, 3] (read-only, cached)."""
    return _static_layer_cached(_static_key(world), size)


# -- dynamic bodies -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _DynamicSprite:
    column: int  # trajectory column
    rgb: np.ndarray
    window: int  # square window side (pixels)
    polygons: tuple[_ConvexPolygon, ...]
    circle_radius: float | None


def _sprites(world: WorldSpec, traj: Trajectory, size: int) -> list[_DynamicSprite]:
    ppm = px_per_metre(size)
    out = []
    # earliest created (largest uid) first, so later-created bodies are painted over it
    for body in sorted((b for b in world.bodies if b.dynamic), key=lambda b: -b.uid):
        if body.uid not in traj.ids:
            raise RenderError(
                f"dynamic body {body.uid} ({body.size} {body.color} {body.shape}) has no column in the "
                f"trajectory (trajectory ids: {list(traj.ids)})"
            )
        geom = body.geometry
        window = min(size, int(math.ceil(2 * _extent(geom) * ppm)) + 3)
        out.append(_DynamicSprite(traj.column(body.uid), _rgb(body.color), window,
                                  tuple(_convex(p) for p in geom.polygons), geom.circle_radius))
    return out


@dataclass(frozen=True)
class PaintedWindows:
    """Where one dynamic body was painted in a chunk of frames: the frames it is visible in (``frames``,
    indices into the chunk), the top-left pixel of its square window there (``x0``, ``y0``), the window's
    side and the body's pixel state (centre x, centre y, angle) [len(frames), 3]. Pixels outside a body's
    windows are not touched by it; equal states paint equal windows."""

    frames: np.ndarray
    x0: np.ndarray
    y0: np.ndarray
    side: int
    states: np.ndarray


def _paint_dynamic(buf: np.ndarray, sprite: _DynamicSprite, pos: np.ndarray, ang: np.ndarray,
                   size: int) -> PaintedWindows:
    """Paint one body into frames ``buf`` [n, size, size, 3] uint8 at states pos [n, 2], ang [n]."""
    n = buf.shape[0]
    ppm = px_per_metre(size)
    w = sprite.window
    cx = (pos[:, 0] - X_MIN) * ppm
    cy = (Y_MAX - pos[:, 1]) * ppm
    # window origin, clamped into the frame (it then still covers every visible pixel of the body)
    x0 = np.clip(np.floor(cx - w / 2).astype(np.int64), 0, size - w)
    y0 = np.clip(np.floor(cy - w / 2).astype(np.int64), 0, size - w)
    r = (w / 2 + 2) / ppm
    visible = (cx + r * ppm > 0) & (cx - r * ppm < size) & (cy + r * ppm > 0) & (cy - r * ppm < size)
    if not visible.any():
        empty = np.zeros(0, dtype=np.int64)
        return PaintedWindows(empty, empty, empty, w, np.zeros((0, 3)))
    if not visible.all():
        idx = np.nonzero(visible)[0]
        x0, y0, cx, cy, ang = x0[idx], y0[idx], cx[idx], cy[idx], ang[idx]
    else:
        idx = np.arange(n)
    # A body at rest repeats its state frame after frame: shade each distinct state once.
    states = np.stack([cx, cy, ang], axis=1)
    uniq, inverse = np.unique(states, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    if len(uniq) < len(states):
        first = np.zeros(len(uniq), dtype=np.int64)
        first[inverse[::-1]] = np.arange(len(states))[::-1]
        alpha, base = _shade(sprite, x0[first], y0[first], cx[first], cy[first], ang[first], w, ppm)
        alpha, base = alpha[inverse], base[inverse]
    else:
        alpha, base = _shade(sprite, x0, y0, cx, cy, ang, w, ppm)
    # composite each frame's window in place: dst * (1 - alpha) + premultiplied colour
    keep = 1.0 - alpha[..., None]
    base += 0.5
    for k, frame_index in enumerate(idx.tolist()):
        ya, xa = int(y0[k]), int(x0[k])
        window = buf[frame_index, ya:ya + w, xa:xa + w]
        window[...] = window * keep[k] + base[k]
    return PaintedWindows(idx, x0, y0, w, states)


def _shade(sprite: _DynamicSprite, x0: np.ndarray, y0: np.ndarray, cx: np.ndarray, cy: np.ndarray,
           ang: np.ndarray, w: int, ppm: float) -> tuple[np.ndarray, np.ndarray]:
    """Coverage [m, w, w] and premultiplied colour [m, w, w, 3] of a body in its pixel windows."""
    ramp = np.arange(w, dtype=np.float32) + np.float32(0.5)
    # pixel-centre offsets from the body centre, in metres (world axes; y up)
    dx = ((x0 - cx).astype(np.float32)[:, None] + ramp[None, :]) / np.float32(ppm)  # [m, w]
    dy = ((cy - y0).astype(np.float32)[:, None] - ramp[None, :]) / np.float32(ppm)  # [m, w]
    c = np.cos(ang).astype(np.float32)[:, None, None]
    s = np.sin(ang).astype(np.float32)[:, None, None]
    dxx, dyy = dx[:, None, :], dy[:, :, None]
    lx = c * dxx + s * dyy  # [m, w, w]
    ly = c * dyy - s * dxx
    if sprite.circle_radius is not None:
        sd = np.sqrt(lx * lx + ly * ly)
        sd -= np.float32(sprite.circle_radius)
        for poly in sprite.polygons:
            sd = np.minimum(sd, _polygon_sd(poly, lx, ly))
    else:
        sd = _polygon_sd(sprite.polygons[0], lx, ly)
        for poly in sprite.polygons[1:]:
            sd = np.minimum(sd, _polygon_sd(poly, lx, ly))
    alpha = _coverage(sd, ppm)
    # eyes: distance to the nearer eye centre
    ex, ey = EYE_CENTRES[0]
    ex_d = np.abs(lx)
    ex_d -= np.float32(abs(ex))
    ey_d = ly - np.float32(ey)
    ex_d *= ex_d
    ey_d *= ey_d
    ex_d += ey_d
    eye_d = np.sqrt(ex_d, out=ex_d)
    sclera = _coverage(eye_d - np.float32(SCLERA_RADIUS), ppm)
    eye_d -= np.float32(PUPIL_RADIUS)
    pupil = _coverage(eye_d, ppm)
    # body colour with white sclera and black pupil, clipped to the body (premultiplied by alpha)
    rgb = sprite.rgb.astype(np.float32)
    base = sclera[..., None] * (np.float32(255.0) - rgb) + rgb
    pupil -= np.float32(1.0)
    pupil *= -alpha  # (1 - pupil) * alpha
    base *= pupil[..., None]
    return alpha, base


def shade_body(geometry: Geometry, color: str, cx: np.ndarray, cy: np.ndarray, angle: np.ndarray, x0: np.ndarray,
               y0: np.ndarray, window: int, size: int = DEFAULT_SIZE) -> tuple[np.ndarray, np.ndarray]:
    """How the renderer draws a dynamic body in pixel windows: coverage [n, w, w] and premultiplied colour
    [n, w, w, 3] (float32) of a body with centre (``cx``, ``cy``) in pixels and ``angle``, in the windows whose
    top-left pixels are (``x0``, ``y0``) (arrays of n). A frame's window is then ``dst * (1 - coverage) + colour``."""
    sprite = _DynamicSprite(0, _rgb(color), window, tuple(_convex(p) for p in geometry.polygons),
                            geometry.circle_radius)
    return _shade(sprite, np.asarray(x0), np.asarray(y0), np.asarray(cx, dtype=np.float64),
                  np.asarray(cy, dtype=np.float64), np.asarray(angle, dtype=np.float64), window, px_per_metre(size))


# -- frames ---------------------------------------------------------------------------------------


def _live(sim: Simulation) -> tuple[WorldSpec, Trajectory]:
    world, traj = getattr(sim, "world", None), getattr(sim, "trajectory", None)
    if world is None or traj is None:
        missing = " and ".join(n for n, v in (("trajectory", traj), ("world", world)) if v is None)
        raise RenderError(
            f"cannot render: this simulation has no {missing}. Rendering needs a live simulation "
            "(e.g. craft_dsl.physics.simulate(scene, seed)); simulations loaded from recorded JSON files "
            "only keep start/end states and events."
        )
    if traj.positions.ndim != 3 or traj.positions.shape[1] != len(traj.ids):
        raise RenderError(f"trajectory positions have shape {traj.positions.shape}; expected [T+1, N, 2]")
    return world, traj


def frame_steps(steps: int, fps: float = SIM_FPS, sim_fps: int = SIM_FPS) -> np.ndarray:
    """Trajectory rows shown by the frames of a video at ``fps``.

    At 60 fps frame i (1-based) shows the state after i steps, as the original (no frame of the initial
    state). Lower rates show the nearest step to each frame time: every 2nd step at 30 fps, every 60/fps-th
    step whenever fps divides 60, so a run of ``steps`` steps gives ``floor(steps * fps / 60)`` frames.
    """
    if not isinstance(fps, int | float) or isinstance(fps, bool) or not math.isfinite(fps) or fps <= 0:
        raise RenderError(f"fps must be a positive number, got {fps!r}")
    if fps > sim_fps:
        raise RenderError(
            f"fps {fps} is above the simulation's {sim_fps} steps per second; the renderer draws at most "
            f"one frame per step (allowed: 0 < fps <= {sim_fps})"
        )
    if steps < 0:
        raise RenderError(f"steps must be >= 0, got {steps}")
    n = int(math.floor(steps * fps / sim_fps + 1e-9))
    k = np.arange(1, n + 1, dtype=np.float64)
    rows = np.floor(k * sim_fps / fps + 0.5 - 1e-9).astype(np.int64)
    return np.clip(rows, 1, max(steps, 1))


def render_states(world: WorldSpec, traj: Trajectory, rows: Sequence[int] | np.ndarray,
                  size: int = DEFAULT_SIZE, out: np.ndarray | None = None,
                  windows: list[PaintedWindows] | None = None) -> np.ndarray:
    """Frames uint8 [len(rows), size, size, 3] of the given trajectory rows (drawn into ``out`` if given);
    ``windows``, if given, receives where each dynamic body was painted, in painting order."""
    rows_a = np.asarray(rows, dtype=np.int64).reshape(-1)
    n_rows = traj.positions.shape[0]
    if rows_a.size and (rows_a.min() < 0 or rows_a.max() >= n_rows):
        bad = int(rows_a[(rows_a < 0) | (rows_a >= n_rows)][0])
        raise RenderError(f"step {bad} is out of range: the trajectory has states 0..{n_rows - 1}")
    if size < 8:
        raise RenderError(f"size must be at least 8 pixels, got {size}")
    background = static_layer(world, size)
    buf = np.empty((rows_a.size, size, size, 3), dtype=np.uint8) if out is None else out
    buf[:] = background
    if rows_a.size == 0:
        return buf
    positions = np.asarray(traj.positions, dtype=np.float64)
    angles = np.asarray(traj.angles, dtype=np.float64)
    for sprite in _sprites(world, traj, size):
        painted = _paint_dynamic(buf, sprite, positions[rows_a, sprite.column], angles[rows_a, sprite.column], size)
        if windows is not None:
            windows.append(painted)
    return buf


def iter_frames(sim: Simulation, fps: float = SIM_FPS, size: int = DEFAULT_SIZE,
                chunk: int = CHUNK) -> Iterator[np.ndarray]:
    """Yield the frames of ``sim`` one by one (uint8 [size, size, 3]), rendering ``chunk`` at a time."""
    world, traj = _live(sim)
    rows = frame_steps(traj.steps, fps, world.steps_per_second)
    for start in range(0, rows.size, chunk):
        yield from render_states(world, traj, rows[start:start + chunk], size)


def frame_count(sim: Simulation, fps: float = SIM_FPS) -> int:
    world, traj = _live(sim)
    return int(frame_steps(traj.steps, fps, world.steps_per_second).size)


def frames(sim: Simulation, fps: float = SIM_FPS, size: int = DEFAULT_SIZE) -> np.ndarray:
    """All frames of a live simulation, uint8 [T, size, size, 3]; frame i shows the state after
    ``(i + 1) * 60 / fps`` steps (no frame of the initial state, as the original)."""
    world, traj = _live(sim)
    rows = frame_steps(traj.steps, fps, world.steps_per_second)
    out = np.empty((rows.size, size, size, 3), dtype=np.uint8)
    for start in range(0, rows.size, CHUNK):
        render_states(world, traj, rows[start:start + CHUNK], size, out=out[start:start + CHUNK])
    return out


def frame(sim: Simulation, step: int, size: int = DEFAULT_SIZE) -> np.ndarray:
    """One frame, uint8 [size, size, 3], of the state after ``step`` steps (0 = initial state)."""
    world, traj = _live(sim)
    if isinstance(step, bool) or not isinstance(step, int | np.integer):
        raise RenderError(f"step must be an integer, got {step!r}")
    if not 0 <= step <= traj.steps:
        raise RenderError(f"step {step} is out of range: this simulation has states 0..{traj.steps}")
    return render_states(world, traj, [int(step)], size)[0]
