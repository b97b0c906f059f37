"""``craft-dsl generate`` over custom scene layout files: parsing ``--scenes``/``--downsampled``, the recorded
layout (resume refuses a changed file), the records and folders of a custom scene, determinism."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import pytest

from craft_dsl.cli import main
from craft_dsl.dataset import pipeline as P
from craft_dsl.dataset.custom_scenes import CustomScene, canonical_json, recorded_layout
from craft_dsl.errors import CraftError
from craft_dsl.ranges import parse_scenes
from craft_dsl.resources import data_dir
from craft_dsl.scenes import load_layout_file, load_scene, sample_world

#: A small run: two videos of built-in scene 1, two of the custom layout.
RUN = ["generate", "--size", "4", "--steps", "120", "--perturbations", "0", "--no-balance", "--quiet"]
#: The same settings for the Python API.
SETTINGS: dict[str, Any] = {"size": 4, "steps": 120, "perturbations": 0, "balance": False}


def write_layout(path: Path, scene: int = 21, top: tuple[float, float] = (27, 34), indent: int = 2) -> Path:
    """Scene 3's layout with its own id and the first object's drop height range changed."""
    data = json.loads((data_dir("scenes") / "scene_03.json").read_text())
    data["scene"] = scene
    data["dynamic"][0]["position"][1] = {"uniform": list(top)}
    path.write_text(json.dumps(data, indent=indent))
    return path


def hashes(folder: Path) -> dict[str, str]:
    """Every file's hash, the log (which holds times) left out."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != P.LOG_FILE}


# -- parsing -------------------------------------------------------------------------------------------------


def test_scenes_mix_ids_ranges_and_files(tmp_path: Path) -> None:
    layout = write_layout(tmp_path / "ramp.json")
    assert parse_scenes(f"1-3,{layout}") == [1, 2, 3, layout]
    config = P.GenerationConfig.make(size=4, scenes=tuple(parse_scenes(f"1-3,{layout}")))
    assert config.scene_ids == (1, 2, 3, 21)
    custom = config.scenes[3]
    assert isinstance(custom, CustomScene) and custom.source == str(layout)
    assert custom.layout == canonical_json(load_layout_file(layout))
    assert custom.sha256 == hashlib.sha256(custom.layout.encode()).hexdigest()
    # the layout rebuilt from the record draws the same worlds as the file
    assert sample_world(custom.load(), 7) == sample_world(layout, 7)
    # formatting is not content: a re-indented copy is the same scene
    same = write_layout(tmp_path / "copy.json", indent=4)
    assert P.GenerationConfig.make(size=1, scenes=(same,)).recorded() == P.GenerationConfig.make(
        size=1, scenes=(layout,)).recorded()


def test_the_canonical_json_keeps_the_order_of_the_random_draws() -> None:
    for scene in (8, 9, 11):  # variables that read earlier ones: their order is the order of the draws
        custom = CustomScene.of(load_scene(scene))
        assert sample_world(custom.load(), 3) == sample_world(scene, 3)


@pytest.mark.parametrize(("scenes", "message"), [
    ("1,x", "--scenes '1,x': 'x' is not one of the scene ids or a range of them; allowed: 1-20, e.g. 1,3,5-8, or a "
            "scene layout file (a path ending in .json)"),
    ("1-25", "--scenes '1-25': '1-25' is outside 1-20"),
    ("2,0", "--scenes '2,0': '0' is outside 1-20"),
    ("2,missing/ramp.json", "--scenes '2,missing/ramp.json': 'missing/ramp.json': not a scene id (1-20) nor a scene "
                            "layout file (no such file)"),
    ("1,1", "scene id 1 appears twice (built-in scene 1; built-in scene 1)"),
])
def test_bad_scenes_are_exit_2_naming_the_option_and_part(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                         scenes: str, message: str) -> None:
    assert main([*RUN, "--scenes", scenes, "--out", str(tmp_path / "out")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out" / "generation_config.json").exists()


def test_bad_downsampled_frame_rates(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for bad, message in (("5,x", "--downsampled '5,x': 'x' is not one of the frame rates or a range of them; "
                                  "allowed: 1-60"),
                         ("0,10", "--downsampled '0,10': '0' is outside 1-60"),
                         ("30-90", "'30-90' is outside 1-60")):
        assert main([*RUN, "--videos", "--downsampled", bad, "--out", str(tmp_path / "out")]) == 2
        assert message in capsys.readouterr().err


def test_a_bad_layout_file_names_the_file_and_field(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    data = json.loads((data_dir("scenes") / "scene_03.json").read_text())
    data["dynamic"][1]["shape"] = "hexagon"
    bad.write_text(json.dumps(data))
    assert main([*RUN, "--scenes", str(bad), "--out", str(tmp_path / "out")]) == 2
    assert f"{bad}: dynamic[1].shape: 'hexagon' is not one of cube, triangle, circle" in capsys.readouterr().err


def test_layout_ids_must_be_their_own(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a = write_layout(tmp_path / "a.json")
    b = write_layout(tmp_path / "b.json", top=(30, 33))
    assert main([*RUN, "--scenes", f"{a},{b}", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "scene id 21 appears twice" in err and str(a) in err and str(b) in err
    # a changed copy of scene 3 that keeps id 3 would pass for the built-in scene 3
    changed = write_layout(tmp_path / "three.json", scene=3)
    assert main([*RUN, "--scenes", str(changed), "--out", str(tmp_path / "out")]) == 2
    assert "id 3 is the built-in scene 3's, and the layout differs from it" in capsys.readouterr().err
    with pytest.raises(CraftError, match=r"bad generation config: scenes: .*three.json: its \"scene\" id 3"):
        P.GenerationConfig.make(size=1, scenes=(changed,))
    # an unchanged copy is the built-in scene
    copy = tmp_path / "copy.json"
    copy.write_text((data_dir("scenes") / "scene_03.json").read_text())
    assert P.GenerationConfig.make(size=1, scenes=(copy,)).scenes == (3,)
    # a hand-made record must be consistent
    custom = CustomScene.of(load_layout_file(a))
    with pytest.raises(ValueError, match="sha256 is not the hash of layout"):
        CustomScene(scene=21, sha256="0" * 64, layout=custom.layout)


# -- generation ----------------------------------------------------------------------------------------------


def test_generate_over_a_custom_layout(tmp_path: Path) -> None:
    (tmp_path / "my_layouts").mkdir()
    layout = write_layout(tmp_path / "my_layouts" / "ramp.json")
    out = tmp_path / "out"
    assert main([*RUN, "--scenes", f"1,{layout}", "--out", str(out)]) == 0
    videos = json.loads((out / "dataset.json").read_text())  # one element per video with questions, ascending
    assert [(v["simulation_id"], v["video_path"]) for v in videos] == [
        ("1", "./videos/sid_1/000000.mpg"), ("1", "./videos/sid_1/000001.mpg"),
        ("21", "./videos/sid_21/000002.mpg"), ("21", "./videos/sid_21/000003.mpg")]
    minimal = json.loads((out / "dataset_minimal.json").read_text())
    assert {r["video_file_path"].split("/")[2] for r in minimal} == {"sid_1", "sid_21"}
    assert {r["simulation_id"] for r in minimal if r["video_index"] >= 2} == {"21"}
    assert json.loads((out / "questions" / "qa_000002.json").read_text())["stats"]["scene"] == 21
    # the custom scene is held out by the hard split
    hard = json.loads((out / "split_info_hard.json").read_text())
    assert {k["video_index"] for k in hard["test"]} == {2, 3}
    # the recorded settings hold the layout itself, not the path
    recorded = json.loads((out / "generation_config.json").read_text())
    assert recorded["scenes"][0] == 1 and set(recorded["scenes"][1]) == {"scene", "sha256", "layout"}
    assert "ramp.json" not in (out / "generation_config.json").read_text()
    # the recorded layout re-simulates the videos (as the viewer does), and the worker drew from it
    rebuilt = recorded_layout(recorded, 21)
    assert rebuilt is not None and sample_world(rebuilt, 5) == sample_world(layout, 5)
    annotation = json.loads((out / "annotations.json").read_text())
    assert len(annotation) == 4
    from craft_dsl.viewer import ViewerData

    data = ViewerData(out)
    assert data.resimulation_unavailable(2) is None
    live = data.live(2)  # raises if its events differ from the recorded ones
    assert live.world.scene_id == 21
    # the user's file is not read again: resuming works after it was moved away
    layout.rename(tmp_path / "elsewhere.json")
    before = hashes(out)
    assert P.generate_dataset(P.GenerationConfig.make(size=4, steps=120, perturbations=0, balance=False,
                                                      scenes=(1, tmp_path / "elsewhere.json")), out)["resumed"] == 4
    assert hashes(out) == before


def test_resume_refuses_a_changed_layout_and_force_starts_over(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    layout = write_layout(tmp_path / "ramp.json")
    out = tmp_path / "out"
    args = [*RUN, "--size", "2", "--scenes", str(layout), "--out", str(out)]
    assert main(args) == 0
    first = hashes(out)
    write_layout(layout, indent=8)  # re-indented: the same layout, the run resumes
    assert main(args) == 0 and hashes(out) == first
    write_layout(layout, top=(28, 30))  # changed: refused, nothing lost
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "holds a dataset generated with other settings (scenes [21 (layout sha256 " in err and "--force" in err
    assert hashes(out) == first
    assert main([*args, "--force"]) == 0
    assert hashes(out) != first
    assert json.loads((out / "generation_config.json").read_text())["scenes"][0]["layout"] == canonical_json(
        load_layout_file(layout))


def test_same_seed_and_layout_give_the_same_bytes_and_workers_never_read_the_file(tmp_path: Path) -> None:
    layout = write_layout(tmp_path / "ramp.json")
    assert main([*RUN, "--scenes", f"{layout},2", "--out", str(tmp_path / "a")]) == 0
    assert main([*RUN, "--scenes", f"{layout},2", "--out", str(tmp_path / "b")]) == 0
    reference = hashes(tmp_path / "a")
    assert hashes(tmp_path / "b") == reference
    assert "videos/sid_21" in (tmp_path / "a" / "dataset.json").read_text()
    # the configuration holds the layout: the worker processes run with the file gone
    config = P.GenerationConfig.make(**SETTINGS, scenes=(layout, 2), workers=2)
    layout.unlink()
    P.generate_dataset(config, tmp_path / "c")
    assert hashes(tmp_path / "c") == reference


def test_a_dask_cluster_gets_the_layout_in_its_tasks(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed", reason="the Dask executor needs the dask extra: "
                                                            "pip install 'craft-dsl[dask]'")
    from craft_dsl.dataset.executors import DaskExecutor

    layout = write_layout(tmp_path / "ramp.json")
    assert main([*RUN, "--scenes", f"1,{layout}", "--out", str(tmp_path / "local")]) == 0
    config = P.GenerationConfig.make(**SETTINGS, scenes=(1, layout))
    layout.unlink()
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) \
            as cluster:
        P.generate_dataset(config, tmp_path / "dask", executor=DaskExecutor(cluster.scheduler_address))
    assert hashes(tmp_path / "dask") == hashes(tmp_path / "local")
