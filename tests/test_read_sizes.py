"""Videos of another size than the reader's 256 px are rescaled as they are decoded."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from craft_dsl.errors import ReaderError
from craft_dsl.reader.answer import Question, answer_questions
from craft_dsl.reader.perceive import perceive_video
from craft_dsl.reader.video import DECODERS, decode


def _rescaled(source: Path, target: Path, width: int, height: int) -> Path:
    import imageio_ffmpeg

    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "mpegvideo", "-i",
                    str(source), "-vf", f"scale={width}:{height}:flags=bicubic", "-c:v", "libx264", "-crf", "18",
                    str(target)], check=True)
    return target


@pytest.fixture(scope="module")
def video(users_dataset: Path) -> Path:
    return sorted((users_dataset / "videos").rglob("*.mpg"))[0]


@pytest.mark.parametrize("decoder", [d for d in DECODERS if d != "auto"])
def test_a_larger_video_is_decoded_at_the_size_asked_for(video: Path, tmp_path: Path, decoder: str) -> None:
    big = _rescaled(video, tmp_path / "big.mp4", 512, 512)
    assert decode(big, decoder).shape[1:] == (512, 512, 3)  # type: ignore[arg-type]
    frames = decode(big, decoder, size=256)  # type: ignore[arg-type]
    assert frames.shape[1:] == (256, 256, 3) and len(frames) == len(decode(video))


def test_frames_that_are_not_square_are_refused(video: Path, tmp_path: Path) -> None:
    wide = _rescaled(video, tmp_path / "wide.mp4", 320, 256)
    with pytest.raises(ReaderError, match="320x256; CRAFT videos are square"):
        decode(wide, size=256)


def test_a_512_pixel_copy_is_read_as_the_original(users_dataset: Path, video: Path, tmp_path: Path) -> None:
    index = int(video.stem)
    records = [r for r in json.loads((users_dataset / "dataset_minimal.json").read_text())
               if r["video_index"] == index]
    questions = [Question(index, r["question_index"], r["question"]) for r in records]
    original = perceive_video(video)
    copy = perceive_video(_rescaled(video, tmp_path / "big.mp4", 512, 512))
    assert copy.layout.scene == original.layout.scene
    assert sorted(copy.reconstruction.attributes) == sorted(original.reconstruction.attributes)
    ours = [a.answer for a in answer_questions(original.scene, questions)]
    theirs = [a.answer for a in answer_questions(copy.scene, questions)]
    assert sum(a == b for a, b in zip(ours, theirs)) >= 0.9 * len(questions)
