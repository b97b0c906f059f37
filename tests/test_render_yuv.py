"""YUV 4:2:0 conversion: exact BT.601 values, the tile-by-tile conversion equal to converting whole frames,
and videos that encode the same bytes from RGB frames and from a simulation."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from craft_dsl import Simulation
from craft_dsl.physics import simulate
from craft_dsl.render import RenderError, frames, iter_frames, write_frames, write_video
from craft_dsl.render.video import write_yuv420
from craft_dsl.render.yuv import Yuv420Canvas, changed_tiles, iter_yuv420, rgb_to_yuv420
from craft_dsl.world import WorldSpec, assign_uids, make_dynamic, make_static
from tests.synthetic_scene import simulation_from_rows


def planes(buffer: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    flat = buffer.reshape(-1)
    n = size * size
    return (flat[:n].reshape(size, size), flat[n:n * 5 // 4].reshape(size // 2, size // 2),
            flat[n * 5 // 4:].reshape(size // 2, size // 2))


def whole(frame: np.ndarray) -> np.ndarray:
    y, u, v = rgb_to_yuv420(frame)
    return np.concatenate([y.ravel(), u.ravel(), v.ravel()])


@pytest.mark.parametrize(("rgb", "yuv"), [
    ((255, 255, 255), (235, 128, 128)),
    ((0, 0, 0), (16, 128, 128)),
    ((255, 0, 0), (82, 90, 240)),
    ((0, 255, 0), (144, 54, 34)),
    ((0, 0, 255), (41, 240, 110)),
])
def test_bt601_limited_range_values(rgb: tuple[int, int, int], yuv: tuple[int, int, int]) -> None:
    y, u, v = rgb_to_yuv420(np.full((4, 6, 3), rgb, dtype=np.uint8))
    assert y.shape == (4, 6) and u.shape == v.shape == (2, 3)
    assert (int(y[0, 0]), int(u[0, 0]), int(v[0, 0])) == yuv
    assert len(np.unique(y)) == len(np.unique(u)) == len(np.unique(v)) == 1


def test_chroma_is_the_mean_of_each_2x2_block() -> None:
    img = np.zeros((2, 2, 3), dtype=np.uint8)
    img[0, 0] = (255, 0, 0)  # one red pixel in four: a quarter of red's chroma offset
    _, u, v = rgb_to_yuv420(img)
    assert (int(u[0, 0]), int(v[0, 0])) == (128 + (-38 * 255 + 512) // 1024, 128 + (112 * 255 + 512) // 1024)


def test_odd_sizes_are_refused() -> None:
    with pytest.raises(RenderError, match="even frame size, got 5 x 4"):
        rgb_to_yuv420(np.zeros((4, 5, 3), dtype=np.uint8))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([8, 16, 10]), st.integers(1, 9))
def test_canvas_from_compared_tiles_equals_whole_frames(seed: int, size: int, n: int) -> None:
    """Frames that change in random rectangles (or not at all): converting only the changed tiles gives every
    frame's whole conversion, chunk after chunk."""
    rng = np.random.default_rng(seed)
    seq = [rng.integers(0, 256, (size, size, 3), dtype=np.uint8)]
    for _ in range(n - 1):
        nxt = seq[-1].copy()
        if rng.random() < 0.7:
            y0, x0 = rng.integers(0, size, 2)
            h, w = rng.integers(1, size + 1, 2)
            nxt[y0:y0 + h, x0:x0 + w] = rng.integers(0, 256, 3, dtype=np.uint8)
        seq.append(nxt)
    rgb = np.stack(seq)
    canvas = Yuv420Canvas(size, size)
    cut = int(rng.integers(0, n + 1))
    out = [b.copy() for b in canvas.frames(rgb[:cut], changed_tiles(rgb[:cut], None, canvas.tile))]
    previous = rgb[cut - 1] if cut else None
    out += [b.copy() for b in canvas.frames(rgb[cut:], changed_tiles(rgb[cut:], previous, canvas.tile))]
    assert len(out) == n
    for got, img in zip(out, rgb, strict=True):
        assert np.array_equal(got.ravel(), whole(img))


def wandering_simulation(seed: int, steps: int) -> Simulation:
    """Three bodies on a random walk with pauses, overlapping each other and leaving the picture."""
    rng = np.random.default_rng(seed)
    dynamic = [make_dynamic(0, "cube", "red", "large", (0.0, 10.0)),
               make_dynamic(0, "circle", "blue", "small", (2.0, 10.0)),
               make_dynamic(0, "triangle", "green", "large", (-2.0, 12.0))]
    world = WorldSpec(bodies=assign_uids([make_static(0, "ground"), make_static(0, "basket", (10.0, -1.2)),
                                          *dynamic]))
    n = len(world.bodies)
    pos = np.array([[b.position for b in world.bodies]] * (steps + 1), dtype=np.float64)
    ang = np.zeros((steps + 1, n))
    for i, body in enumerate(world.bodies):
        if not body.dynamic:
            continue
        for t in range(1, steps + 1):
            move = rng.random() < 0.6
            pos[t, i] = pos[t - 1, i] + (rng.normal(0, 3.0, 2) if move else 0.0)
            ang[t, i] = ang[t - 1, i] + (rng.normal(0, 0.5) if move else 0.0)
            if rng.random() < 0.1:
                pos[t, i] = (rng.uniform(-40, 40), rng.uniform(-20, 60))  # jumps, often out of the picture
    return simulation_from_rows(world, pos, ang)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 5))
def test_tiles_from_painted_windows_equal_whole_frames(seed: int, chunk: int) -> None:
    """The renderer's windows mark every tile that changed: bodies moving, pausing, overlapping, leaving and
    re-entering the picture, across chunk boundaries."""
    sim = wandering_simulation(seed, steps=12)
    rgb = list(iter_frames(sim))
    got = [b.copy() for b in iter_yuv420(sim, chunk=chunk)]
    assert len(got) == len(rgb) == 12
    for buffer, img in zip(got, rgb, strict=True):
        assert np.array_equal(buffer.ravel(), whole(img))


def test_a_physics_run_converts_as_its_whole_frames() -> None:
    sim = simulate(6, seed=3, steps=180)
    rgb = frames(sim)
    got = [b.copy() for b in iter_yuv420(sim)]
    for buffer, img in zip(got, rgb, strict=True):
        assert np.array_equal(buffer.ravel(), whole(img))
    y, _, _ = planes(got[-1], 256)
    assert y.min() < 100 < y.max()  # bodies and background both present


@pytest.mark.parametrize("ext", [".mpg", ".mp4"])
def test_video_from_a_simulation_and_from_its_frames_are_the_same_bytes(tmp_path: Path, ext: str) -> None:
    sim = simulate(3, seed=1, steps=90)
    a = write_video(sim, tmp_path / f"a{ext}")
    b = write_frames(iter(frames(sim)), tmp_path / f"b{ext}")
    assert a.read_bytes() == b.read_bytes()
    assert write_video(sim, tmp_path / f"c{ext}").read_bytes() == a.read_bytes()  # deterministic
    container = av.open(str(a), format="mpeg1video" if ext == ".mpg" else None)
    decoded = np.stack([f.to_ndarray(format="rgb24") for f in container.decode(video=0)])
    container.close()
    assert decoded.shape == (90, 256, 256, 3)
    error = np.abs(decoded.astype(int) - frames(sim).astype(int))
    assert error.mean() < 1.0 and np.percentile(error, 99) <= 12


def test_yuv_writer_checks_its_input(tmp_path: Path) -> None:
    with pytest.raises(RenderError, match=r"planes of shape \(256, 256\); expected \(384, 256\)"):
        write_yuv420(iter([np.zeros((256, 256), np.uint8)]), tmp_path / "v.mpg")
    with pytest.raises(RenderError, match="from RGB frames"):
        write_yuv420(iter([]), tmp_path / "v.gif")
    with pytest.raises(RenderError, match="no frames to write"):
        write_yuv420(iter([]), tmp_path / "v.mp4")
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing half-written


@pytest.mark.parametrize("size", [42, 100])
def test_sizes_with_padded_planes_encode_and_decode(tmp_path: Path, size: int) -> None:
    """Sizes whose planes FFmpeg pads (42: Y lines of 48 bytes) take the general copy and still decode."""
    sim = simulate(3, seed=1, steps=20)
    path = write_video(sim, tmp_path / "v.mpg", size=size)
    container = av.open(str(path), format="mpeg1video")
    decoded = np.stack([f.to_ndarray(format="rgb24") for f in container.decode(video=0)])
    container.close()
    assert decoded.shape == (20, size, size, 3)
    assert np.abs(decoded.astype(int) - frames(sim, size=size).astype(int)).mean() < 2.0
