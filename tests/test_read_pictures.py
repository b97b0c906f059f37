"""Frames that are not square hold the square CRAFT picture boxed between bars or stretched: it is found, cut out
and read as a square."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from reader_helpers import assert_read_alike, reencoded, video_questions

from craft_dsl.physics import simulate
from craft_dsl.reader.perceive import perceive_video
from craft_dsl.reader.picture import BAR_TOLERANCE, Picture, find_picture, slack
from craft_dsl.reader.video import DECODERS, decode, decode_sized, decode_video
from craft_dsl.render.raster import frame


@pytest.fixture(scope="module")
def picture() -> np.ndarray:
    """One CRAFT frame [1, 256, 256, 3]: walls at its left and right edges, the ground along its bottom."""
    return frame(simulate(1, seed=0, steps=30), 20)[None]


def _pad(frames: np.ndarray, left: int, right: int, top: int, bottom: int, colour: tuple[int, int, int]
         ) -> np.ndarray:
    n, h, w, _ = frames.shape
    out = np.empty((n, h + top + bottom, w + left + right, 3), dtype=np.uint8)
    out[:] = np.array(colour, dtype=np.uint8)
    out[:, top:top + h, left:left + w] = frames
    return out


@pytest.mark.parametrize("colour", [(0, 0, 0), (16, 16, 16), (255, 255, 255), (40, 90, 200)])
def test_a_pillarboxed_picture_is_the_square_between_its_bars(picture: np.ndarray, colour: tuple[int, int, int]
                                                             ) -> None:
    boxed = find_picture(_pad(picture, 64, 64, 0, 0, colour))
    assert boxed == Picture(64, 0, 256, 256, 384, 256, "boxed")
    uneven = find_picture(_pad(picture, 10, 30, 0, 0, colour))  # bars of different widths: the picture is off-centre
    assert (uneven.x, uneven.width, uneven.how) == (10, 256, "boxed")


def test_a_letterboxed_picture_is_the_square_between_bars_above_and_below(picture: np.ndarray) -> None:
    found = find_picture(_pad(picture, 0, 0, 40, 40, (0, 0, 0)))
    # the black bottom bar takes in the ground line, which the square's centring gives back
    assert found == Picture(0, 40, 256, 256, 256, 336, "boxed")


def test_bars_with_compression_noise_are_bars(picture: np.ndarray) -> None:
    noisy = _pad(picture, 48, 48, 0, 0, (0, 0, 0)).astype(np.int16)
    rng = np.random.default_rng(0)
    noise = rng.integers(0, BAR_TOLERANCE // 2, size=noisy.shape)
    noisy[:, :, :48] += noise[:, :, :48]
    noisy[:, :, -48:] += noise[:, :, -48:]
    assert find_picture(np.clip(noisy, 0, 255).astype(np.uint8)) == Picture(48, 0, 256, 256, 352, 256, "boxed")


def test_a_stretched_picture_is_the_whole_frame(picture: np.ndarray) -> None:
    columns = (np.arange(400) * 256 // 400).astype(int)
    wide = picture[:, :, columns]  # 400 x 256: no bars but its own (black) wall lines at both edges
    assert find_picture(wide) == Picture(0, 0, 400, 256, 400, 256, "stretched")


def test_bars_around_a_region_of_another_shape_leave_that_region_stretched(picture: np.ndarray) -> None:
    squeezed = picture[:, :, ::2]  # 128 x 256, as a 4:3 picture squeezed into a frame would be
    found = find_picture(_pad(squeezed, 100, 100, 0, 0, (200, 200, 200)))
    assert (found.x, found.width, found.height, found.how) == (100, 128, 256, "stretched")


def test_a_square_frame_is_never_searched(picture: np.ndarray) -> None:
    black = np.zeros((1, 64, 64, 3), dtype=np.uint8)
    assert find_picture(black).how == "whole" and find_picture(picture) == Picture(0, 0, 256, 256, 256, 256, "whole")


def test_the_slack_covers_two_wall_lines_at_any_size() -> None:
    for side in (128, 240, 256, 480, 1080):
        assert slack(side) >= 2 * side / 256 + 2


def test_find_picture_refuses_what_is_not_frames() -> None:
    with pytest.raises(ValueError, match="expected frames"):
        find_picture(np.zeros((4, 4, 3), dtype=np.uint8))


@pytest.mark.parametrize("decoder", [d for d in DECODERS if d != "auto"])
def test_a_pillarboxed_video_decodes_to_its_picture(video: Path, tmp_path: Path, decoder: str) -> None:
    boxed = reencoded(video, tmp_path / "boxed.mp4", "scale=480:480:flags=bicubic,pad=640:480:80:0:black")
    decoded = decode_video(boxed, decoder, size=256)  # type: ignore[arg-type]
    frames, found = decoded.frames, decoded.picture
    assert found == Picture(80, 0, 480, 480, 640, 480, "boxed")
    original = decode(video).astype(np.int16)
    assert frames.shape == original.shape
    assert float(np.abs(frames.astype(np.int16) - original).mean()) < 4.0  # rescaled twice and H.264, not cropped
    assert decode_sized(boxed, decoder, size=256)[1] == 480  # type: ignore[arg-type]
    at_own_size = decode(boxed, decoder)  # type: ignore[arg-type]
    assert at_own_size.shape[1:] == (480, 480, 3)


def test_both_decoders_cut_and_scale_a_picture_alike(video: Path, tmp_path: Path) -> None:
    wide = reencoded(video, tmp_path / "wide.mp4", "scale=320:240:flags=bicubic")
    pyav, ffmpeg = decode_video(wide, "pyav", size=256), decode_video(wide, "ffmpeg", size=256)
    (by_pyav, pyav_picture), (by_ffmpeg, ffmpeg_picture) = (pyav.frames, pyav.picture), (ffmpeg.frames, ffmpeg.picture)
    assert pyav_picture == ffmpeg_picture == Picture(0, 0, 320, 240, 320, 240, "stretched")
    assert by_pyav.shape == by_ffmpeg.shape == (len(decode(video)), 256, 256, 3)
    assert float(np.abs(by_pyav.astype(np.int16) - by_ffmpeg.astype(np.int16)).mean()) < 0.5


@pytest.mark.parametrize("video_filter", ["scale=480:480:flags=bicubic,pad=640:480:80:0:black",
                                          "scale=320:240:flags=bicubic"], ids=["pillarboxed", "stretched"])
def test_a_video_that_is_not_square_is_read_as_the_original(users_dataset: Path, video: Path, tmp_path: Path,
                                                          video_filter: str) -> None:
    questions = video_questions(users_dataset, video)
    original = perceive_video(video)
    copy = perceive_video(reencoded(video, tmp_path / "copy.mp4", video_filter))
    assert copy.picture is not None and copy.scene.meta["picture"] == copy.picture.to_json()
    assert original.picture is None and "picture" not in original.scene.meta
    assert_read_alike(original, copy, questions)
