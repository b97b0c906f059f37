"""Rendering: pixels against the simulation state, frame counts, and files that decode back."""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from craft_dsl import Simulation, load_simulation
from craft_dsl.cli import main
from craft_dsl.render import (
    RenderError,
    frame,
    frame_count,
    frames,
    world_to_pixel,
    write_frames,
    write_png,
    write_video,
)
from craft_dsl.render.raster import SENSOR_GREY
from craft_dsl.vocabulary import COLOR_RGB
from craft_dsl.world import WorldSpec, assign_uids, make_dynamic, make_static
from tests.synthetic_scene import simulation_from_rows, synthetic_simulation

E1 = Path(__file__).parent / "data" / "e1.json"


def still_simulation(bodies: list, steps: int = 4, spin: float = 0.0) -> Simulation:
    """A simulation whose bodies stay where the world puts them (dynamic ones turn by ``spin`` rad/step)."""
    world = WorldSpec(bodies=assign_uids(bodies))
    pos = np.array([[b.position for b in world.bodies]] * (steps + 1), dtype=np.float64)
    ang = np.array([[b.angle + (spin * t if b.dynamic else 0.0) for b in world.bodies] for t in range(steps + 1)])
    return simulation_from_rows(world, pos, ang)


def scene(*dynamic: object) -> list:
    return [make_static(0, "wall_l"), make_static(0, "wall_r"), make_static(0, "ground"),
            make_static(0, "basket", (10.0, -1.2)), make_static(0, "platform", (-10.0, 10.0)), *dynamic]


def pixel(img: np.ndarray, x: float, y: float) -> tuple[int, ...]:
    col, row = world_to_pixel(x, y)
    return tuple(int(v) for v in img[int(row), int(col)])


def local_to_world(pos: tuple[float, float], angle: float, lx: float, ly: float) -> tuple[float, float]:
    c, s = math.cos(angle), math.sin(angle)
    return pos[0] + c * lx - s * ly, pos[1] + s * lx + c * ly


def test_background_statics_sensor_and_object_colours() -> None:
    sim = still_simulation(scene(make_dynamic(0, "cube", "red", "large", (0.0, 25.0)),
                                 make_dynamic(0, "circle", "cyan", "large", (-15.0, 35.0))))
    img = frame(sim, 1)
    assert img.shape == (256, 256, 3) and img.dtype == np.uint8
    assert pixel(img, 15.0, 40.0) == (255, 255, 255)          # background
    assert pixel(img, -10.0, 10.0) == (0, 0, 0)              # platform centre
    assert pixel(img, -10.0, -4.95) == (0, 0, 0)             # ground
    assert pixel(img, 10.0, -1.2) == SENSOR_GREY              # basket sensor
    # body colour away from the eyes (at angle pi the eyes sit above the centre, so look below it)
    assert pixel(img, 0.0, 25.0 - 1.2) == COLOR_RGB["red"]
    assert pixel(img, -15.0, 35.0 - 1.2) == COLOR_RGB["cyan"]


def test_basket_outline_is_a_faint_dark_line() -> None:
    img = frame(still_simulation(scene()), 1)
    # the right wall of the basket at y = 0 (relative y 1.2) crosses x = 10 + 2.5 + 4.7 / 7
    col, row = world_to_pixel(10.0 + 2.5 + 4.7 / 7, 0.0)
    strip = img[int(row), int(col) - 4:int(col) + 5, 0].astype(int)
    assert 0 < strip.min() < 200          # thinner than a pixel: a grey line, not black
    assert strip[0] == 229 and strip[-1] == 255  # sensor grey inside, white outside


def _window(img: np.ndarray, x: float, y: float, r: int = 2) -> np.ndarray:
    col, row = world_to_pixel(x, y)
    return img[int(row) - r:int(row) + r + 1, int(col) - r:int(col) + r + 1].astype(int)


@pytest.mark.parametrize("angle", [math.pi, math.pi / 2, 0.3])
def test_eyes_turn_with_the_body(angle: float) -> None:
    sim = still_simulation(scene(make_dynamic(0, "cube", "blue", "large", (0.0, 25.0), angle=angle)))
    img = frame(sim, 1)
    for side in (-0.45, 0.45):
        eye = _window(img, *local_to_world((0.0, 25.0), angle, side, -0.45))
        assert eye.max(axis=2).min() < 40           # a black pupil
        assert eye.min(axis=2).max() > 240          # white sclera around it
        # the mirrored place (where the eyes would be if they did not turn) is plain body colour
        away = _window(img, *local_to_world((0.0, 25.0), angle, side, 1.2), r=1)
        assert (away == COLOR_RGB["blue"]).all()


def test_dynamic_over_static_and_newest_on_top() -> None:
    sim = still_simulation(scene(make_dynamic(0, "cube", "green", "large", (-10.0, 10.0)),   # on the platform
                                 make_dynamic(0, "cube", "yellow", "large", (-9.0, 9.5)),    # created last
                                 ))
    img = frame(sim, 1)
    assert pixel(img, -11.5, 11.0) == COLOR_RGB["green"]   # green over the black platform
    assert pixel(img, -9.0, 8.0) == COLOR_RGB["yellow"]    # the later-created cube covers the earlier one


def test_frame_counts_follow_the_frame_rate() -> None:
    sim = synthetic_simulation(steps=60)
    assert frames(sim).shape == (60, 256, 256, 3)
    assert frame_count(sim, fps=30) == 30 and frames(sim, fps=30).shape[0] == 30
    assert frame_count(sim, fps=20) == 20
    # frame i at 60 fps shows the state after i+1 steps (no frame of the initial state)
    assert np.array_equal(frames(sim)[0], frame(sim, 1))
    assert np.array_equal(frames(sim, fps=30)[0], frame(sim, 2))
    for bad in (0, -5, 120):
        with pytest.raises(RenderError, match="fps"):
            frames(sim, fps=bad)


def test_live_simulation_renders_objects_where_the_physics_put_them() -> None:
    from craft_dsl.physics import simulate

    sim = simulate(10, seed=0, steps=40)
    traj, img = sim.trajectory, frame(sim, 40)
    assert traj is not None
    for obj in sim.objects:
        if obj.dynamic and obj.shape == "cube":
            k = traj.column(obj.id)
            x, y = traj.positions[40, k]
            wx, wy = local_to_world((x, y), float(traj.angles[40, k]), 0.0, 0.6)
            assert pixel(img, wx, wy) == COLOR_RGB[obj.color]


def test_recorded_simulation_cannot_be_rendered() -> None:
    with pytest.raises(RenderError, match="live simulation"):
        frame(load_simulation(E1), 1)


def _decode(path: Path) -> tuple[tuple[int, int], list[np.ndarray]]:
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    w, h = meta["size"]
    return meta["size"], [np.frombuffer(f, np.uint8).reshape(h, w, 3) for f in reader]


@pytest.mark.parametrize(("name", "fps", "expected"), [("v.mp4", 60, 48), ("v.gif", 30, 24)])
def test_written_video_decodes_back(tmp_path: Path, name: str, fps: int, expected: int) -> None:
    sim = synthetic_simulation(steps=48)
    out = write_video(sim, tmp_path / name, fps=fps)
    size, decoded = _decode(out)
    assert size == (256, 256) and len(decoded) == expected
    # lossy, but close to what was rendered
    assert np.abs(decoded[5].astype(int) - frames(sim, fps=fps)[5].astype(int)).mean() < 6
    assert [p.name for p in tmp_path.iterdir()] == [name]


def test_png_is_lossless(tmp_path: Path) -> None:
    sim = synthetic_simulation(steps=10)
    path = write_png(sim, tmp_path / "f.png", 7)
    size, decoded = _decode(path)
    assert size == (256, 256) and np.array_equal(decoded[0], frame(sim, 7))


def test_written_files_get_the_usual_permissions(tmp_path: Path) -> None:
    sim = synthetic_simulation(steps=4)
    old = os.umask(0o022)
    try:
        path = write_png(sim, tmp_path / "f.png", 1)
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == 0o644


def test_failed_write_leaves_nothing(tmp_path: Path) -> None:
    sim = synthetic_simulation(steps=10)

    def broken() -> object:
        yield frame(sim, 1)
        raise RuntimeError("interrupted")

    with pytest.raises(RuntimeError, match="interrupted"):
        write_frames(broken(), tmp_path / "v.mp4")  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(RenderError, match="allowed: .mpg, .mp4, .gif"):
        write_video(sim, tmp_path / "v.avi")
    assert list(tmp_path.iterdir()) == []


def test_mpeg1_refuses_a_rate_it_cannot_state(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sim = synthetic_simulation(steps=12)
    with pytest.raises(RenderError, match=r"cannot store 10 frames per second \(it allows 23.976, 24, 25, 29.97, "
                                          r"30, 50, 59.94, 60\); write an .mp4"):
        write_video(sim, tmp_path / "v.mpg", fps=10)
    assert list(tmp_path.iterdir()) == []
    assert len(_decode(write_video(sim, tmp_path / "v.mpg", fps=30))[1]) == 6  # a rate MPEG-1 has
    out = tmp_path / "cli.mpg"
    assert main(["render", "--scene", "1", "--steps", "30", "--fps", "10", "--out", str(out), "--quiet"]) == 2
    assert "error:" in capsys.readouterr().err and not out.exists()


def test_render_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "f.png"
    assert main(["render", "--scene", "3", "--seed", "7", "--steps", "30", "--frame", "30", "--out", str(png)]) == 0
    assert _decode(png)[0] == (256, 256)
    mp4 = tmp_path / "d.mp4"
    assert main(["render", "--scene", "3", "--seed", "7", "--steps", "30", "--out", str(mp4), "--quiet"]) == 0
    assert len(_decode(mp4)[1]) == 30
    assert main(["render", "--scene", "3", "--out", str(tmp_path / "x.png")]) == 2
    assert "--frame" in capsys.readouterr().err
