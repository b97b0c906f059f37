"""The original CRAFT simulator as a third engine (``--engine original``).

The tests that drive the real binary need it built (``bash tools/original/build.sh``; ``.ci/run`` builds it) and
are skipped, saying so, where it is not. Everything else (the scene file, binary discovery, every failure of the
binary) runs everywhere, with small stand-in programs where a binary is needed.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from original_helpers import needs_binary, stand_in

from craft_dsl import parse
from craft_dsl.analysis.engines import compare_engines
from craft_dsl.cli import main
from craft_dsl.physics import original as orig
from craft_dsl.physics import simulate
from craft_dsl.physics.original import OriginalSimulation, OriginalSimulator, OriginalSimulatorError
from craft_dsl.scenes import sample_world
from craft_dsl.world import make_dynamic

# -- the scene file (no binary needed) ------------------------------------------------------------------------


@pytest.mark.parametrize(("shape", "size", "mass", "inertia"), [
    ("cube", "small", 200.0, 133.33), ("cube", "large", 800.0, 2133.33),
    ("triangle", "small", 259.81, 259.81), ("triangle", "large", 584.57, 1315.28),
    ("circle", "small", 157.02, 78.48), ("circle", "large", 628.07, 1255.63),
])
def test_scene_file_carries_the_mass_data_the_original_computes(shape: str, size: str, mass: float,
                                                                  inertia: float) -> None:
    rec = orig.body_record(make_dynamic(0, shape, "red", size, (1.0, 2.0), (3.0, 0.0)))
    assert rec["massData-mass"] == pytest.approx(mass, abs=0.01)
    assert rec["massData-I"] == pytest.approx(inertia, abs=0.01)
    assert abs(rec["massData-centerX"]) < 1e-9 and abs(rec["massData-centerY"]) < 1e-9
    assert rec["2dCoords"] == [1.0, 2.0] and rec["2dLinearVelocity"] == [3.0, 0.0] and rec["bodyType"] == 2


def test_scene_file_lists_every_body_in_creation_order_with_its_fields() -> None:
    world = sample_world(2, 0)
    scene = orig.scene_file(world)
    objects = scene["scene_states"][0]["scene"]["objects"]
    assert [o["uniqueID"] for o in objects] == [b.uid for b in world.bodies]
    assert [o["shape"] for o in objects[:4]] == ["wall_l", "wall_r", "ground", "basket"]
    statics = [o for o in objects if o["bodyType"] == 0]
    assert statics and all(o["massData-mass"] == 0.0 and o["color"] == "black" for o in statics)
    keys = {"2dCoords", "2dLinearVelocity", "active", "allowSleep", "angle", "angularDamping", "angularVelocity",
            "awake", "bodyType", "bullet", "color", "density", "fixedRotation", "friction", "gravityScale",
            "linearDamping", "massData-I", "massData-centerX", "massData-centerY", "massData-mass", "restitution",
            "shape", "size", "uniqueID"}
    assert all(set(o) == keys for o in objects)
    json.dumps(scene, allow_nan=False)


def test_scene_file_refuses_what_the_original_cannot_express() -> None:
    from dataclasses import replace

    world = sample_world(1, 0)
    with pytest.raises(OriginalSimulatorError, match="needs its walls, ground and basket; missing: basket"):
        orig.scene_file(world.without(next(b.uid for b in world.bodies if b.shape == "basket")))
    with pytest.raises(OriginalSimulatorError, match="gravity"):
        orig.scene_file(replace(world, gravity=(0.0, -9.81)))
    bad = replace(world, bodies=tuple(replace(b, position=(math.nan, 0.0)) if b.dynamic else b
                                      for b in world.bodies))
    with pytest.raises(OriginalSimulatorError, match="not finite"):
        orig.scene_file(bad)


# -- finding the binary and its failures (stand-in programs) --------------------------------------------------


def test_an_unbuilt_simulator_is_one_clear_error(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.delenv(orig.ENV_BINARY, raising=False)
    monkeypatch.setenv(orig.ENV_HOME, str(tmp_path / "empty"))
    monkeypatch.setattr(orig, "default_archive", lambda: None)
    with pytest.raises(OriginalSimulatorError, match="not built.*tools/original/build.sh"):
        orig.find_binary()
    assert main(["engines", "original", "--check"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: the original CRAFT simulator is not built") and err.count("\n") == 1
    assert main(["simulate", "--scene", "1", "--engine", "original", "--out", str(tmp_path / "s.json")]) == 2
    assert "not built" in capsys.readouterr().err and not (tmp_path / "s.json").exists()
    assert main(["engines", "compare", "--scenes", "1", "--seeds", "1", "--engines", "pymunk,original"]) == 2
    assert "not built" in capsys.readouterr().err


def _controller_field(field: str) -> str:
    return f"$({sys.executable} -c \"import json,sys; print(json.load(open(sys.argv[1]))['{field}'])\" \"$1\")"


@pytest.mark.parametrize(("body", "message"), [
    ("echo 'segfault soon' >&2; exit 3", r"failed on scene 1 seed 0 \(exit code 3\): segfault soon"),
    ("kill -SEGV $$", "killed by signal 11"),
    ("exit 0", "wrote no output file"),
    ("echo '{\"causal' > " + _controller_field("outputJSONPath"), "malformed output file"),
    ("echo '[1, 2]' > " + _controller_field("outputJSONPath"), "not a JSON object"),
    ("echo '{\"causal_graph\": {\"nodes\": []}, \"scene_states\": []}' > " + _controller_field("outputJSONPath"),
     "malformed output file"),
    ("sleep 30", "ran past its time limit of 1 s"),
])
def test_every_failure_of_the_binary_is_one_error_naming_the_cause(body: str, message: str, tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(orig.ENV_DISPLAY, ":424242")  # the stand-ins draw nothing
    simulator = OriginalSimulator(stand_in(tmp_path, body), timeout=1)
    with pytest.raises(OriginalSimulatorError, match=message):
        simulator.simulation(sample_world(1, 0), 60)


def test_a_binary_that_is_not_executable_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "Testbed"
    path.write_text("not a program")
    monkeypatch.setenv(orig.ENV_BINARY, str(path))
    assert main(["engines", "original", "--check"]) == 2
    assert f"${orig.ENV_BINARY} is '{path}', which is not an executable file" in capsys.readouterr().err


class _MarksWhereItDies:
    """Appends the id of the process that frees it to ``path``."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __del__(self) -> None:
        with self.path.open("a") as out:
            out.write(f"{os.getpid()}\n")


def test_no_python_runs_in_the_child_between_fork_and_exec(tmp_path: Path) -> None:
    """Python code between fork and exec frees the other threads' thread-local objects in the child; a library's
    object there (PyAV's scaler) then waits forever on a lock its thread held: the sampler's parallel runs hung."""
    marks = tmp_path / "freed_in"
    ready, release = threading.Event(), threading.Event()
    local = threading.local()

    def hold() -> None:
        local.obj = _MarksWhereItDies(marks)
        ready.set()
        release.wait(60)

    holder = threading.Thread(target=hold)
    holder.start()
    ready.wait(60)
    try:
        with pytest.raises(OriginalSimulatorError, match="wrote no output file"):
            orig.run_binary(stand_in(tmp_path, "exit 0"), tmp_path / "controller.json", tmp_path, dict(os.environ),
                            30, "a stand-in", tmp_path / "out.json")
    finally:
        release.set()
        holder.join(60)
    freed_in = marks.read_text().split() if marks.exists() else []
    assert freed_in == [str(os.getpid())], "a thread's local object was freed in a child process"


@pytest.mark.skipif(orig._setpriv() is None, reason="needs util-linux's setpriv with --pdeathsig (Linux)")
def test_a_simulator_ends_with_the_process_that_started_it(tmp_path: Path) -> None:
    pid_file = tmp_path / "pid"
    binary = stand_in(tmp_path, f"echo $$ > {pid_file}; exec sleep 60")
    script = (f"from pathlib import Path; from craft_dsl.physics import original as o; "
              f"o.run_binary(Path({str(binary)!r}), Path('c.json'), Path({str(tmp_path)!r}), {{}}, 60, 'x', "
              f"Path('o.json'))")
    parent = subprocess.Popen([sys.executable, "-c", script])
    try:
        for _ in range(600):
            if pid_file.exists() and pid_file.read_text().strip():
                break
            time.sleep(0.05)
        child = int(pid_file.read_text())
    finally:
        parent.kill()
        parent.wait()
    for _ in range(200):
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    os.kill(child, signal.SIGKILL)
    pytest.fail("the simulator outlived the process that started it")


def test_the_video_option_belongs_to_the_original(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--scene", "1", "--steps", "10", "--video", str(tmp_path / "v.mpg"),
                 "--out", str(tmp_path / "s.json")]) == 2
    assert "--video takes the original renderer's video" in capsys.readouterr().err


# -- the real binary --------------------------------------------------------------------------------------------


@needs_binary
def test_original_and_pymunk_start_from_the_same_state_and_answer_the_same_programs() -> None:
    ours = simulate(1, seed=0, steps=240)
    theirs = simulate(1, seed=0, steps=240, engine="original")
    assert isinstance(theirs, OriginalSimulation) and theirs.meta["engine"] == "original"
    assert theirs.world == ours.world
    assert [(o.id, o.shape, o.color, o.size, o.dynamic) for o in theirs.objects] == \
        [(o.id, o.shape, o.color, o.size, o.dynamic) for o in ours.objects]
    for a, b in zip(theirs.objects, ours.objects):
        assert a.start.position == pytest.approx(b.start.position, abs=1e-5)  # the original stores float32
        assert a.start.velocity == pytest.approx(b.start.velocity, abs=1e-5)
    assert theirs.events[0].type == "Start" and theirs.events[-1].type == "End" and theirs.events[-1].step == 240
    programs = ["Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))",
                "Count(FilterEnterBasket(Events()))", "Count(FilterMoving(SceneAtEnd(), EndSceneStep()))"]
    for text in programs:
        program = parse(text)
        a, b = program.run(theirs), program.run(ours)
        assert type(a) is type(b)
    assert theirs.causal_graph.number_of_nodes() == len(theirs.events)


@needs_binary
def test_counterfactuals_and_perturbations_are_reruns_of_the_original() -> None:
    sim = simulate(3, seed=1, steps=180, engine="original")
    uid = min(sim.dynamic_ids)
    cf = sim.counterfactual(uid)
    assert isinstance(cf, OriginalSimulation) and cf is sim.counterfactual(uid)  # cached
    assert not cf.has_object(uid) and set(cf.all_ids) == set(sim.all_ids) - {uid} and cf.removed == (uid,)
    assert all(uid not in e.objects for e in cf.events)
    o = sim.object(uid)
    query = f'Unique(FilterShape(FilterColor(FilterSize(SceneAtStart(), "{o.size}"), "{o.color}"), "{o.shape}"))'
    count = parse(f"Count(FilterCollideGround(GetCounterfactEvents({query})))")
    assert count.run(sim) == len([e for e in cf.events if e.type == "Collision" and cf.ground_id in e.objects])
    again = simulate(3, seed=1, steps=180, engine="original")
    assert [(e.type, e.step, e.objects) for e in again.events] == [(e.type, e.step, e.objects) for e in sim.events]
    moved = sim.perturbed(5)
    assert moved.world != sim.world and moved.meta["perturbation_seed"] == 5


@needs_binary
def test_simulate_command_writes_the_file_and_the_original_video(tmp_path: Path) -> None:
    av = pytest.importorskip("av", reason="decoding needs PyAV, a core dependency")
    out, video = tmp_path / "sim.json", tmp_path / "v.mpg"
    assert main(["simulate", "--scene", "4", "--seed", "2", "--steps", "120", "--engine", "original",
                 "--video", str(video), "--out", str(out)]) == 0
    from craft_dsl import load_simulation

    sim = load_simulation(out)
    assert sim.steps == 120 and sim.counterfactual(min(sim.dynamic_ids)).steps == 120
    with av.open(str(video)) as container:
        frames = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    assert len(frames) == 120 and frames[0].shape == (256, 256, 3)
    last = frames[-1]
    assert (last[:, 200:] < 100).any(), "the right half of the picture is drawn (the full-size window)"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim.json", "v.mpg"]  # no temporary file left


@needs_binary
def test_static_balls_are_drawn_as_the_original_draws_a_generated_scene(tmp_path: Path) -> None:
    """A scene loaded from JSON drew no static ball (the simulator left it untextured); the build's edit draws it
    black like the other statics, as the original's generated scenes (the published videos) do."""
    from craft_dsl.reader.video import decode
    from craft_dsl.render.raster import world_to_pixel

    world = sample_world(13, 3)
    OriginalSimulator().run(world, 2, video=tmp_path / "v.mpg")
    first = decode(tmp_path / "v.mpg")[0]
    balls = [b for b in world.bodies if b.shape == "static_ball"]
    assert len(balls) == 3
    for ball in balls:
        x, y = world_to_pixel(*ball.position)
        assert first[int(y), int(x)].max() < 60, (ball.position, first[int(y), int(x)])


@needs_binary
def test_skipping_the_drawing_changes_nothing_the_original_writes(tmp_path: Path) -> None:
    """Runs without a video skip drawing (the build's one speed edit): states and events are those of a run that
    draws and encodes every frame."""
    simulator = OriginalSimulator()
    world = sample_world(2, 3)
    drawn = simulator.run(world, 150, video=tmp_path / "v.mpg").output
    plain = simulator.run(world, 150).output
    assert drawn["scene_states"] == plain["scene_states"]
    events = [[(n["type"], n["step"], n["objects"]) for n in out["causal_graph"]["nodes"]] for out in (drawn, plain)]
    assert events[0] == events[1] and len(events[0]) > 2


@needs_binary
def test_engines_compare_with_the_original_as_reference(capsys: pytest.CaptureFixture[str]) -> None:
    cmp = compare_engines([6], [0], engines=("pymunk", "original"), steps=180, perturb=0.02)
    assert cmp.reference == "original" and cmp.runs == ("pymunk", "original~0.02")
    assert all(len(t.agree) == 2 for t in cmp.templates) and cmp.categories()[-1].questions > 0
    assert main(["engines", "original", "--check"]) == 0
    assert "scene 1 seed 0, 60 steps" in capsys.readouterr().out


@needs_binary
def test_check_runs_from_a_fresh_process_with_its_own_display() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", orig.ENV_DISPLAY)}
    done = subprocess.run([sys.executable, "-m", "craft_dsl", "engines", "original", "--check"], env=env,
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert "events" in done.stdout


def _folder_bytes(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name not in ("generation.log", "generation_report.json")}


@needs_binary
def test_generate_with_the_original_engine_and_its_renderer(tmp_path: Path) -> None:
    """A dataset made by the original simulator, videos drawn by its renderer: byte-identical for any number of
    workers and on a Dask cluster, and every answer re-derived from the saved simulations."""
    args = ["generate", "--size", "2", "--scenes", "1,6", "--steps", "240", "--perturbations", "1", "--no-balance",
            "--videos", "--engine", "original", "--quiet"]
    assert main([*args, "--workers", "1", "--out", str(tmp_path / "one")]) == 0
    assert main([*args, "--workers", "2", "--out", str(tmp_path / "two")]) == 0
    one, two = _folder_bytes(tmp_path / "one"), _folder_bytes(tmp_path / "two")
    assert one == two
    videos = sorted(k for k in one if k.endswith(".mpg"))
    assert len(videos) >= 1 and all(one[k][-4:] == b"\x00\x00\x01\xb7" for k in videos)  # the original's end code
    config = json.loads(one["generation_config.json"])
    assert config["engine"] == "original"
    assert main(["verify", "--dataset", str(tmp_path / "one" / "dataset.json"),
                 "--annotations", str(tmp_path / "one" / "annotations.json")]) == 0
    distributed = pytest.importorskip("distributed", reason="the Dask executor needs the dask extra: "
                                                            "pip install 'craft-dsl[dask]'")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) \
            as cluster:  # each Dask worker process starts its own Xvfb
        assert main([*args, "--executor", "dask", "--scheduler", cluster.scheduler_address,
                     "--out", str(tmp_path / "dask")]) == 0
    assert _folder_bytes(tmp_path / "dask") == one


@needs_binary
@pytest.mark.parametrize("size", ["small", "large"])
def test_our_box2d_circles_roll_as_far_as_the_originals_128_gons(size: str) -> None:
    """The original's polygon circles slow down as they roll; our Box2D adds that loss to its true circles."""
    from dataclasses import replace

    from craft_dsl.physics.box2d_engine import Box2DEngine

    radius = 1.0 if size == "small" else 2.0
    ball = replace(make_dynamic(0, "circle", "red", size, (-20.0, -4.8 + radius + 0.01), (2.0, 0.0)),
                   angular_velocity=-2.0 / radius)
    w = sample_world(1, 0)
    keep = [b for b in w.bodies if b.shape in ("wall_l", "wall_r", "ground")]
    basket = [replace(b, position=(19.0, -1.2)) for b in w.bodies if b.shape == "basket"]
    rolling = type(w)(tuple(keep + basket + [replace(ball, uid=0)]))
    speeds = {}
    for name, engine in (("original", "original"), ("box2d", "box2d"),
                         ("true circle", Box2DEngine(rolling_deceleration=(0.0, 0.0)))):
        sim = simulate(rolling, steps=180, engine=engine)  # type: ignore[call-overload]
        speeds[name] = sim.object(0).end.velocity[0]
    assert speeds["original"] < 1.7  # three seconds of rolling cost the 128-gon at least 0.3 m/s
    assert speeds["box2d"] == pytest.approx(speeds["original"], abs=0.15)
    assert abs(speeds["true circle"] - speeds["original"]) > 0.3


@needs_binary
def test_our_box2d_circles_collide_with_the_ground_as_often_as_the_originals_rolling_128_gons() -> None:
    """Rolling, the original's polygon circle makes a new ground contact every few steps (each a Collision)."""
    from dataclasses import replace

    from craft_dsl.physics.box2d_engine import Box2DEngine

    w = sample_world(1, 0)
    keep = [b for b in w.bodies if b.shape in ("wall_l", "wall_r", "ground")]
    basket = [replace(b, position=(19.0, -1.2)) for b in w.bodies if b.shape == "basket"]
    ball = replace(make_dynamic(0, "circle", "red", "small", (-22.0, -3.79), (3.0, 0.0)), angular_velocity=-3.0)
    rolling = type(w)(tuple(keep + basket + [ball]))
    counts = {}
    for name, engine in (("original", "original"), ("box2d", "box2d"), ("one contact", Box2DEngine(flicker=False))):
        sim = simulate(rolling, steps=240, engine=engine)  # type: ignore[call-overload]
        counts[name] = sum(1 for e in sim.events if e.type == "Collision" and sim.ground_id in e.objects)
    assert counts["original"] >= 20
    assert 0.6 * counts["original"] <= counts["box2d"] <= 1.4 * counts["original"]
    assert counts["one contact"] <= 2
