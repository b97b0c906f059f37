"""The original CRAFT simulator's own scene sampler, seeded through the build's edit (CRAFT_ORIGINAL_SEED).

The tests that run the real binary need it built (``bash tools/original/build.sh``) and are skipped, saying so,
where it is not. Reading scene records and every failure of the binary are tested everywhere, with small stand-in
programs where a binary is needed.
"""

from __future__ import annotations

import json
import os
import subprocess
from collections import Counter
from pathlib import Path

import pytest
from original_helpers import needs_binary, stand_in
from scipy import stats

from craft_dsl.physics import original as orig
from craft_dsl.physics import original_sampler as osamp
from craft_dsl.physics.original import OriginalSimulatorError
from craft_dsl.physics.original_sampler import sample_original, sample_original_many, world_from_scene
from craft_dsl.scenes import sample_world
from craft_dsl.vocabulary import COLORS, SHAPES, SIZES
from craft_dsl.world import WorldSpec


def _records(world: WorldSpec) -> list[dict[str, object]]:
    objects = orig.scene_file(world)["scene_states"][0]["scene"]["objects"]
    assert isinstance(objects, list)
    return objects


# -- reading scene records (no binary needed) -------------------------------------------------------------------


@pytest.mark.parametrize("layout", [1, 2, 11, 13, 20])
def test_scene_records_read_back_into_the_same_world(layout: int) -> None:
    world = sample_world(layout, 3)
    back = world_from_scene(_records(world), world.scene_id, world.seed)
    assert back == world


@pytest.mark.parametrize(("change", "message"), [
    ({"shape": "hexagon"}, "shape 'hexagon'; allowed: cube, triangle, circle"),
    ({"color": "black"}, "color 'black'; allowed: gray"),
    ({"size": "huge"}, "size 'huge'; allowed: small, large"),
    ({"bodyType": 1}, "bodyType 1"),
    ({"2dCoords": [0.0]}, "2dCoords"),
    ({"massData-mass": 1.0}, "mass 1 kg; craft_dsl's geometry for it has"),
])
def test_a_malformed_dynamic_record_is_one_error_naming_it(change: dict[str, object], message: str) -> None:
    records = _records(sample_world(1, 0))
    records[-1] = dict(records[-1], **change)
    with pytest.raises(OriginalSimulatorError, match=f"^the scene, step-0 object {len(records) - 1}.*{message}"):
        world_from_scene(records, 1, 0)


def test_static_records_and_uids_are_checked() -> None:
    records = _records(sample_world(1, 0))
    with pytest.raises(OriginalSimulatorError, match="static platform is red large"):
        world_from_scene([dict(r, color="red") if r["shape"] == "platform" else r for r in records])
    with pytest.raises(OriginalSimulatorError, match="unknown static shape 'table'"):
        world_from_scene([dict(records[0], shape="table")] + records[1:])
    with pytest.raises(OriginalSimulatorError, match="uniqueIDs repeat"):
        world_from_scene([dict(r, uniqueID=0) for r in records])


@pytest.mark.parametrize(("scene", "seed", "message"), [
    (0, 1, "scenes 1 to 20, got scene 0"), (21, 1, "got scene 21"), (1, -1, "from 0 to 4294967295"),
    (1, 2**32, "got 4294967296"), (1, True, "got True"), (1, 1.5, "got 1.5"),
])
def test_bad_scene_ids_and_seeds_are_refused_before_any_run(scene: int, seed: int, message: str) -> None:
    with pytest.raises(OriginalSimulatorError, match=message):
        sample_original(scene, seed, binary=Path("/nonexistent/Testbed"))
    with pytest.raises(OriginalSimulatorError, match=message):
        sample_original_many([(1, 1), (scene, seed)], binary=Path("/nonexistent/Testbed"))


_OUT = "$(sed -n 's/.*\"outputJSONPath\": \"\\([^\"]*\\)\".*/\\1/p' \"$1\")"


@pytest.mark.parametrize(("body", "message"), [
    ("echo 'bad seed' >&2; exit 2", r"failed on a fresh scene 4 \(seed 9\) \(exit code 2\): bad seed"),
    ("exit 0", "wrote no output file on a fresh scene 4"),
    (f"echo '[1]' > \"{_OUT}\"", "not a JSON object"),
    (f"echo '{{\"scene_states\": []}}' > \"{_OUT}\"", "0 step-0 scene records"),
    (f"echo '{{\"scene_states\": [{{\"step\": 0, \"scene\": {{\"objects\": null}}}}]}}' > \"{_OUT}\"",
     "no objects at step 0"),
    ("sleep 30", "ran past its time limit of 1 s on a fresh scene 4"),
])
def test_every_failure_of_the_binary_is_one_error(body: str, message: str, tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(orig.ENV_DISPLAY, ":424242")  # the stand-ins draw nothing
    with pytest.raises(OriginalSimulatorError, match=message):
        sample_original(4, 9, binary=stand_in(tmp_path, body), timeout=1)


def test_the_stand_in_gets_a_fresh_scene_controller_and_the_seed(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(orig.ENV_DISPLAY, ":424242")
    monkeypatch.setenv(osamp.ENV_SEED, "123")  # the caller's own value never leaks into an unseeded run
    keep = tmp_path / "seen"
    body = f"cp \"$1\" {keep}.json; echo \"${{{osamp.ENV_SEED}-unset}} $CRAFT_ORIGINAL_NO_DRAW\" > {keep}.env; exit 5"
    binary = stand_in(tmp_path, body)
    for seed, expected in ((77, "77 1"), (None, "unset 1")):
        with pytest.raises(OriginalSimulatorError):
            sample_original(6, seed, binary=binary)
        controller = json.loads(Path(f"{keep}.json").read_text())
        assert controller["inputScenePath"] == "" and controller["simulationID"] == 6
        assert controller["stepCount"] == osamp.SAMPLE_STEPS and controller["outputVideoPath"] == ""
        assert Path(f"{keep}.env").read_text().strip() == expected


# -- the real binary --------------------------------------------------------------------------------------------


@needs_binary
def test_the_same_seed_gives_the_same_scene_and_another_seed_another() -> None:
    a, b, c = sample_original_many([(1, 5), (1, 5), (1, 6)], workers=2)
    assert a == b and a.seed == 5 and a.scene_id == 1
    assert c != a
    assert [x.position for x in a.bodies if x.dynamic] != [x.position for x in c.bodies if x.dynamic]


@needs_binary
def test_unseeded_runs_keep_the_originals_own_randomness() -> None:
    a, b = sample_original_many([(1, None), (1, None)], workers=2)
    assert a.seed is None and a != b  # positions come from the hardware, even within one second


@needs_binary
def test_a_malformed_seed_variable_stops_the_binary_with_a_message() -> None:
    binary = orig.find_binary()
    env = dict(os.environ, **{osamp.ENV_SEED: "12x"})
    done = subprocess.run([str(binary), "/nonexistent/controller.json"], cwd=binary.parent, env=env,
                          capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 2 and "CRAFT_ORIGINAL_SEED must be an unsigned 32-bit decimal integer" in done.stderr


@needs_binary
def test_every_layout_has_the_object_counts_and_static_shapes_of_ours() -> None:
    worlds = sample_original_many([(layout, 1000 + layout) for layout in osamp.SCENE_IDS], workers=2)
    for layout, world in zip(osamp.SCENE_IDS, worlds):
        ours = sample_world(layout, 0)
        n_static = sum(not b.dynamic for b in ours.bodies)
        assert [b.shape for b in world.bodies if not b.dynamic] == [b.shape for b in ours.bodies if not b.dynamic]
        n_dynamic = sum(b.dynamic for b in world.bodies)
        expected = {3, 4} if layout == 7 else {len(ours.bodies) - n_static}  # scene 7 may drop its 4th object
        assert n_dynamic in expected, layout
        assert [b.uid for b in world.bodies] == list(range(len(world.bodies) - 1, -1, -1))
        assert all(b.angle == pytest.approx(3.14159265, abs=1e-6) for b in world.bodies if b.dynamic)


RUNS = 24


@pytest.fixture(scope="module")
def samples() -> dict[int, tuple[list[WorldSpec], list[WorldSpec]]]:
    layouts = (1, 2)
    worlds = sample_original_many([(layout, 50_000 + k) for layout in layouts for k in range(RUNS)], workers=2)
    return {layout: (worlds[i * RUNS:(i + 1) * RUNS], [sample_world(layout, k) for k in range(RUNS)])
            for i, layout in enumerate(layouts)}


@needs_binary
def test_shapes_sizes_and_colours_come_from_the_same_sets_and_frequencies(
        samples: dict[int, tuple[list[WorldSpec], list[WorldSpec]]]) -> None:
    # Layout 1: five objects of random shape, size and colour; layout 2: six small cubes and four circles.
    for attribute, allowed in (("shape", SHAPES), ("size", SIZES), ("color", COLORS)):
        theirs = Counter(getattr(b, attribute) for w in samples[1][0] for b in w.bodies if b.dynamic)
        ours = Counter(getattr(b, attribute) for w in samples[1][1] for b in w.bodies if b.dynamic)
        assert set(theirs) == set(ours) == set(allowed), attribute
        table = [[theirs[v] for v in allowed], [ours[v] for v in allowed]]
        assert stats.chi2_contingency(table).pvalue > 1e-3, (attribute, table)
    for worlds in samples[2]:  # the six cubes have six colours, the four circles four
        for w in worlds:
            dyn = [b for b in w.bodies if b.dynamic]
            assert [b.shape for b in dyn] == ["cube"] * 6 + ["circle"] * 4
            assert {b.size for b in dyn[:6]} == {"small"}
            assert len({b.color for b in dyn[:6]}) == 6 and len({b.color for b in dyn[6:]}) == 4


@needs_binary
def test_random_positions_and_speeds_cover_the_same_ranges(
        samples: dict[int, tuple[list[WorldSpec], list[WorldSpec]]]) -> None:
    theirs, ours = samples[1]
    # layout 1: basket x ~ U(-3, 3); the first object's x ~ U(-10, -7); the fourth's y ~ U(35, 45)
    for pick in (lambda w: w.bodies[3].position[0], lambda w: [b for b in w.bodies if b.dynamic][0].position[0],
                 lambda w: [b for b in w.bodies if b.dynamic][3].position[1]):
        a, b = [pick(w) for w in theirs], [pick(w) for w in ours]
        assert stats.ks_2samp(a, b).pvalue > 1e-3
    theirs, ours = samples[2]
    speeds = {[b for b in w.bodies if b.dynamic][6].velocity[0] for w in theirs}  # a choice among five speeds
    assert speeds <= {-24.0, -28.0, -25.0, -18.0, -19.0} and len(speeds) >= 3
