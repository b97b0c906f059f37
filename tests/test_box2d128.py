"""The box2d128 engine: Box2D with the original's 128-gon circles, which needs Box2D built with 128-vertex polygons
(``tools/box2d128/build.sh``). Its physics tests are skipped, saying so, where that build is not installed; its
refusal, its polygons and the build's source edits are tested everywhere."""

from __future__ import annotations

import math
import runpy
from pathlib import Path

import pytest
from original_helpers import needs_binary
from test_engines import _roller

from craft_dsl.cli import main
from craft_dsl.physics import box2d_engine as b2e
from craft_dsl.physics import get_engine, simulate
from craft_dsl.physics.box2d_engine import Box2D128Engine, Box2DBuildError, max_polygon_vertices, regular_polygon
from craft_dsl.scenes import sample_world

ROOT = Path(__file__).resolve().parents[1]
BUILT = max_polygon_vertices(128) == 128
needs_build = pytest.mark.skipif(
    not BUILT, reason="Box2D is not built with 128-vertex polygons: run `bash tools/box2d128/build.sh` (needs swig "
                      "and g++; .ci/run does it)")


def test_the_polygon_is_the_originals() -> None:
    points = regular_polygon(2.0, 128)
    assert len(points) == 128 and points[0] == pytest.approx((0.0, -2.0))
    assert all(math.hypot(x, y) == pytest.approx(2.0) for x, y in points)
    turns = [(a[0] * b[1] - a[1] * b[0]) for a, b in zip(points, points[1:] + points[:1])]
    assert all(t > 0 for t in turns)  # counter-clockwise, convex


def test_without_the_build_the_engine_is_refused_naming_it(monkeypatch: pytest.MonkeyPatch,
                                                           capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    monkeypatch.setattr(b2e, "max_polygon_vertices", lambda wanted=128: 16)
    with pytest.raises(Box2DBuildError, match=r"takes 16: build it with `bash tools/box2d128/build.sh`"):
        get_engine("box2d128")
    out = tmp_path / "sim.json"
    assert main(["simulate", "--scene", "3", "--engine", "box2d128", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: the box2d128 engine needs Box2D built") and err.count("\n") == 1
    assert not out.exists()
    assert get_engine("box2d").name == "box2d"  # the default needs no build


def test_the_installed_cap_is_read_from_box2d() -> None:
    assert max_polygon_vertices(16) == 16
    assert max_polygon_vertices(128) in (16, 128)


def _fake_source(tmp_path: Path, cap: str = "16") -> Path:
    (tmp_path / "Box2D" / "Common").mkdir(parents=True)
    (tmp_path / "Box2D" / "Common" / "b2Settings.h").write_text(f"#define b2_maxPolygonVertices\t{cap}\n")
    (tmp_path / "setup.py").write_text('setup_dict = dict(\n    name             = "box2d-py",\n'
                                       '    version          = version_str,\n)\n')
    return tmp_path


def test_the_build_edits_the_cap_name_and_version_once(tmp_path: Path) -> None:
    edit = runpy.run_path(str(ROOT / "tools" / "box2d128" / "edit_source.py"))["edit"]
    source = _fake_source(tmp_path / "ok")
    edit(source, "2.3.10+craft128")
    assert (source / "Box2D/Common/b2Settings.h").read_text() == "#define b2_maxPolygonVertices\t128\n"
    setup = (source / "setup.py").read_text()
    assert 'name             = "box2d"' in setup and 'version          = "2.3.10+craft128"' in setup
    with pytest.raises(SystemExit, match=r"b2Settings.h: expected one match"):
        edit(_fake_source(tmp_path / "other", cap="8"), "2.3.10+craft128")


@needs_build
def test_circles_are_one_128_gon_fixture_and_roll_with_the_originals_loss() -> None:
    eng = get_engine("box2d128")
    assert isinstance(eng, Box2D128Engine) and eng.name == "box2d128"
    world = sample_world(11, 0)  # a static ball and circles
    _b2w, bodies = eng.build_world(world)
    for spec in world.bodies:
        if spec.geometry.circle_radius:
            (fixture,) = bodies[spec.uid].fixtures
            assert len(fixture.shape.vertices) == 128
    for size, low, high in (("small", 0.15, 0.3), ("large", 0.12, 0.25)):  # the original: 0.22 and 0.17 m/s a second
        w, uid, _ = _roller(size, 2.0)
        slowed = (2.0 - simulate(w, steps=90, engine="box2d128").object(uid).end.velocity[0]) / 1.5
        assert low < slowed < high, (size, slowed)


@needs_build
def test_runs_are_deterministic_and_the_default_engine_unchanged() -> None:
    a, b = (simulate(13, seed=4, engine="box2d128") for _ in range(2))
    assert (a.traj.positions == b.traj.positions).all() and a.events == b.events
    assert simulate(13, seed=4).meta["engine"] == "box2d"


@needs_build
@needs_binary
def test_its_end_positions_are_the_originals_closer_than_true_circles() -> None:
    worlds = [sample_world(scene, seed) for scene in (1, 8, 11, 13, 18) for seed in (0, 1)]
    error = {"box2d": 0.0, "box2d128": 0.0}
    for world in worlds:
        reference = simulate(world, engine="original")
        for engine in error:
            sim = simulate(world, engine=engine)
            error[engine] += sum(math.dist(o.end.position, reference.object(o.id).end.position)
                                 for o in sim.objects if o.dynamic)
    assert error["box2d128"] < 0.5 * error["box2d"], error
