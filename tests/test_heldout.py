"""craft-dsl heldout: a held-out evaluation set from a fresh seed, made by the generate pipeline, with its card."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from craft_dsl import __version__
from craft_dsl.cli import main
from craft_dsl.dataset.heldout import HELDOUT_FILE, SECTION_TITLE, fresh_seed
from craft_dsl.dataset.pipeline import GenerationConfig, generate_dataset

#: Tiny settings: one short video of each of two scenes, one perturbation.
TINY = ["--size", "2", "--scenes", "1-2", "--steps", "120", "--perturbations", "1", "--workers", "1", "--no-balance"]


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("heldout") / "eval"
    assert main(["heldout", "--out", str(out), *TINY, "--quiet"]) == 0
    return out


def test_the_command_makes_a_dataset_with_videos_from_a_fresh_seed(made: Path) -> None:
    record = json.loads((made / HELDOUT_FILE).read_text())
    config = json.loads((made / "generation_config.json").read_text())
    assert record["seed_source"] == "os.urandom" and 0 <= record["seed"] < 2**63
    assert config["seed"] == record["seed"] and config["videos"] is True and config["engine"] == "box2d"
    assert len(list((made / "videos").rglob("*.mpg"))) + len(list(made.glob("videos_with_no_questions/**/*.mpg"))) == 2
    assert json.loads((made / "dataset_minimal.json").read_text())
    assert main(["verify", "--dataset", str(made / "dataset.json"), "--annotations",
                 str(made / "annotations.json")]) == 0


def test_the_card_says_how_the_set_was_made(made: Path) -> None:
    record = json.loads((made / HELDOUT_FILE).read_text())
    card = (made / "README.md").read_text()
    seed = str(record["seed"])
    assert card.startswith("---\n") and card.count(SECTION_TITLE) == 1
    section = card[card.index(SECTION_TITLE):card.index("\n## ", card.index(SECTION_TITLE))]
    assert f"craft-dsl heldout --out {made} --size 2 --seed {seed} --scenes 1-2 --steps 120 --perturbations 1" \
           " --no-balance" in section
    assert "drawn from `os.urandom`" in section and "`box2d`" in section and f"`{__version__}`" in section
    assert "No model can have trained on this set unless that model" in section and "was given the seed" in section
    assert "## Loading" in card and "## Generation settings" in card  # generate's card is kept around it


def test_resuming_without_a_seed_keeps_the_recorded_one(made: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = json.loads((made / HELDOUT_FILE).read_text())
    data = (made / "dataset.json").read_bytes()
    assert main(["heldout", "--out", str(made), *TINY]) == 0
    assert f"resuming the held-out set of seed {before['seed']}" in capsys.readouterr().err
    assert json.loads((made / HELDOUT_FILE).read_text()) == before
    assert (made / "dataset.json").read_bytes() == data
    assert (made / "README.md").read_text().count(SECTION_TITLE) == 1


def test_a_given_seed_gives_the_bytes_generate_gives(tmp_path: Path) -> None:
    args = ["--size", "1", "--scenes", "3", "--steps", "60", "--perturbations", "0", "--workers", "1", "--no-balance"]
    assert main(["heldout", "--out", str(tmp_path / "h"), "--seed", "11", *args, "--quiet"]) == 0
    generate_dataset(GenerationConfig.make(size=1, seed=11, scenes=(3,), steps=60, perturbations=0, balance=False,
                                           videos=True), tmp_path / "g")
    for name in ("dataset.json", "annotations.json", "generation_config.json"):
        assert (tmp_path / "h" / name).read_bytes() == (tmp_path / "g" / name).read_bytes()
    videos = sorted(p.relative_to(tmp_path / "g") for p in (tmp_path / "g").rglob("*.mpg"))
    assert videos and all((tmp_path / "h" / v).read_bytes() == (tmp_path / "g" / v).read_bytes() for v in videos)
    record = json.loads((tmp_path / "h" / HELDOUT_FILE).read_text())
    assert record["seed"] == 11 and record["seed_source"] == "given"
    assert "(given on the command line)" in (tmp_path / "h" / "README.md").read_text()


def test_fresh_seeds_differ() -> None:
    seeds = {fresh_seed() for _ in range(8)}
    assert len(seeds) == 8 and all(0 <= s < 2**63 for s in seeds)


def test_bad_size_is_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["heldout", "--out", str(tmp_path / "x"), "--size", "0"]) == 2
    assert "error: --size" in capsys.readouterr().err


def test_a_folder_of_another_seed_or_dataset_is_refused_and_left_alone(made: Path, tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    record = (made / HELDOUT_FILE).read_bytes()
    seed = json.loads(record)["seed"]
    assert main(["heldout", "--out", str(made), *TINY, "--seed", str(seed + 1)]) == 2
    assert f"holds the held-out set of seed {seed}" in capsys.readouterr().err
    assert (made / HELDOUT_FILE).read_bytes() == record
    (tmp_path / "generation_config.json").write_text("{}")
    assert main(["heldout", "--out", str(tmp_path), *TINY]) == 2
    assert "did not make" in capsys.readouterr().err and not (tmp_path / HELDOUT_FILE).exists()
