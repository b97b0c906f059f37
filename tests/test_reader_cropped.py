"""A cropped picture is flagged (:mod:`craft_dsl.reader.whole`): its wall and ground lines are gone from the frame's
edges, and every answer says the video is not whole; pictures rescaled, re-encoded, letterboxed or padded to another
aspect keep their lines and are not flagged."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage as ndi

from craft_dsl.physics import simulate
from craft_dsl.reader import video as reader_video
from craft_dsl.reader.video import collect_unchecked
from craft_dsl.reader.whole import BORDER_CONTRAST, border_contrast, cropped, cropped_video, first_pictures
from craft_dsl.render import frames as render_frames

#: ffmpeg filters of the copies, and whether each is cropped (the robustness benchmark's variants and more)
COPIES = {
    "h264-crf28": ("null", ["-crf", "28"], False),
    "scale-128": ("scale=128:128", ["-qp", "0"], False),
    "scale-512": ("scale=512:512", ["-qp", "0"], False),
    "letterbox-16x9": ("pad=ceil(ih*16/9/2)*2:ih:(ow-iw)/2:0:color=black", ["-qp", "0"], False),
    "letterbox-16x9-crf28": ("pad=ceil(ih*16/9/2)*2:ih:(ow-iw)/2:0:color=black", ["-crf", "28"], False),
    "pad-4x3-gray": ("pad=ceil(ih*4/3/2)*2:ih:(ow-iw)/2:0:color=0x808080", ["-qp", "0"], False),
    "stretched-320x240": ("scale=320:240", ["-qp", "0"], False),
    "crop-8": ("crop=iw-16:ih-16:8:8", ["-qp", "0"], True),
    "crop-8-crf28": ("crop=iw-16:ih-16:8:8", ["-crf", "28"], True),
    "crop-2": ("crop=iw-4:ih-4:2:2", ["-qp", "0"], True),
    "crop-8-letterbox-16x9": ("crop=iw-16:ih-16:8:8,pad=ceil(ih*16/9/2)*2:ih:(ow-iw)/2:0:color=black", ["-qp", "0"],
                              True),
}


@pytest.fixture(scope="module")
def pictures() -> dict[int, np.ndarray]:
    """The first 4 frames of a run of three layouts, as the renderer draws them (256 px)."""
    return {scene: render_frames(simulate(scene, seed=0, steps=4)) for scene in (1, 8, 11)}


def _resized(frames: np.ndarray, side: int, crop: int = 0) -> np.ndarray:
    """``frames`` cut by ``crop`` px on every side and rescaled to ``side`` px: by whole factors, area averages down
    and linear otherwise (as the reader's decoder rescales)."""
    size = frames.shape[1]
    cut = frames[:, crop:size - crop, crop:size - crop].astype(np.float64)
    have = cut.shape[1]
    if have % side == 0:
        k = have // side
        out = cut.reshape(len(cut), side, k, side, k, 3).mean(axis=(2, 4))
    else:
        out = ndi.zoom(cut, (1, side / have, side / have, 1), order=1, mode="nearest")
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


def test_a_whole_picture_has_its_border_lines(pictures: dict[int, np.ndarray]) -> None:
    for frames in pictures.values():
        contrast = border_contrast(frames)
        assert set(contrast) == {"left", "right", "bottom"}
        assert min(contrast.values()) > 0.95  # black lines on white
        assert cropped(frames) is None
        # drawn smaller or larger and read at 256 px: fainter lines, still there
        assert cropped(_resized(_resized(frames, 128), 256), 128) is None
        assert cropped(_resized(_resized(frames, 512), 256), 512) is None


def test_a_cropped_picture_has_none(pictures: dict[int, np.ndarray]) -> None:
    for frames in pictures.values():
        copy = _resized(frames, 256, crop=8)
        assert max(border_contrast(copy).values()) < 0.05
        why = cropped(copy, 240)
        assert why is not None and "looks cropped" in why
        assert "left wall line, right wall line and ground line are not at the frame's edge" in why


def test_each_missing_line_is_named(pictures: dict[int, np.ndarray]) -> None:
    frames = pictures[1].copy()
    frames[:, :, :4] = 255  # the left wall line painted over
    why = cropped(frames)
    assert why is not None and why.startswith("the picture's left wall line is not at the frame's edge: the picture "
                                              "looks cropped")
    frames[:, -4:] = 255  # and the ground line
    why = cropped(frames)
    assert why is not None and "left wall line and ground line are not" in why


def test_a_graded_picture_keeps_its_lines(pictures: dict[int, np.ndarray]) -> None:
    frames = pictures[8]
    washed = (16 + frames.astype(np.float32) * (235 - 16) / 255).astype(np.uint8)  # limited range read as full
    assert cropped(washed) is None
    dark = (frames.astype(np.float32) * 0.5).astype(np.uint8)  # a darker grade: the contrast is the background's share
    assert min(border_contrast(dark).values()) > BORDER_CONTRAST


def test_frames_of_another_shape_are_refused() -> None:
    with pytest.raises(ValueError, match="expected frames"):
        border_contrast(np.zeros((4, 16, 16), dtype=np.uint8))
    with pytest.raises(ValueError, match="expected frames"):
        border_contrast(np.zeros((0, 16, 16, 3), dtype=np.uint8))


# -- files: the first frames as the reader reads them ------------------------------------------------------------


@pytest.fixture(scope="module")
def copies(video: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The first 8 frames of ``video`` copied through each of :data:`COPIES` (H.264)."""
    import imageio_ffmpeg

    out = tmp_path_factory.mktemp("cropped")
    made = {}
    for name, (video_filter, quality, _cut) in COPIES.items():
        target = out / f"{name}.mp4"
        subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-f", "mpegvideo", "-i",
                        str(video), "-vf", f"{video_filter},trim=end_frame=8", "-c:v", "libx264", *quality,
                        "-pix_fmt", "yuv420p", str(target)], check=True)
        made[name] = target
    return made


def test_the_reader_s_first_pictures(video: Path, copies: dict[str, Path]) -> None:
    frames, side = first_pictures(video)
    assert frames.shape == (4, 256, 256, 3) and side == 256
    assert first_pictures(copies["scale-128"])[1] == 128
    boxed, side = first_pictures(copies["letterbox-16x9"])
    assert boxed.shape == (4, 256, 256, 3) and side == 256  # the bars removed
    assert np.abs(boxed.astype(int) - frames.astype(int)).mean() < 2  # the picture the original holds


def test_only_cropped_copies_are_flagged(video: Path, copies: dict[str, Path]) -> None:
    assert cropped_video(video) is None
    for name, path in copies.items():
        why = cropped_video(path)
        assert (why is not None) == COPIES[name][2], (name, why)


def test_the_ffmpeg_decoder_reads_the_same_pictures(copies: dict[str, Path], monkeypatch: pytest.MonkeyPatch
                                                    ) -> None:
    ours = {name: first_pictures(copies[name]) for name in ("letterbox-16x9", "crop-8", "scale-512")}
    monkeypatch.setattr(reader_video, "have_pyav", lambda: False)
    for name, (frames, side) in ours.items():
        theirs, their_side = first_pictures(copies[name])
        assert theirs.shape == frames.shape and their_side == side
        assert np.abs(theirs.astype(int) - frames.astype(int)).mean() < 3
        assert (cropped_video(copies[name]) is None) == (not COPIES[name][2])


def test_a_file_that_cannot_be_decoded_again_is_not_checked(tmp_path: Path) -> None:
    broken = tmp_path / "000000.mp4"
    broken.write_bytes(b"not a video")
    with collect_unchecked() as unchecked:
        assert cropped_video(broken) is None
    assert len(unchecked) == 1 and "whether its picture is cropped could not be checked" in unchecked[0]


def test_every_answer_of_a_cropped_copy_is_warned(users_dataset: Path, video: Path, tmp_path: Path) -> None:
    from reader_helpers import reencoded, video_questions

    from craft_dsl.reader.cli import read_video

    copy = reencoded(video, tmp_path / f"{video.stem}.mp4", "crop=iw-16:ih-16:8:8")
    questions = video_questions(users_dataset, video)
    result = read_video(str(copy), questions, votes=0, steps=json.loads(
        (users_dataset / "generation_config.json").read_text())["steps"])
    assert "error" not in result
    assert "looks cropped" in result["warning"]
    assert len(result["answers"]) == len(questions)
    assert all(a.warning == result["warning"] for a in result["answers"])
