"""RGB frames -> YUV 4:2:0 planes (what MPEG-1 and H.264 encode), converting only what changed.

The conversion is ITU-R BT.601, limited range, in exact integer arithmetic (the same bytes on every
machine)::

    Y = ((66 R + 129 G + 25 B + 128) >> 8) + 16
    U = ((-38 R - 74 G + 112 B + 128) >> 8) + 128      (R, G, B: the mean of each 2 x 2 block)
    V = ((112 R - 94 G - 18 B + 128) >> 8) + 128

A video's frames differ from the previous frame only where a moving body was or is, so each frame is
converted tile by tile (8 x 8 pixels, 4 x 4 chroma samples) and only the tiles marked as changed are
converted again; the result is the same, byte for byte, as converting every frame whole
(:func:`rgb_to_yuv420`), at a fraction of the cost.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

from ..simulation import Simulation
from .raster import CHUNK, DEFAULT_SIZE, SIM_FPS, PaintedWindows, RenderError, _live, frame_steps, render_states

#: Tile side in pixels (a multiple of 2: each tile holds whole chroma samples).
TILE = 8


def _luma(r: np.ndarray, g: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Y of uint16 R, G, B (the sum stays below 2**16)."""
    y = r * np.uint16(66)
    y += g * np.uint16(129)
    y += b * np.uint16(25)
    y += np.uint16(128)
    y >>= 8
    y += np.uint16(16)
    return y.astype(np.uint8)


def _chroma(r: np.ndarray, g: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """U and V from int32 sums of 2 x 2 blocks (four times the mean; hence the shift by 10 and the rounding 512)."""
    u = ((-38 * r - 74 * g + 112 * b + 512) >> 10) + 128
    v = ((112 * r - 94 * g - 18 * b + 512) >> 10) + 128
    return u.astype(np.uint8), v.astype(np.uint8)


def _convert(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Y [..., h, w] and U, V [..., h/2, w/2] of uint8 RGB [..., h, w, 3] with even h and w."""
    x = rgb.astype(np.uint16)
    y = _luma(x[..., 0], x[..., 1], x[..., 2])
    s = x[..., ::2, ::2, :] + x[..., 1::2, ::2, :]
    s += x[..., ::2, 1::2, :]
    s += x[..., 1::2, 1::2, :]
    s32 = s.astype(np.int32)
    u, v = _chroma(s32[..., 0], s32[..., 1], s32[..., 2])
    return y, u, v


def rgb_to_yuv420(frame: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Y [H, W] and U, V [H/2, W/2] planes of one uint8 RGB frame [H, W, 3] (H and W even)."""
    check_frame_size(frame.shape[0], frame.shape[1])
    return _convert(np.asarray(frame, dtype=np.uint8))


def check_frame_size(height: int, width: int) -> None:
    if height % 2 or width % 2 or height < 2 or width < 2:
        raise RenderError(f"a YUV 4:2:0 video needs an even frame size, got {width} x {height} pixels")


def tile_for(height: int, width: int) -> int:
    """The tile side used for frames of this size: :data:`TILE`, or 2 where the size is no multiple of it."""
    check_frame_size(height, width)
    return TILE if height % TILE == 0 and width % TILE == 0 else 2


def changed_tiles(frames: np.ndarray, previous: np.ndarray | None, tile: int) -> np.ndarray:
    """Which tiles of each frame differ from the frame before: bool [n, H/tile, W/tile] (all of the first
    frame when there is no ``previous``)."""
    n, h, w, _ = frames.shape
    out = np.empty((n, h // tile, w // tile), dtype=bool)
    if n == 0:
        return out

    def grid(diff: np.ndarray) -> np.ndarray:
        return np.asarray(diff.reshape(-1, h // tile, tile, w // tile, tile * 3).any(axis=(2, 4)))

    out[0] = True if previous is None else grid(frames[0] != previous)[0]
    out[1:] = grid(frames[1:] != frames[:-1])
    return out


class Yuv420Canvas:
    """The planes of the current frame, one contiguous uint8 buffer [H * 3 / 2, W] (Y, then U, then V: the
    layout of a ``yuv420p`` frame), updated tile by tile."""

    def __init__(self, height: int, width: int) -> None:
        self.tile = tile = tile_for(height, width)
        self.height, self.width = height, width
        self.buffer = np.zeros((height * 3 // 2, width), dtype=np.uint8)
        c = tile // 2
        ty, tx = height // tile, width // tile
        flat = self.buffer.reshape(-1)
        y = flat[: height * width].reshape(height, width)
        u = flat[height * width: height * width * 5 // 4].reshape(height // 2, width // 2)
        v = flat[height * width * 5 // 4:].reshape(height // 2, width // 2)
        # tile views: [tile row, pixel row, tile column, pixel column]
        self._y = y.reshape(ty, tile, tx, tile)
        self._u = u.reshape(ty, c, tx, c)
        self._v = v.reshape(ty, c, tx, c)

    def frames(self, rgb: np.ndarray, changed: np.ndarray) -> Iterator[np.ndarray]:
        """For each frame of ``rgb`` [n, H, W, 3], convert its ``changed`` tiles [n, H/tile, W/tile] into the
        canvas and yield :attr:`buffer` (the same array each time: use it before asking for the next)."""
        n, h, w, _ = rgb.shape
        if (h, w) != (self.height, self.width):
            raise RenderError(f"frames of {w} x {h} pixels for a {self.width} x {self.height} video")
        tile = self.tile
        k, ty, tx = np.nonzero(changed)
        tiles = rgb.reshape(n, h // tile, tile, w // tile, tile, 3)[k, ty, :, tx, :, :]  # [K, tile, tile, 3]
        y, u, v = _convert(tiles)
        starts = np.searchsorted(k, np.arange(n + 1)).tolist()
        for i in range(n):
            a, b = starts[i], starts[i + 1]
            if b > a:
                rows, cols = ty[a:b], tx[a:b]
                self._y[rows, :, cols, :] = y[a:b]
                self._u[rows, :, cols, :] = u[a:b]
                self._v[rows, :, cols, :] = v[a:b]
            yield self.buffer


#: A body's last painted window (visible, x0, y0, centre x, centre y, angle), carried from chunk to chunk.
_Last = tuple[bool, int, int, float, float, float]


def window_changes(windows: Sequence[PaintedWindows], n: int, last: list[_Last] | None, size: int,
                   tile: int) -> tuple[np.ndarray, list[_Last]]:
    """The tiles of a chunk of ``n`` rendered frames that differ from the frame before, from where the bodies
    were painted: a body whose window or state changed dirties the tiles under its old and its new window
    (every other pixel is the previous frame's). ``last``: each body's window in the frame before the chunk
    (None for a video's first chunk, whose first frame is then all changed). Returns bool [n, size/tile,
    size/tile] and the bodies' windows in the chunk's last frame."""
    nt = size // tile
    out = np.zeros((n, nt, nt), dtype=bool)
    carried: list[_Last] = []
    for b, win in enumerate(windows):
        vis = np.zeros(n + 1, dtype=bool)
        x0 = np.zeros(n + 1, dtype=np.int64)
        y0 = np.zeros(n + 1, dtype=np.int64)
        st = np.zeros((n + 1, 3))
        if last is not None:
            vis[0], x0[0], y0[0], st[0, 0], st[0, 1], st[0, 2] = last[b]
        at = win.frames + 1
        vis[at], x0[at], y0[at], st[at] = True, win.x0, win.y0, win.states
        moved = (x0[1:] != x0[:-1]) | (y0[1:] != y0[:-1]) | (st[1:] != st[:-1]).any(axis=1)
        changed = (vis[1:] != vis[:-1]) | (vis[1:] & moved)
        w = win.side
        for when, shift in ((changed & vis[1:], 1), (changed & vis[:-1], 0)):
            k = np.nonzero(when)[0]
            if k.size == 0:
                continue
            xa, ya = x0[k + shift], y0[k + shift]
            tx0, ty0 = xa // tile, ya // tile
            tx1 = np.minimum((xa + w - 1) // tile, nt - 1)
            ty1 = np.minimum((ya + w - 1) // tile, nt - 1)
            span = (w + tile - 1) // tile + 1
            for dy in range(span):
                for dx in range(span):
                    ok = (ty0 + dy <= ty1) & (tx0 + dx <= tx1)
                    out[k[ok], ty0[ok] + dy, tx0[ok] + dx] = True
        carried.append((bool(vis[n]), int(x0[n]), int(y0[n]), float(st[n, 0]), float(st[n, 1]), float(st[n, 2])))
    if last is None and n:
        out[0] = True
    return out, carried


def iter_yuv420(sim: Simulation, fps: float = SIM_FPS, size: int = DEFAULT_SIZE,
                chunk: int = CHUNK) -> Iterator[np.ndarray]:
    """The frames of ``sim`` as yuv420p buffers [size * 3 / 2, size] (see :class:`Yuv420Canvas`; the same
    array each time), the same bytes as converting each frame of :func:`~craft_dsl.render.iter_frames`
    whole, converting only the tiles that moving bodies changed."""
    world, traj = _live(sim)
    rows = frame_steps(traj.steps, fps, world.steps_per_second)
    canvas = Yuv420Canvas(size, size)
    last: list[_Last] | None = None
    for start in range(0, rows.size, chunk):
        windows: list[PaintedWindows] = []
        rgb = render_states(world, traj, rows[start:start + chunk], size, windows=windows)
        changed, last = window_changes(windows, rgb.shape[0], last, size, canvas.tile)
        yield from canvas.frames(rgb, changed)


__all__ = ["TILE", "Yuv420Canvas", "changed_tiles", "check_frame_size", "iter_yuv420", "rgb_to_yuv420", "tile_for",
           "window_changes"]
