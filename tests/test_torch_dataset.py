"""craft_dsl.torch: the PyTorch Dataset over a generated dataset folder, with real video decoding (PyAV)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="needs the torch extra: pip install torch==2.13.0 'craft-dsl[torch]'")
pytest.importorskip("av", reason="video decoding needs PyAV, the torch extra: pip install 'craft-dsl[torch]'")

from torch.utils.data import DataLoader  # noqa: E402

from craft_dsl.errors import CraftError  # noqa: E402
from craft_dsl.program import Program  # noqa: E402
from craft_dsl.torch import CraftVideoQA, collate, decode_image, decode_video  # noqa: E402


def test_decode_video_frames_rates_and_sizes(users_dataset: Path) -> None:
    from craft_dsl.physics import simulate
    from craft_dsl.render import frame

    path = users_dataset / "videos" / "sid_1" / "000001.mpg"
    full = decode_video(path)
    assert full.shape == (200, 256, 256, 3) and full.dtype == np.uint8
    qa = json.loads((users_dataset / "questions" / "qa_000001.json").read_text())
    sim = simulate(qa["stats"]["scene"], seed=qa["stats"]["simulation_seed"], steps=200)
    assert np.abs(full[59].astype(int) - frame(sim, 60).astype(int)).mean() < 6.0
    five = decode_video(path, fps=5)
    assert five.shape[0] == 16  # floor(200 * 5 / 60): the frames of steps 12, 24, ..., 192
    assert np.array_equal(five[0], full[11]) and np.array_equal(five[-1], full[191])
    small = decode_video(path, fps=10, size=(64, 48))
    assert small.shape == (33, 64, 48, 3)
    png = decode_image(users_dataset / "first_frames" / "sid_1" / "000001.png")
    assert np.array_equal(png, frame(sim, 1))
    with pytest.raises(CraftError, match="no such video or frame file"):
        decode_video(users_dataset / "videos" / "sid_1" / "999999.mpg")


def test_items_hold_frames_question_answer_and_program(users_dataset: Path) -> None:
    train = CraftVideoQA(users_dataset, "train", fps=5, size=64)
    split = json.loads((users_dataset / "split_info_random.json").read_text())
    assert len(train) == len(split["train"])
    item = train[0]
    assert item["frames"].shape == (16, 3, 64, 64) and item["frames"].dtype == torch.uint8
    assert train.answers[item["answer_index"]] == item["answer"]
    full = {(q["video_index"], q["question_index"]): q for v in json.loads((users_dataset / "dataset.json")
                                                                           .read_text()) for q in
            v["questions"]["questions"]}
    program = Program.from_nodes(full[(item["video_index"], item["question_index"])]["program"])
    assert item["program_tokens"] == program.to_tokens(order="prefix")
    assert [train.tokens[i] for i in item["program_ids"].tolist()] == item["program_tokens"]
    assert item["template_id"] == full[(item["video_index"], item["question_index"])]["template_id"]
    assert item["category"] and item["question_type"] and item["question"]
    test = CraftVideoQA(users_dataset, "test", split="hard", frames="first_last", size=32,
                        token_order="postfix")
    assert test.answers == train.answers  # one vocabulary for every part
    item = test[0]
    assert item["frames"].shape == (2, 3, 32, 32)
    assert item["program_tokens"][-1] in {"Count", "Exist", "QueryColor", "QueryShape", "AnyTrue", "AnyFalse",
                                          "IsBefore", "IsAfter", "ExistList"}
    assert CraftVideoQA(users_dataset, "all", frames="none")[0]["frames"].shape[0] == 0


def test_collate_pads_frames_and_programs(users_dataset: Path) -> None:
    data = CraftVideoQA(users_dataset, "all", frames="video", fps=6, size=32)
    items = [data[0], data[len(data) - 1]]
    items[1]["frames"] = items[1]["frames"][:7]  # a shorter video in the same batch
    batch = collate(items)
    assert batch["frames"].shape == (2, 20, 3, 32, 32)
    assert batch["frame_lengths"].tolist() == [20, 7] and batch["frame_mask"].sum(1).tolist() == [20, 7]
    assert not batch["frames"][1, 7:].any()
    lengths = [len(i["program_tokens"]) for i in items]
    assert batch["program_ids"].shape == (2, max(lengths)) and batch["program_lengths"].tolist() == lengths
    assert batch["answer_index"].tolist() == [i["answer_index"] for i in items]
    assert batch["question"] == [i["question"] for i in items]
    loader = DataLoader(CraftVideoQA(users_dataset, "validation", frames="first", size=16), batch_size=4,
                        collate_fn=collate, shuffle=False)
    batches = list(loader)
    assert sum(len(b["answer"]) for b in batches) == len(loader.dataset)
    assert batches[0]["frames"].shape[1:] == (1, 3, 16, 16)
    with pytest.raises(CraftError, match="share their size"):
        collate([data[0], CraftVideoQA(users_dataset, "all", frames="first", size=16)[0]])


def test_mp4_datasets_and_bad_arguments(users_dataset: Path, tmp_path: Path) -> None:
    from craft_dsl.dataset.pipeline import GenerationConfig, generate_dataset

    out = tmp_path / "mp4"
    generate_dataset(GenerationConfig.make(size=5, scenes=(2,), steps=60, perturbations=0, balance=False,
                                           videos=True, video_format="mp4"), out)
    data = CraftVideoQA(out, "all", fps=30)
    assert data[0]["frames"].shape == (30, 3, 256, 256)
    for kwargs, message in (({"part": "dev"}, "unknown part"), ({"split": "easy"}, "unknown split"),
                            ({"frames": "middle"}, "unknown frames mode"), ({"fps": 120}, "fps must be")):
        with pytest.raises(CraftError, match=message):
            CraftVideoQA(users_dataset, **kwargs)  # type: ignore[arg-type]
