"""craft_dsl.torch.stream: fresh questions generated on the fly, sharded by worker and rank, equal to generate's."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="needs torch (pip install 'craft-dsl[torch]')")

from torch.utils.data import DataLoader  # noqa: E402

from craft_dsl.dataset.pipeline import GenerationConfig, generate_dataset  # noqa: E402
from craft_dsl.dataset.stages import answer_label  # noqa: E402
from craft_dsl.errors import CraftError, MissingExtraError  # noqa: E402
from craft_dsl.program import Program  # noqa: E402
from craft_dsl.torch import CraftStream, collate, decode_image, hf_stream, stream_answers, stream_tokens  # noqa: E402

#: Small settings: two scenes, short runs, one perturbation (about 0.25 s a video).
FAST: dict[str, Any] = {"scenes": (1, 2), "steps": 120, "perturbations": 1}
SEED = 7


def _plain(sample: dict[str, Any]) -> dict[str, Any]:
    """A sample with its tensors as bytes, for comparing whole samples."""
    return {k: (v.numpy().tobytes(), tuple(v.shape)) if isinstance(v, torch.Tensor) else v for k, v in sample.items()}


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``generate --size 2 --videos --no-balance`` with the FAST settings (one video of each scene)."""
    out = tmp_path_factory.mktemp("gen") / "craft"
    generate_dataset(GenerationConfig.make(size=2, seed=SEED, videos=True, balance=False, **FAST), out)
    return out


def test_indices_of_two_workers_and_two_ranks_are_disjoint_and_cover_the_range() -> None:
    stream = CraftStream(SEED, videos=37, start=3, frames="none", **FAST)
    seen: list[int] = []
    for rank in range(2):
        ranked = CraftStream(SEED, videos=37, start=3, frames="none", rank=rank, world_size=2, **FAST)
        for worker in range(2):  # what shard() gives worker `worker` of 2 on this rank
            seen += list(ranked.indices([ranked.rank * 2 + worker], ranked.world_size * 2))
    assert sorted(seen) == list(range(3, 37))
    assert len(seen) == len(set(seen))
    two_workers = [list(stream.indices([w], 2)) for w in range(2)]
    assert not set(two_workers[0]) & set(two_workers[1])
    assert sorted(two_workers[0] + two_workers[1]) == list(range(3, 37))


def test_an_endless_stream_does_not_end_and_cycles_the_scenes() -> None:
    stream = CraftStream(SEED, frames="none", **FAST)
    first = [i for i, _ in zip(stream.indices([1], 4), range(1000), strict=False)]
    assert first[:3] == [1, 5, 9] and len(first) == 1000
    assert [stream.scene_of(i) for i in range(4)] == [1, 2, 1, 2]
    assert [CraftStream(SEED, videos=4, frames="none", **FAST).scene_of(i) for i in range(4)] == [1, 1, 2, 2]


def test_rank_defaults_and_bad_settings() -> None:
    assert (CraftStream(SEED, frames="none").rank, CraftStream(SEED, frames="none").world_size) == (0, 1)
    with pytest.raises(CraftError, match="rank"):
        CraftStream(SEED, rank=2, world_size=2)
    with pytest.raises(CraftError, match="not a stream setting"):
        CraftStream(SEED, balance=False)
    with pytest.raises(CraftError, match="cache_dir"):
        CraftStream(SEED, frames="file")
    with pytest.raises(CraftError, match="square"):
        CraftStream(SEED, size=(64, 32))
    with pytest.raises(CraftError, match="frames mode"):
        CraftStream(SEED, frames="gif")  # type: ignore[arg-type]
    with pytest.raises(CraftError, match="bad generation config"):
        CraftStream(SEED, scenes=(99,))


def test_rows_and_media_equal_what_generate_writes(generated: Path, tmp_path: Path) -> None:
    rows = [json.loads(line) for line in (generated / "hf" / "random" / "train.jsonl").read_text().splitlines()]
    for part in ("validation", "test"):
        path = generated / "hf" / "random" / f"{part}.jsonl"
        if path.is_file():
            rows += [json.loads(line) for line in path.read_text().splitlines()]
    rows.sort(key=lambda r: (r["video_index"], r["question_index"]))
    stream = CraftStream(SEED, videos=2, frames="file", cache_dir=tmp_path, **FAST)
    ours = [r for i in range(2) for r in stream.rows(i)]
    assert [{k: v for k, v in r.items() if k not in ("scene", "video")} for r in ours] == rows
    for r in ours:
        video = Path(r["video"])
        assert video.read_bytes() == (generated / r["video_file_path"]).read_bytes()
        for kind in ("first", "last"):
            rel = r[f"{kind}_frame_path"]
            assert (stream.media_root() / rel).read_bytes() == (generated / rel).read_bytes()
    # the frames drawn in memory are the PNGs' pixels
    drawn = CraftStream(SEED, videos=2, frames="first_last", **FAST).video_samples(0)[0]["frames"]
    r0 = ours[0]
    pngs = [decode_image(generated / r0[f"{k}_frame_path"]) for k in ("first", "last")]
    assert torch.equal(drawn, torch.from_numpy(np.stack(pngs).transpose(0, 3, 1, 2).copy()))


def test_same_seed_and_index_give_the_same_sample_bytes() -> None:
    a = CraftStream(SEED, frames="video", fps=2, size=32, **FAST).video_samples(5)
    b = CraftStream(SEED, frames="video", fps=2, size=32, **FAST).video_samples(5)
    assert a and [_plain(x) for x in a] == [_plain(x) for x in b]
    assert a[0]["frames"].shape == (4, 3, 32, 32)  # 120 steps at 2 fps
    other = CraftStream(SEED + 1, frames="video", fps=2, size=32, **FAST).video_samples(5)
    assert [_plain(x) for x in other] != [_plain(x) for x in a]


def test_every_answer_is_what_the_program_gives_on_the_simulation() -> None:
    stream = CraftStream(SEED, videos=3, frames="none", **FAST)
    samples = list(stream)
    assert {s["video_index"] for s in samples} == {0, 1, 2}
    sims = {i: stream.simulation(i) for i in range(3)}  # the factual run again, from the instance's seed
    vocabulary = set(stream_answers())
    for s in samples:
        program = Program.parse(s["program"])
        assert answer_label(program.run(sims[s["video_index"]])) == s["answer"], s["question"]
        assert s["answer"] in vocabulary and s["answer_index"] == stream.answers.index(s["answer"])
        assert s["program_tokens"] == program.to_tokens()
        assert 1 not in s["program_ids"].tolist()  # no unknown token
        assert s["category"].split("/")[0] in ("C", "CF", "D") and s["family"] == s["category"].split("/")[0]
    assert stream_tokens()[:2] == ("<pad>", "<unk>")


def test_two_data_loader_workers_share_the_videos_without_overlap() -> None:
    stream = CraftStream(SEED, videos=2, frames="video", fps=1, size=16, **FAST)
    loader = DataLoader(stream, batch_size=8, collate_fn=collate, num_workers=2)
    keys: list[tuple[int, int]] = []
    for batch in loader:
        assert batch["frames"].shape[1:] == (2, 3, 16, 16)
        keys += list(zip(batch["video_index"].tolist(), batch["question_index"].tolist(), strict=True))
    alone = [(s["video_index"], s["question_index"]) for s in CraftStream(SEED, videos=2, frames="none", **FAST)]
    assert len(keys) == len(set(keys)) and sorted(keys) == sorted(alone)


def test_hugging_face_iterable_gives_the_same_rows() -> None:
    datasets = pytest.importorskip("datasets", reason="needs datasets (pip install 'craft-dsl[integration]')")
    ds = hf_stream(SEED, videos=2, shards=4, **FAST)
    assert isinstance(ds, datasets.IterableDataset) and ds.n_shards == 4
    rows = list(ds)
    expected = [r for i in range(2) for r in CraftStream(SEED, videos=2, frames="none", **FAST).rows(i)]
    assert sorted(rows, key=lambda r: (r["video_index"], r["question_index"])) == expected
    ranks = [{r["video_index"] for r in hf_stream(SEED, videos=2, shards=1, rank=k, world_size=2, **FAST)}
             for k in range(2)]
    assert ranks == [{0}, {1}]
    with pytest.raises(CraftError, match="not for Hugging Face rows"):
        hf_stream(SEED, frames="video")


def test_hugging_face_iterable_without_datasets_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "datasets", None)
    with pytest.raises(MissingExtraError, match=r"craft-dsl\[integration\]"):
        hf_stream(SEED)
