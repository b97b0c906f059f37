"""Helpers of the reader's tests."""

from __future__ import annotations

import json
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from craft_dsl.perception.schema import PerceivedScene
from craft_dsl.reader.answer import Question, answer_questions
from craft_dsl.reader.perceive import Perception
from craft_dsl.render.raster import world_to_pixel


def tracks_px(perception: Perception) -> dict[tuple[str, str, str], np.ndarray]:
    """Each dynamic body's reconstructed path in pixels ([steps, 2], from step 1), by (shape, colour, size)."""
    traj = perception.reconstruction.simulation.trajectory
    out = {}
    for b in perception.reconstruction.simulation.world_spec.bodies:
        if b.dynamic:
            pos = traj.positions[1:, traj.column(b.uid)]
            out[(b.shape, b.color, b.size)] = np.stack(world_to_pixel(pos[:, 0], pos[:, 1]), axis=1)
    return out


def reencoded(source: Path, target: Path, video_filter: str = "null", options: Sequence[str] = ()) -> Path:
    """The MPEG-1 video ``source`` re-encoded to ``target`` (H.264, crf 18) through ffmpeg's ``video_filter``, with
    ffmpeg's output ``options`` besides (``-fps_mode vfr``, say)."""
    import imageio_ffmpeg

    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "mpegvideo", "-i",
                    str(source), "-vf", video_filter, *options, "-c:v", "libx264", "-crf", "18", "-pix_fmt",
                    "yuv420p", str(target)], check=True)
    return target


def video_questions(dataset: Path, video: Path) -> list[Question]:
    """Every question of ``video`` (named ``<video_index>.mpg``) in ``dataset``'s ``dataset_minimal.json``, text
    only."""
    index = int(video.stem)
    records = [r for r in json.loads((dataset / "dataset_minimal.json").read_text()) if r["video_index"] == index]
    return [Question(index, r["question_index"], r["question"]) for r in records]


def assert_same_answers(original: PerceivedScene, copy: PerceivedScene, questions: Sequence[Question]) -> None:
    """The two scenes answer at least 90% of ``questions`` alike."""
    ours = [a.answer for a in answer_questions(original, questions)]
    theirs = [a.answer for a in answer_questions(copy, questions)]
    assert sum(a == b for a, b in zip(ours, theirs)) >= 0.9 * len(questions)


def assert_read_alike(original: Perception, copy: Perception, questions: Sequence[Question]) -> None:
    """A copy of a video is read as the original: the same layout, the same bodies' attributes, and at least 90% of
    ``questions`` answered alike."""
    assert copy.layout.scene == original.layout.scene
    assert sorted(copy.reconstruction.attributes) == sorted(original.reconstruction.attributes)
    assert_same_answers(original.scene, copy.scene, questions)


def strip_dataset(dataset: Path, out: Path, videos: Sequence[int]) -> Path:
    """The videos ``videos`` of a generated ``dataset``, flat in ``out/videos``, and ``out/questions.json``: their
    records' (video_index, question_index, question), as a user without the dataset's files has them."""
    (out / "videos").mkdir()
    for index in videos:
        source = next(dataset.glob(f"videos/*/{index:06d}.mpg"))
        shutil.copy(source, out / "videos" / source.name)
    records = json.loads((dataset / "dataset_minimal.json").read_text())
    (out / "questions.json").write_text(json.dumps([
        {k: r[k] for k in ("video_index", "question_index", "question")} for r in records
        if r["video_index"] in videos]))
    return out
