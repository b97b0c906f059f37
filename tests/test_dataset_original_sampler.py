"""Datasets whose start states the original simulator's own sampler draws (``generate --sampler original``).

With ``--engine original`` too, each video is made as the original pipeline makes it: one run of the original that
samples the scene (seeded through the build's edit) and simulates it; counterfactuals and perturbations from its
step-0 scene. Seeded, so the same command gives the same bytes."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from original_helpers import needs_binary

from craft_dsl.cli import main
from craft_dsl.dataset import GenerationConfig
from craft_dsl.dataset.instance import instance_seeds
from craft_dsl.errors import CraftError
from craft_dsl.physics.original_sampler import run_fresh_scene, sample_original, simulate_fresh
from craft_dsl.recorded import load_simulation

SMALL = ["--size", "2", "--scenes", "7,15", "--seed", "11", "--steps", "90", "--perturbations", "1",
         "--no-balance", "--quiet", "--sampler", "original"]


def digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != "generation.log"}


def _start(records: list[dict[str, object]]) -> list[tuple[object, ...]]:
    return sorted((r["uniqueID"], r["shape"], r["color"], r["size"], tuple(r["2dCoords"]),  # type: ignore[arg-type]
                   tuple(r["2dLinearVelocity"])) for r in records)  # type: ignore[arg-type]


def test_the_original_sampler_takes_built_in_scenes_only(tmp_path: Path) -> None:
    layout = tmp_path / "mine.json"
    layout.write_text(json.dumps({"scene": 31, "basket": {"position": [0, -1.2]},
                                  "dynamic": [{"position": [0, 20]}]}))
    with pytest.raises(CraftError, match="sampler original draws the 20 built-in scenes only"):
        GenerationConfig.make(size=1, scenes=(1, str(layout)), sampler="original")
    with pytest.raises(CraftError, match="sampler"):
        GenerationConfig.make(size=1, sampler="mine")


@needs_binary
def test_a_fresh_run_is_the_run_the_original_makes_itself() -> None:
    """simulate_fresh's factual run is the original's own run of a scene it samples (node ids aside: they are
    pointers), and its start state is what the sampler alone draws."""
    sim = simulate_fresh(3, 1003, 120)
    direct = load_simulation(run_fresh_scene(3, 1003, steps=120))
    assert [(e.type, e.step, e.objects) for e in sim.events] == [(e.type, e.step, e.objects) for e in direct.events]
    assert sim.world_spec == sample_original(3, 1003)
    assert sim.sampler_seed == 1003


@needs_binary
def test_generate_as_the_original_pipeline_is_seeded_and_reproducible(tmp_path: Path) -> None:
    one, two = tmp_path / "one", tmp_path / "two"
    assert main(["generate", *SMALL, "--engine", "original", "--videos", "--out", str(one)]) == 0
    assert main(["generate", *SMALL, "--engine", "original", "--videos", "--workers", "2", "--out", str(two)]) == 0
    assert digests(one) == digests(two)
    recorded = json.loads((one / "generation_config.json").read_text())
    assert (recorded["engine"], recorded["sampler"]) == ("original", "original")
    assert main(["verify", "--dataset", str(one / "dataset.json"), "--annotations",
                 str(one / "annotations.json")]) == 0
    # each video's start state is the one the original's sampler draws with the video's simulation seed
    annotations = json.loads((one / "annotations.json").read_text())
    for instance, scene in ((0, 7), (1, 15)):
        sim_seed = instance_seeds(11, instance)[0]
        world = sample_original(scene, sim_seed)
        entry = next(v for k, v in annotations.items() if int(k) == instance)
        objects = entry["original_video_output"]["scene_states"][0]["scene"]["objects"]
        expected = [(b.uid, b.shape, b.color, b.size, b.position, b.velocity) for b in world.bodies]
        assert _start(objects) == sorted(expected)
    assert (one / "videos" / "sid_7" / "000000.mpg").stat().st_size > 0


@needs_binary
def test_the_original_sampler_with_another_engine(tmp_path: Path) -> None:
    """Start states from the original's sampler, simulated by Box2D: the scenes the original draws, faster."""
    out = tmp_path / "b"
    assert main(["generate", *SMALL, "--engine", "box2d", "--out", str(out)]) == 0
    annotations = json.loads((out / "annotations.json").read_text())
    entry = next(v for k, v in annotations.items() if int(k) == 0)
    objects = entry["original_video_output"]["scene_states"][0]["scene"]["objects"]
    world = sample_original(7, instance_seeds(11, 0)[0])
    assert {o["uniqueID"] for o in objects} == {b.uid for b in world.bodies}
