"""The original CRAFT simulator (C++ Box2D 2.3.2 with CRAFT's settings and OpenGL renderer) as a third engine.

The binary is built by ``tools/original/build.sh`` from the original code's archive; it is not part of the package.
craft_dsl drives it through its scene-from-JSON mode, so that every engine starts from the same seeded state:

1. the :class:`~craft_dsl.world.WorldSpec` that craft_dsl samples for a scene and seed is written as a step-0
   scene in the original's JSON format (every body, walls included, with the mass data the original computes);
2. the binary simulates it headless (its own X server, Xvfb, started once per process) and writes its output
   JSON (start and end states, events, causal graph) and, when asked, its MPEG-1 video;
3. the output is read by :func:`~craft_dsl.recorded.load_simulation`, the loader of recorded CRAFT files.

Counterfactuals are made as the original pipeline makes them: the step-0 scene less one object, simulated again
(lazily, one run per object asked for). They are not "clean" in craft_dsl's sense: the original's own numerical
noise is part of what it computes. Perturbations use craft_dsl's seeded version of the original's noise formula
(:func:`~craft_dsl.physics.engine.perturb_world`), so that every engine gets the same perturbed start state.

>>> from craft_dsl.physics import simulate
>>> sim = simulate(3, seed=0, engine="original")   # doctest: +SKIP
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..atomic import atomic_path
from ..errors import CounterfactualUnavailable, CraftError, SimulationFileError
from ..simulation import Simulation
from ..world import DEFAULT_STEPS, DENSITY, FRICTION, RESTITUTION, BodySpec, WorldSpec, regular_polygon
from .engine import perturb_world

#: Environment variables: the binary itself, the build cache, an X display to use instead of a private Xvfb,
#: and the time limit of one run in seconds.
ENV_BINARY = "CRAFT_ORIGINAL_BIN"
ENV_HOME = "CRAFT_ORIGINAL_HOME"
ENV_DISPLAY = "CRAFT_ORIGINAL_DISPLAY"
ENV_TIMEOUT = "CRAFT_ORIGINAL_TIMEOUT"
#: Set for runs without a video: the build skips drawing (it changes nothing the binary writes).
NO_DRAW = "CRAFT_ORIGINAL_NO_DRAW"
#: Seeds the original's own scene sampler (the build's edit; an unsigned 32-bit decimal). Unset, the original seeds
#: it from the clock and the hardware, as it was written.
ENV_SEED = "CRAFT_ORIGINAL_SEED"
#: The file a finished build writes last in its cache folder.
BUILD_STAMP = "BUILD_COMPLETE"
#: The binary inside a build folder; its folder holds the Data/ it reads from its working directory.
BINARY_PATH = ("run", "Testbed")
DEFAULT_TIMEOUT = 300.0
#: Video size of the published dataset.
VIDEO_SIZE = 256
#: The original builds its "circles" (and the static ball) as regular 128-gons.
CIRCLE_SIDES = 128


class OriginalSimulatorError(CraftError):
    """The original simulator is not built, could not be started, failed, timed out or wrote a malformed file."""


def default_home() -> Path:
    """The build cache: ``$CRAFT_ORIGINAL_HOME``, else ``~/.cache/craft_dsl/original``."""
    env = os.environ.get(ENV_HOME)
    return Path(env) if env else Path.home() / ".cache" / "craft_dsl" / "original"


def repository_root() -> Path | None:
    """The checkout this package runs from (with ``tools/original/build.sh``), or None for an installed wheel."""
    root = Path(__file__).resolve().parents[2]
    return root if (root / "tools" / "original" / "build.sh").is_file() else None


def default_archive() -> Path | None:
    """The original code's archive beside the checkout (``../shared/original-craft/``), if present."""
    root = repository_root()
    if root is None:
        return None
    path = root.parent / "shared" / "original-craft" / "craft-box2d-85c50b2.tar.gz"
    return path if path.is_file() else None


#: The files of ``tools/original/`` that make a build, hashed into its cache key with the archive.
RECIPE_FILES = ("patch_sources.py", "Makefile", "VideoWriter.h")


def _sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def build_key(archive: Path, recipe: Path) -> str:
    """The build cache's key, as ``tools/original/build.sh`` computes it: the first 16 hex digits of the SHA-256 of
    the archive's SHA-256 (hex, one line) followed by the recipe files."""
    digest = hashlib.sha256((_sha256_file(archive) + "\n").encode())
    for name in RECIPE_FILES:
        digest.update((recipe / name).read_bytes())
    return digest.hexdigest()[:16]


def find_binary() -> Path:
    """The built binary: ``$CRAFT_ORIGINAL_BIN``, else the cache folder of the archive beside the checkout, else
    the most recent finished build in the cache. Raises :class:`OriginalSimulatorError` saying how to build it."""
    env = os.environ.get(ENV_BINARY)
    if env:
        path = Path(env)
        if not (path.is_file() and os.access(path, os.X_OK)):
            raise OriginalSimulatorError(f"${ENV_BINARY} is {env!r}, which is not an executable file")
        return path
    home = default_home()
    archive = default_archive()
    candidates: list[Path] = []
    root = repository_root()
    if archive is not None and root is not None:
        candidates.append(home / build_key(archive, root / "tools" / "original"))
    if home.is_dir():
        builds = [p for p in home.iterdir() if (p / BUILD_STAMP).is_file()]
        candidates += sorted(builds, key=lambda p: (p / BUILD_STAMP).stat().st_mtime, reverse=True)
    for folder in candidates:
        binary = folder.joinpath(*BINARY_PATH)
        if (folder / BUILD_STAMP).is_file() and binary.is_file():
            return binary
    raise OriginalSimulatorError(
        f"the original CRAFT simulator is not built (looked in {home}); build it with "
        "`bash tools/original/build.sh` from a craft_dsl checkout (it needs the original code's archive, "
        f"../shared/original-craft/craft-box2d-85c50b2.tar.gz), or set ${ENV_BINARY}")


def _with_parent(argv: Sequence[str]) -> list[str]:
    """``argv`` started so that Linux ends it when the thread that started it dies (no Xvfb or simulator outlives a
    killed craft_dsl process): through util-linux's ``setpriv --pdeathsig TERM`` where it is installed, else as is.

    The death signal is set by a program exec'd before the command, not by a ``preexec_fn``: Python code between
    fork and exec, in a process with other threads, frees those threads' thread-local objects in the child, and a
    library's object there (a PyAV scaler) waits forever on a lock its thread held at the fork."""
    setpriv = _setpriv()
    return [setpriv, "--pdeathsig", "TERM", "--", *argv] if setpriv else list(argv)


@functools.cache
def _setpriv() -> str | None:
    """util-linux's setpriv, where it has ``--pdeathsig`` (Linux only)."""
    if not sys.platform.startswith("linux"):
        return None
    found = shutil.which("setpriv")
    if found is None:
        return None
    try:
        done = subprocess.run([found, "--pdeathsig", "TERM", "--", "true"], stdin=subprocess.DEVNULL,
                              capture_output=True, timeout=10, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return found if done.returncode == 0 else None


def _kill_group(proc: subprocess.Popen[bytes]) -> None:
    """Kill a child started in its own session, with whatever it started."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()


# -- the X server ----------------------------------------------------------------------------------------


class _Display:
    """One private Xvfb per process, started on first use and stopped at exit (the display number chosen by Xvfb
    itself, so that parallel processes never collide)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._proc: subprocess.Popen[bytes] | None = None
        self._name: str | None = None

    def name(self) -> str:
        external = os.environ.get(ENV_DISPLAY)
        if external:
            return external
        with self._lock:
            if self._proc is not None and self._proc.poll() is None and self._name is not None:
                return self._name
            self._name = self._start()
            return self._name

    def _start(self) -> str:
        xvfb = shutil.which("Xvfb")
        if xvfb is None:
            raise OriginalSimulatorError("the original simulator draws with OpenGL and needs an X server: Xvfb is not "
                                         "installed (apt-get install xvfb), or set $" + ENV_DISPLAY)
        read_fd, write_fd = os.pipe()
        try:
            proc = subprocess.Popen(
                _with_parent([xvfb, "-displayfd", str(write_fd), "-screen", "0", "1024x768x24", "-nolisten", "tcp",
                              "-noreset"]),
                pass_fds=(write_fd,), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL, start_new_session=True)
        finally:
            os.close(write_fd)
        with os.fdopen(read_fd, "rb") as reader:
            number = reader.readline().strip()  # Xvfb writes its display number once it accepts connections
        if not number.isdigit():
            proc.kill()
            proc.wait()
            raise OriginalSimulatorError(f"Xvfb did not start (exit code {proc.returncode})")
        self._proc = proc
        atexit.register(self.stop)
        return f":{number.decode()}"

    def lost(self) -> bool:
        """True if this process started an X server that has since died (the next :meth:`name` starts another)."""
        return self._proc is not None and self._proc.poll() is not None

    def stop(self) -> None:
        proc, self._proc = self._proc, None
        if proc is not None and proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


_DISPLAY = _Display()


# -- the scene file --------------------------------------------------------------------------------------


def polygon_mass(vertices: Sequence[tuple[float, float]], density: float) -> tuple[float, float, float, float]:
    """Mass, centroid (x, y) and rotational inertia about the body origin of a solid polygon, as Box2D computes
    them for a polygon fixture."""
    area = cx = cy = inertia = 0.0
    n = len(vertices)
    for i in range(n):
        x1, y1 = vertices[i]
        x2, y2 = vertices[(i + 1) % n]
        cross = x1 * y2 - x2 * y1
        area += cross / 2
        cx += (x1 + x2) * cross / 6
        cy += (y1 + y2) * cross / 6
        inertia += cross * (x1 * x1 + x1 * x2 + x2 * x2 + y1 * y1 + y1 * y2 + y2 * y2) / 12
    return density * area, cx / area, cy / area, density * inertia


def original_polygon(body: BodySpec) -> tuple[tuple[float, float], ...]:
    """The polygon the original builds for a dynamic body (circles as 128-gons)."""
    geometry = body.geometry
    if geometry.circle_radius is not None:
        return regular_polygon(geometry.circle_radius, CIRCLE_SIDES)
    if len(geometry.polygons) != 1:
        raise OriginalSimulatorError(f"body {body.uid} ({body.shape}) has {len(geometry.polygons)} polygons; the "
                                     "original simulator makes every dynamic body of one polygon")
    return geometry.polygons[0]


def body_record(body: BodySpec) -> dict[str, Any]:
    """One body as the original's scene-from-JSON mode reads it (its geometry comes from shape and size)."""
    if body.dynamic:
        mass, cx, cy, inertia = polygon_mass(original_polygon(body), DENSITY)
    else:
        mass = cx = cy = inertia = 0.0
    for name, value in (("position", body.position), ("velocity", body.velocity),
                        ("angle", (body.angle, body.angular_velocity))):
        if not all(math.isfinite(v) for v in value):
            raise OriginalSimulatorError(f"body {body.uid} ({body.shape}): {name} {value} is not finite")
    return {
        "2dCoords": [body.position[0], body.position[1]],
        "2dLinearVelocity": [body.velocity[0], body.velocity[1]],
        "active": True,
        "allowSleep": True,
        "angle": body.angle,
        "angularDamping": 0.0,
        "angularVelocity": body.angular_velocity,
        "awake": True,
        "bodyType": 2 if body.dynamic else 0,
        "bullet": False,
        "color": body.color,
        "density": DENSITY,
        "fixedRotation": False,
        "friction": FRICTION,
        "gravityScale": 1.0,
        "linearDamping": 0.0,
        "massData-I": inertia,
        "massData-centerX": cx,
        "massData-centerY": cy,
        "massData-mass": mass,
        "restitution": RESTITUTION,
        "shape": body.shape,
        "size": body.size,
        "uniqueID": body.uid,
    }


def scene_file(world: WorldSpec) -> dict[str, Any]:
    """The step-0 scene of ``world`` as the original reads it (bodies in creation order)."""
    if world.gravity != (0.0, -15.0) or world.steps_per_second != 60:
        raise OriginalSimulatorError(f"the original simulator has gravity (0, -15) and 60 steps per second; this "
                                     f"world has gravity {world.gravity} and {world.steps_per_second}")
    shapes = {b.shape for b in world.bodies}
    missing = [s for s in ("wall_l", "wall_r", "ground", "basket") if s not in shapes]
    if missing:
        raise OriginalSimulatorError(f"a scene for the original simulator needs its walls, ground and basket; "
                                     f"missing: {', '.join(missing)}")
    objects = [body_record(b) for b in world.bodies]
    directions = {"above": [0, 1], "below": [0, -1], "left": [-1, 0], "right": [1, 0]}
    return {"scene_states": [{"step": 0, "scene": {"directions": directions, "objects": objects}}]}


# -- one run ---------------------------------------------------------------------------------------------


def run_binary(binary: Path, controller: Path, workdir: Path, env: dict[str, str], timeout: float, label: str,
               out_json: Path) -> dict[str, Any]:
    """Run the simulator on ``controller`` (in its own process group, ended with this process) and return the
    JSON object it wrote to ``out_json``. Not starting, running past ``timeout`` seconds, a non-zero exit and a
    missing or malformed output are each an :class:`OriginalSimulatorError` naming ``label``."""
    try:
        proc = subprocess.Popen(_with_parent([str(binary), str(controller)]), cwd=workdir, env=env,
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                start_new_session=True)
    except OSError as err:
        raise OriginalSimulatorError(f"could not start the original simulator {binary}: {err}") from None
    try:
        _, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        _kill_group(proc)
        raise OriginalSimulatorError(f"the original simulator ran past its time limit of {timeout:g} s on {label} "
                                     f"(set ${ENV_TIMEOUT} to change it)") from None
    except BaseException:  # interrupted: leave nothing running
        _kill_group(proc)
        raise
    if proc.returncode != 0:
        tail = stderr.decode(errors="replace").strip().splitlines()[-3:]
        code = proc.returncode
        cause = f"killed by signal {-code}" if code < 0 else f"exit code {code}"
        raise OriginalSimulatorError(f"the original simulator failed on {label} ({cause})"
                                     + (": " + " | ".join(tail) if tail else ""))
    try:
        output = json.loads(out_json.read_text())
    except FileNotFoundError:
        raise OriginalSimulatorError(f"the original simulator wrote no output file on {label}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise OriginalSimulatorError(f"the original simulator wrote a malformed output file on {label}: "
                                     f"{err}") from None
    if not isinstance(output, dict):
        raise OriginalSimulatorError(f"the original simulator wrote a malformed output file on {label}: "
                                     "not a JSON object")
    return output


@dataclass(frozen=True)
class OriginalRun:
    """What one run of the binary wrote: its output JSON (parsed) and the video, if one was asked for."""

    output: dict[str, Any]
    video: Path | None
    seconds: float


class OriginalSimulator:
    """Runs the built binary on WorldSpecs (thread-safe; each run in its own temporary folder)."""

    name = "original"

    def __init__(self, binary: Path | None = None, timeout: float | None = None) -> None:
        self.binary = binary if binary is not None else find_binary()
        self.workdir = self.binary.parent  # holds Data/ (textures, font), which the binary reads from its cwd
        env_timeout = os.environ.get(ENV_TIMEOUT)
        self.timeout = timeout if timeout is not None else float(env_timeout) if env_timeout else DEFAULT_TIMEOUT

    def run(self, world: WorldSpec, steps: int = DEFAULT_STEPS, video: str | os.PathLike[str] | None = None,
            what: str = "") -> OriginalRun:
        """Simulate ``world`` for ``steps`` steps; write the original renderer's MPEG-1 video to ``video`` if
        given. ``what`` names the run in error messages. A run that fails because the private X server went away
        is run once more on a new one."""
        return self._execute(world.scene_id if isinstance(world.scene_id, int) else 1, steps, video,
                             what or _describe(world), scene=scene_file(world))

    def run_fresh(self, scene_id: int, seed: int | None, steps: int = DEFAULT_STEPS,
                  video: str | os.PathLike[str] | None = None, what: str = "") -> OriginalRun:
        """Let the original sample scene ``scene_id`` itself and simulate it in the same run, as its own pipeline
        makes a video: seeded with ``seed`` through the build's edit (:data:`ENV_SEED`), or, with None, from the
        clock and the hardware. The output's step-0 scene is the start state it drew."""
        label = what or f"a fresh scene {scene_id} ({'unseeded' if seed is None else f'seed {seed}'})"
        return self._execute(scene_id, steps, video, label, seed=seed)

    def _execute(self, scene_id: int, steps: int, video: str | os.PathLike[str] | None, label: str, *,
                 scene: dict[str, Any] | None = None, seed: int | None = None) -> OriginalRun:
        """:meth:`_execute_once`, once more on a new X server where the private one went away."""
        try:
            return self._execute_once(scene_id, steps, video, label, scene=scene, seed=seed)
        except OriginalSimulatorError:
            if not _DISPLAY.lost():
                raise
            return self._execute_once(scene_id, steps, video, label, scene=scene, seed=seed)

    def _execute_once(self, scene_id: int, steps: int, video: str | os.PathLike[str] | None, label: str, *,
                      scene: dict[str, Any] | None = None, seed: int | None = None) -> OriginalRun:
        """One run of the binary: from ``scene`` (a step-0 scene file), or a scene the original samples itself
        (``scene`` None, seeded with ``seed``)."""
        import time

        if steps < 1:
            raise OriginalSimulatorError(f"steps must be at least 1, got {steps}")
        display = _DISPLAY.name()
        with tempfile.TemporaryDirectory(prefix="craft-original-") as tmp:
            folder = Path(tmp)
            scene_path, out_json = folder / "scene.json", folder / "out.json"
            out_video = folder / "out.mpg" if video is not None else None
            if scene is not None:
                scene_path.write_text(json.dumps(scene))
            controller = {
                "simulationID": scene_id, "offline": True, "width": VIDEO_SIZE, "height": VIDEO_SIZE,
                "inputScenePath": str(scene_path) if scene is not None else "",
                "outputVideoPath": str(out_video or ""),
                "outputJSONPath": str(out_json), "stepCount": steps, "noiseAmount": 0.0, "perturbationSeed": 0,
            }
            (folder / "controller.json").write_text(json.dumps(controller))
            env = dict(os.environ, DISPLAY=display)
            env.pop(ENV_SEED, None)
            if scene is None and seed is not None:
                env[ENV_SEED] = str(seed)
            if video is None:
                env[NO_DRAW] = "1"  # nothing is recorded, so nothing needs drawing (the build's own edit)
            start = time.perf_counter()
            output = run_binary(self.binary, folder / "controller.json", self.workdir, env, self.timeout, label,
                                out_json)
            seconds = time.perf_counter() - start
            kept: Path | None = None
            if video is not None and out_video is not None:
                if not out_video.is_file() or out_video.stat().st_size == 0:
                    raise OriginalSimulatorError(f"the original simulator wrote no video on {label}")
                kept = Path(video)
                with atomic_path(kept) as part:
                    shutil.copyfile(out_video, part)
        return OriginalRun(output, kept, seconds)

    def simulation(self, world: WorldSpec, steps: int = DEFAULT_STEPS, *, video: str | os.PathLike[str] | None = None,
                   meta: dict[str, Any] | None = None) -> OriginalSimulation:
        """The run of ``world`` as a :class:`OriginalSimulation` (counterfactuals made on demand)."""
        run = self.run(world, steps, video)
        return OriginalSimulation._from_run(self, world, steps, run, dict(meta or {}), ())


def _describe(world: WorldSpec) -> str:
    scene = f"scene {world.scene_id}" if world.scene_id is not None else "a custom scene"
    return f"{scene}" + (f" seed {world.seed}" if world.seed is not None else "")


def _load(output: dict[str, Any], label: str) -> Simulation:
    from ..recorded import load_simulation

    try:
        return load_simulation(output)
    except SimulationFileError as err:
        raise OriginalSimulatorError(f"the original simulator wrote a malformed output file on {label}: {err}") \
            from None


class OriginalSimulation(Simulation):
    """A run of the original simulator, read through the recorded-file loader.

    Attributes besides :class:`~craft_dsl.simulation.Simulation`'s: ``simulator``, ``output`` (the original's
    output JSON, as written), ``video`` (the path of its MPEG-1 video, if one was made) and ``seconds`` (the
    binary's wall time)."""

    simulator: OriginalSimulator
    output: dict[str, Any]
    video: Path | None
    seconds: float
    #: The seed of the original's own sampler, where the original drew this run's start state itself
    #: (:func:`craft_dsl.physics.original_sampler.simulate_fresh`): the video is then made the same way.
    sampler_seed: int | None = None

    @classmethod
    def _from_run(cls, simulator: OriginalSimulator, world: WorldSpec, steps: int, run: OriginalRun,
                  meta: dict[str, Any], removed: tuple[int, ...]) -> OriginalSimulation:
        loaded = _load(run.output, _describe(world))
        if loaded.steps != steps:
            raise OriginalSimulatorError(f"the original simulator ran {loaded.steps} steps on {_describe(world)}; "
                                         f"{steps} were asked for")
        expected = {b.uid for b in world.bodies}
        found = set(loaded.all_ids)
        if found != expected:
            raise OriginalSimulatorError(f"the original simulator's output on {_describe(world)} holds objects "
                                         f"{sorted(found)}; the scene has {sorted(expected)}")
        sim = cls(loaded.objects, loaded.events, steps=steps, causal_graph=loaded.causal_graph, world=world,
                  removed=removed, meta=dict(meta, engine="original"))
        sim._counterfactuals = sim._rerun_without
        sim.simulator = simulator
        sim.output = run.output
        sim.video = run.video
        sim.seconds = run.seconds
        return sim

    @property
    def world_spec(self) -> WorldSpec:
        assert self.world is not None
        return self.world

    def _rerun_without(self, uid: int) -> OriginalSimulation:
        spec = self.world_spec.body(uid)
        if spec.shape in ("ground", "basket"):
            raise CounterfactualUnavailable(
                f"cannot remove object {uid} ({spec.shape}): every scene needs its ground and basket")
        world = self.world_spec.without(uid)
        run = self.simulator.run(world, self.steps, what=f"{_describe(self.world_spec)} without object {uid}")
        return OriginalSimulation._from_run(self.simulator, world, self.steps, run, dict(self.meta),
                                            self.removed + (uid,))

    def counterfactual(self, object_id: int) -> OriginalSimulation:
        """The original's re-run of the same start state without ``object_id`` (lazy, cached)."""
        sim = super().counterfactual(object_id)
        assert isinstance(sim, OriginalSimulation)
        return sim

    def perturbed(self, seed: int, amount: float = 0.02) -> OriginalSimulation:
        """The whole scene re-run by the original from craft_dsl's seeded perturbation of the start state."""
        world = perturb_world(self.world_spec, seed, amount)
        meta = dict(self.meta, perturbation_seed=seed, perturbation_amount=amount)
        run = self.simulator.run(world, self.steps, what=f"{_describe(self.world_spec)} perturbed (seed {seed})")
        return OriginalSimulation._from_run(self.simulator, world, self.steps, run, meta, self.removed)


def simulate_original(world: WorldSpec, steps: int = DEFAULT_STEPS, *, video: str | os.PathLike[str] | None = None,
                      simulator: OriginalSimulator | None = None, meta: dict[str, Any] | None = None,
                      ) -> OriginalSimulation:
    """Run ``world`` with the original simulator (found by :func:`find_binary` unless given)."""
    return (simulator or OriginalSimulator()).simulation(world, steps, video=video, meta=meta)


def check(simulator: OriginalSimulator | None = None) -> str:
    """Build check: simulate scene 1 (seed 0) for 60 steps and describe the result; raises
    :class:`OriginalSimulatorError` if anything fails."""
    from ..scenes import sample_world

    sim = simulate_original(sample_world(1, 0), 60, simulator=simulator)
    return (f"original simulator {sim.simulator.binary}: scene 1 seed 0, 60 steps in {sim.seconds:.2f} s, "
            f"{len(sim.objects)} objects, {len(sim.events)} events")
