"""The original CRAFT simulator's own scene sampler, seeded, read back as a :class:`~craft_dsl.world.WorldSpec`.

craft_dsl samples scenes from its layout files (:func:`craft_dsl.scenes.sample_world`). The original builds a fresh
random scene itself when its controller names no input scene (``"inputScenePath": ""``). This module runs that mode
and returns the start state it drew, so that the two samplers can be compared (``benchmarks/sampler_compare.py``).

The original draws positions, angles and speeds from ``std::random_device`` (a new ``mt19937`` seeded from the
hardware for every number) and shapes, sizes and colours from C ``rand()`` seeded with the clock. The build's own
edit (``tools/original/patch_sources.py``) makes both reproducible when the environment variable
``CRAFT_ORIGINAL_SEED`` holds an unsigned 32-bit integer: ``rand()`` is seeded with it, and every hardware seed is
replaced by the next number of one ``mt19937`` seeded with it. The same (scene, seed) then gives the same scene;
without the variable the binary behaves as the original.

The start state is the output's step-0 scene record: the original writes it after building the scene and before the
first world step, so a run of one step is enough.

>>> from craft_dsl.physics.original_sampler import sample_original
>>> world = sample_original(3, seed=7)   # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ..recorded import ObjectRecord
from ..vocabulary import COLORS, SHAPES, SIZES, STATIC_COLOR, STATIC_SIZE
from ..world import DEFAULT_STEPS, DENSITY, BodySpec, WorldSpec, make_dynamic, make_static
from .original import (
    ENV_SEED,
    OriginalSimulation,
    OriginalSimulator,
    OriginalSimulatorError,
    find_binary,
    original_polygon,
    polygon_mass,
)

__all__ = [
    "ENV_SEED",
    "SAMPLE_STEPS",
    "SCENE_IDS",
    "SEED_LIMIT",
    "check_seed",
    "run_fresh_scene",
    "sample_original",
    "sample_original_many",
    "simulate_fresh",
    "world_from_scene",
]

#: Seeds run from 0 to this (the edit takes an unsigned 32-bit integer).
SEED_LIMIT = 2**32 - 1
#: Steps a sampling run simulates: the step-0 record is written before the first step, and one is the fewest.
SAMPLE_STEPS = 1
#: The scenes the original generates (scene 0, its obstruction demo, has no basket and is left out).
SCENE_IDS = tuple(range(1, 21))
#: Relative difference allowed between the mass the original reports for a dynamic body and the mass of the
#: geometry craft_dsl gives its shape and size (the original writes single-precision floats).
MASS_TOLERANCE = 1e-4


def check_seed(seed: int | None) -> int | None:
    """``seed`` if it is None or an int in [0, :data:`SEED_LIMIT`]; else :class:`OriginalSimulatorError`."""
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= SEED_LIMIT:
        raise OriginalSimulatorError(f"a seed for the original's sampler must be an int from 0 to {SEED_LIMIT} "
                                     f"(or None for its own clock and hardware seeding), got {seed!r}")
    return seed


def _check_scene_id(scene_id: int) -> int:
    if isinstance(scene_id, bool) or not isinstance(scene_id, int) or scene_id not in SCENE_IDS:
        raise OriginalSimulatorError(f"the original's sampler makes scenes 1 to 20, got scene {scene_id!r}")
    return scene_id


def _label(scene_id: int, seed: int | None) -> str:
    return f"a fresh scene {scene_id} ({'unseeded' if seed is None else f'seed {seed}'})"


def run_fresh_scene(scene_id: int, seed: int | None, *, binary: Path | None = None, steps: int = SAMPLE_STEPS,
                    timeout: float | None = None) -> dict[str, Any]:
    """Run the original's controller on a freshly generated scene ``scene_id`` for ``steps`` steps, seeded with
    ``seed`` (None: the original's clock and hardware seeding), and return its output JSON (parsed, unchecked)."""
    _check_scene_id(scene_id)
    check_seed(seed)
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise OriginalSimulatorError(f"steps must be an int of at least 1, got {steps!r}")
    return OriginalSimulator(binary, timeout).run_fresh(scene_id, seed, steps, what=_label(scene_id, seed)).output


def _start_objects(output: Mapping[str, Any], label: str) -> list[Any]:
    """The object records of the output's step-0 scene."""
    states = output.get("scene_states")
    if not isinstance(states, list):
        raise OriginalSimulatorError(f"the original simulator's output on {label} has no scene_states list")
    start = [s for s in states if isinstance(s, dict) and s.get("step") == 0]
    if len(start) != 1:
        raise OriginalSimulatorError(f"the original simulator's output on {label} has {len(start)} step-0 scene "
                                     "records; one was expected")
    scene = start[0].get("scene")
    objects = scene.get("objects") if isinstance(scene, dict) else None
    if not isinstance(objects, list) or not objects:
        raise OriginalSimulatorError(f"the original simulator's output on {label} has no objects at step 0")
    return objects


def _body(raw: Any, index: int, label: str) -> BodySpec:
    where = f"{label}, step-0 object {index}"
    if not isinstance(raw, dict):
        raise OriginalSimulatorError(f"{where}: not a JSON object")
    try:
        rec = ObjectRecord.model_validate(raw)
    except ValidationError as err:
        first = err.errors()[0]
        field = ".".join(str(p) for p in first["loc"])
        raise OriginalSimulatorError(f"{where}: {field}: {first['msg']}") from None
    values = (*rec.coords, *rec.linear_velocity, rec.angle, rec.angularVelocity)
    if not all(math.isfinite(v) for v in values):
        raise OriginalSimulatorError(f"{where} ({rec.shape}): a position, angle or velocity is not finite")
    if rec.bodyType == 0:
        if (rec.color, rec.size) != (STATIC_COLOR, STATIC_SIZE):
            raise OriginalSimulatorError(f"{where}: static {rec.shape} is {rec.color} {rec.size}; every static "
                                         f"body is {STATIC_COLOR} {STATIC_SIZE}")
        try:
            body = make_static(rec.uniqueID, rec.shape, rec.coords, rec.angle)
        except ValueError as err:
            raise OriginalSimulatorError(f"{where}: {err}") from None
        return replace(body, velocity=rec.linear_velocity, angular_velocity=rec.angularVelocity)
    if rec.bodyType != 2:
        raise OriginalSimulatorError(f"{where}: bodyType {rec.bodyType}; the original makes static (0) and "
                                     "dynamic (2) bodies only")
    for name, value, allowed in (("shape", rec.shape, SHAPES), ("color", rec.color, COLORS),
                                 ("size", rec.size, SIZES)):
        if value not in allowed:
            raise OriginalSimulatorError(f"{where}: {name} {value!r}; allowed: {', '.join(allowed)}")
    body = make_dynamic(rec.uniqueID, rec.shape, rec.color, rec.size, rec.coords, rec.linear_velocity, rec.angle)
    body = replace(body, angular_velocity=rec.angularVelocity)
    mass = raw.get("massData-mass")
    if isinstance(mass, (int, float)):
        expected = polygon_mass(original_polygon(body), DENSITY)[0]
        if abs(mass - expected) > MASS_TOLERANCE * expected:
            raise OriginalSimulatorError(f"{where}: a {rec.size} {rec.shape} of mass {mass:g} kg; craft_dsl's "
                                         f"geometry for it has {expected:g} kg")
    return body


def world_from_scene(objects: Sequence[Any], scene_id: int | None = None, seed: int | None = None,
                     what: str = "the scene") -> WorldSpec:
    """A WorldSpec from the original's scene object records (as its output JSON and scene files hold them: in
    creation order, each with its uniqueID). Inverse of :func:`craft_dsl.physics.original.scene_file` for the
    fields a WorldSpec holds; geometry comes from each record's shape and size, and each dynamic body's reported
    mass is checked against it."""
    bodies = tuple(_body(raw, i, what) for i, raw in enumerate(objects))
    uids = [b.uid for b in bodies]
    if len(set(uids)) != len(uids):
        raise OriginalSimulatorError(f"{what}: uniqueIDs repeat: {uids}")
    return WorldSpec(bodies=bodies, scene_id=scene_id, seed=seed)


def sample_original(scene_id: int, seed: int | None, *, binary: Path | None = None,
                    timeout: float | None = None) -> WorldSpec:
    """The start state the original's own sampler draws for scene ``scene_id`` with ``seed`` (an int in
    [0, 2**32 - 1], or None for the original's unrepeatable clock and hardware seeding). The WorldSpec's ``seed`` is
    that seed of the original's sampler, not one of :func:`craft_dsl.scenes.sample_world`."""
    label = _label(scene_id, seed)
    output = run_fresh_scene(scene_id, seed, binary=binary, timeout=timeout)
    return world_from_scene(_start_objects(output, label), scene_id, seed, label)


def simulate_fresh(scene_id: int, seed: int, steps: int = DEFAULT_STEPS, *,
                   simulator: OriginalSimulator | None = None,
                   meta: Mapping[str, Any] | None = None) -> OriginalSimulation:
    """A video as the original pipeline makes it: the original samples scene ``scene_id`` with ``seed`` and
    simulates it in one run. The simulation's start state (``world_spec``) is that run's step-0 scene, from which
    its counterfactuals and perturbations are run, as the original pipeline runs them; its video
    (:func:`craft_dsl.dataset.layout.write_original_media`) is the same fresh run, drawn."""
    _check_scene_id(scene_id)
    check_seed(seed)
    runner = simulator or OriginalSimulator()
    label = _label(scene_id, seed)
    run = runner.run_fresh(scene_id, seed, steps, what=label)
    world = world_from_scene(_start_objects(run.output, label), scene_id, seed, label)
    sim = OriginalSimulation._from_run(runner, world, steps, run, dict(meta or {}), ())
    sim.sampler_seed = seed
    return sim


def sample_original_many(pairs: Iterable[tuple[int, int | None]], *, workers: int | None = None,
                         binary: Path | None = None, timeout: float | None = None) -> list[WorldSpec]:
    """:func:`sample_original` for each (scene id, seed) pair, ``workers`` binaries at a time (default: the
    number of CPUs), in the order given. Every pair is checked before any run starts; on the first failure the runs
    not yet started are cancelled and the error is raised once the running ones have finished."""
    jobs = [(_check_scene_id(scene), check_seed(seed)) for scene, seed in pairs]
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise OriginalSimulatorError(f"workers must be a positive int, got {workers!r}")
    exe = binary if binary is not None else find_binary()
    count = workers or os.cpu_count() or 1
    if not jobs:
        return []
    # Each run is a separate process (the binary); threads only wait on them.
    with ThreadPoolExecutor(max_workers=min(count, len(jobs))) as pool:
        futures = [pool.submit(sample_original, scene, seed, binary=exe, timeout=timeout) for scene, seed in jobs]
        try:
            return [f.result() for f in futures]
        except BaseException:
            for f in futures:
                f.cancel()
            raise

