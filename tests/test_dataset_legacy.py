"""Datasets made before Box2D became the default engine, and before revision 2 of the layouts, stay what they were.

``tests/data/legacy_datasets.json`` holds, for one small dataset of each engine made by the code before the change
(pymunk then the default), and one of scenes 7 and 15 (the layouts revision 2 changed) made before that revision,
its ``generation_config.json`` and the SHA-256 of every file it wrote (the log, which holds times, and the Parquet
files, whose bytes name the pyarrow version, left out: the JSONL files hold the same rows). The dataset card names
the Parquet files only where pyarrow is installed, so the card made without it (by the same code, in an environment
without pyarrow) has a digest of its own. Each is resumed in its folder and regenerated from its configuration by
today's code, and must come out byte-identical; a configuration that names no engine means pymunk, one that names no
sampler revision 1 of the layouts.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
from pathlib import Path
from typing import Any

import pytest

from craft_dsl.cli import main
from craft_dsl.dataset import pipeline as P
from craft_dsl.dataset.samplers import DEFAULT_SAMPLER
from craft_dsl.errors import CraftError
from craft_dsl.vocabulary import DEFAULT_ENGINE, LEGACY_DEFAULT_ENGINE

LEGACY = json.loads((Path(__file__).parent / "data" / "legacy_datasets.json").read_text(encoding="utf-8"))
HAS_PYARROW = importlib.util.find_spec("pyarrow") is not None
for _made in LEGACY.values():  # the card this environment writes: with Parquet files or without
    if not HAS_PYARROW:
        _made["sha256"]["README.md"] = _made["card_sha256_without_pyarrow"]
#: The command line the engines' datasets were made with, less the engine (``LEGACY[name]["command"]``).
ARGS = ["--size", "6", "--scenes", "1-3", "--seed", "7", "--no-balance", "--quiet"]


def made_with(name: str) -> list[str]:
    """The options a legacy dataset was made with, less its engine."""
    words = LEGACY[name]["command"].split()[2:]
    if "--engine" in words:
        at = words.index("--engine")
        del words[at:at + 2]
    return [*words, "--quiet"]


def digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != P.LOG_FILE and p.suffix != ".parquet"}


def write_config(folder: Path, config: dict[str, Any]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "generation_config.json"
    path.write_text(json.dumps(config, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return path


def test_the_default_engine_is_box2d_and_the_legacy_one_pymunk() -> None:
    assert DEFAULT_ENGINE == "box2d"
    assert LEGACY_DEFAULT_ENGINE == "pymunk"
    assert P.GenerationConfig.make(size=1).engine == "box2d"


@pytest.mark.parametrize("name", sorted(LEGACY))
def test_a_legacy_dataset_resumes_byte_identically_without_naming_its_engine(tmp_path: Path, name: str) -> None:
    """The same command as before (no --engine, no --sampler) in the dataset's folder resumes with the engine it
    recorded and the layouts of its time."""
    legacy = LEGACY[name]
    config_path = write_config(tmp_path / "ds", legacy["config"])
    before = config_path.read_bytes()
    assert main(["generate", *made_with(name), "--out", str(tmp_path / "ds")]) == 0
    assert config_path.read_bytes() == before
    assert digests(tmp_path / "ds") == legacy["sha256"]


def test_a_config_that_names_no_engine_means_pymunk(tmp_path: Path) -> None:
    config = {k: v for k, v in LEGACY["pymunk"]["config"].items() if k != "engine"}
    config_path = write_config(tmp_path / "ds", config)
    before = config_path.read_bytes()
    assert P.recorded_engine(tmp_path / "ds") == "pymunk"
    assert main(["generate", *ARGS, "--out", str(tmp_path / "ds")]) == 0
    assert config_path.read_bytes() == before  # left as it was made
    expected = {k: v for k, v in LEGACY["pymunk"]["sha256"].items() if k != "generation_config.json"}
    got = digests(tmp_path / "ds")
    got.pop("generation_config.json")
    assert got == expected
    # naming another engine in that folder is refused, saying which one it was made with
    with pytest.raises(CraftError, match="engine 'pymunk' here, 'box2d' now"):
        P.generate_dataset(P.GenerationConfig.from_recorded({**config, "engine": "box2d"}), tmp_path / "ds")


@pytest.mark.parametrize("name", sorted(LEGACY))
def test_regenerated_from_its_config_file(tmp_path: Path, name: str) -> None:
    """``generate --config generation_config.json`` makes the same dataset in a new folder, and verify passes."""
    config_path = write_config(tmp_path / "old", LEGACY[name]["config"])
    out = tmp_path / "new"
    assert main(["generate", "--config", str(config_path), "--out", str(out), "--quiet"]) == 0
    assert digests(out) == LEGACY[name]["sha256"]
    assert main(["verify", "--dataset", str(out / "dataset.json"), "--annotations",
                 str(out / "annotations.json")]) == 0


#: The files that record the settings: they name the sampler in a dataset of revision 2.
SETTINGS_FILES = ("generation_config.json", "generation_report.json", "README.md")


def test_a_new_folder_gets_the_default_engine_and_sampler(tmp_path: Path) -> None:
    out = tmp_path / "new"
    assert main(["generate", *ARGS, "--out", str(out)]) == 0
    recorded = json.loads((out / "generation_config.json").read_text())
    assert (recorded["engine"], recorded["sampler"]) == (DEFAULT_ENGINE, DEFAULT_SAMPLER)
    # scenes 1-3 are the same in both revisions of the layouts: only the files naming the settings differ
    got, legacy = digests(out), LEGACY[DEFAULT_ENGINE]["sha256"]
    assert {k for k in got if got[k] != legacy.get(k)} == set(SETTINGS_FILES)
    assert set(got) == set(legacy)


def test_revision_2_changes_scenes_7_and_15_and_layouts_1_keeps_them(tmp_path: Path) -> None:
    """A new dataset of scenes 7 and 15 differs from the one made before revision 2 (seed 2 drops scene 7's 4th
    object in video 0; scene 15's platform moves by 0.4 mm, which changes none of these questions); asking for
    ``--sampler layouts-1`` gives the old questions again."""
    legacy = LEGACY["box2d_scenes_7_15"]["sha256"]
    new, old = tmp_path / "new", tmp_path / "old"
    assert main(["generate", *made_with("box2d_scenes_7_15"), "--out", str(new)]) == 0
    changed = {k for k, v in digests(new).items() if v != legacy.get(k)}
    assert "questions/qa_000000.json" in changed
    assert main(["generate", *made_with("box2d_scenes_7_15"), "--sampler", "layouts-1", "--out", str(old)]) == 0
    assert digests(old) == legacy  # layouts-1 is written as a legacy dataset: no sampler key at all


def test_config_refuses_content_options_and_bad_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config_path = write_config(tmp_path / "old", LEGACY["pymunk"]["config"])
    old = write_config(tmp_path / "older", {**LEGACY["pymunk"]["config"], "format_version": 2})
    odd = write_config(tmp_path / "odd", {**LEGACY["pymunk"]["config"], "colour": "red"})
    cases = [
        (["--config", str(config_path), "--size", "3", "--engine", "box2d"],
         "decides every setting of the dataset; drop --size, --engine"),
        (["--config", str(old)], "format_version 2, and this version of craft_dsl writes 3"),
        (["--config", str(odd)], "unknown settings colour"),
        (["--config", str(tmp_path / "missing.json")], "missing.json"),
        ([], "give --size N (the number of videos), or --config FILE"),
    ]
    for i, (args, message) in enumerate(cases):
        out = tmp_path / f"out{i}"
        assert main(["generate", *args, "--out", str(out)]) == 2
        assert message in capsys.readouterr().err
        assert not out.exists()  # nothing written
