"""A graded video (limited range read as full, gamma, brightness, saturation) is measured against the palette and
brought back to it; a video as drawn, or re-encoded, is read as it is."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reader_helpers import assert_read_alike, reencoded, video_questions

from craft_dsl.physics import simulate
from craft_dsl.reader.perceive import perceive_video
from craft_dsl.reader.tone import (
    CHROMA_TOLERANCE,
    LUMA_TOLERANCE,
    Tone,
    calibrated,
    correct,
    from_ycc,
    measure_tone,
    plausible,
    to_ycc,
)
from craft_dsl.render.raster import frame


@pytest.fixture(scope="module")
def frames() -> np.ndarray:
    """Eight frames of a scene-2 run, spread over it: background, statics, sensor and several body colours."""
    sim = simulate(2, seed=3, steps=240)
    return np.stack([frame(sim, k) for k in range(0, 240, 30)])


def graded(frames: np.ndarray, offset: float, scale: float, gamma: float, gain: complex) -> np.ndarray:
    """``frames`` graded as a video tool grades them: luma ``offset + scale * 255 * (Y/255) ** gamma``, chroma times
    ``gain``, rounded to uint8."""
    ycc = to_ycc(frames.astype(np.float64))
    ycc[..., 0] = offset + scale * 255.0 * (np.clip(ycc[..., 0], 0, 255) / 255.0) ** gamma
    z = (ycc[..., 1] + 1j * ycc[..., 2]) * gain
    ycc[..., 1], ycc[..., 2] = z.real, z.imag
    return np.clip(from_ycc(ycc) + 0.5, 0, 255).astype(np.uint8)


def test_ycc_round_trips() -> None:
    rgb = np.random.default_rng(0).uniform(0, 255, (100, 3))
    assert np.allclose(from_ycc(to_ycc(rgb)), rgb)
    assert np.allclose(to_ycc(np.array([200.0, 200.0, 200.0]))[1:], 0.0)  # greys hold no chroma


def test_frames_as_drawn_are_left_as_they_are(frames: np.ndarray) -> None:
    tone = measure_tone(frames)
    assert tone is not None and not tone.graded
    assert tone.luma_shift < 2.0 and tone.chroma_change < 0.05
    out, undone = calibrated(frames)
    assert out is frames and undone is None


def test_limited_range_read_as_full_is_measured_and_undone(frames: np.ndarray) -> None:
    washed = graded(frames, 16.0, 219 / 255, 1.0, 224 / 255)
    tone = measure_tone(washed)
    assert tone is not None and tone.graded
    assert tone.offset == pytest.approx(16.0, abs=2.0)
    assert tone.scale == pytest.approx(219 / 255, abs=0.02)
    assert tone.gamma == pytest.approx(1.0, abs=0.05)
    assert abs(tone.gain - 224 / 255) < 0.04
    out, undone = calibrated(washed)
    assert undone is not None
    assert float(np.abs(washed.astype(np.int16) - frames).mean()) > 10.0
    assert float(np.abs(out.astype(np.int16) - frames).mean()) < 1.0


@pytest.mark.parametrize(("offset", "scale", "gamma", "gain"), [
    (0.0, 1.0, 0.75, 0.8),        # mid-tones brightened, paler
    (12.0, 0.95, 1.0, 0.5),       # lifted blacks, much paler
    (-4.0, 1.015, 1.25, 1.0),     # more contrast (white not clipped), mid-tones darker
    (0.0, 1.0, 0.8, 0.85 + 0.25j),  # brighter mid-tones, a hue turned
])
def test_a_grading_is_measured_and_undone(frames: np.ndarray, offset: float, scale: float, gamma: float,
                                         gain: complex) -> None:
    copy = graded(frames, offset, scale, gamma, gain)
    out, tone = calibrated(copy)
    assert tone is not None
    assert tone.gamma == pytest.approx(gamma, rel=0.08)
    assert abs(tone.gain - gain) < 0.06
    mid = (frames.max(axis=-1) > 10) & (frames.min(axis=-1) < 245)  # bodies and edges: where a grading shows
    before = float(np.abs(copy.astype(np.int16) - frames)[mid].mean())
    after = float(np.abs(out.astype(np.int16) - frames)[mid].mean())
    assert after < 4.0 and after < before / 3, (before, after)


@settings(max_examples=12, deadline=None)
@given(offset=st.floats(0.0, 25.0), scale=st.floats(0.8, 1.0), gamma=st.floats(0.6, 1.6),
       gain=st.floats(0.5, 1.05), turn=st.floats(-0.3, 0.3))
def test_any_grading_within_reach_is_undone_or_left_as_harmless(frames: np.ndarray, offset: float, scale: float,
                                                                 gamma: float, gain: float, turn: float) -> None:
    """Law: a grading that clips nothing (black and white within range, colours no more saturated: a brighter red
    would clip) is either undone (the bodies' pixels near the drawn ones) or small enough to be left (within the
    tolerances, the frames returned untouched)."""
    if offset + scale * 255.0 > 255.0:  # white clipped: outside the model (see the module docstring)
        offset = 255.0 - scale * 255.0
    k = gain * complex(np.cos(turn), np.sin(turn))
    copy = graded(frames, offset, scale, gamma, k)
    true = Tone(offset, scale, gamma, (k.real, -k.imag, k.imag, k.real), 0.0, 0.0, 0)
    out, tone = calibrated(copy)
    mid = (frames.max(axis=-1) > 10) & (frames.min(axis=-1) < 245)
    if true.luma_shift > 2 * LUMA_TOLERANCE or true.chroma_change > 2 * CHROMA_TOLERANCE:
        assert tone is not None  # a grading well over the tolerances is always measured
    if tone is None:
        assert out is copy
        measured = measure_tone(copy)
        assert measured is None or not measured.graded
    else:  # near the drawn pixels, or (a strong grading) a tenth as far from them as the graded ones
        before = float(np.abs(copy.astype(np.int16) - frames)[mid].mean())
        assert float(np.abs(out.astype(np.int16) - frames)[mid].mean()) < max(4.0, 0.1 * before)


def test_a_small_paling_such_as_a_lossy_codec_makes_is_not_corrected(frames: np.ndarray) -> None:
    copy = graded(frames, 1.0, 0.995, 1.0, 0.9)
    tone = measure_tone(copy)
    assert tone is not None and tone.chroma_change < CHROMA_TOLERANCE and tone.luma_shift < LUMA_TOLERANCE
    assert calibrated(copy)[0] is copy


def test_frames_without_the_palette_are_not_measured() -> None:
    grey = np.full((4, 64, 64, 3), 128, dtype=np.uint8)
    assert measure_tone(grey) is None
    noise = np.random.default_rng(1).integers(0, 256, (4, 64, 64, 3), dtype=np.uint8)
    out, tone = calibrated(noise)
    assert out is noise and tone is None


def test_implausible_gradings_are_refused() -> None:
    base = dict(scale=1.0, gamma=1.0, matrix=(1.0, 0.0, 0.0, 1.0), residual=0.0, deviation=0.0, pairs=5)
    assert plausible(Tone(offset=10.0, **base))  # type: ignore[arg-type]
    assert not plausible(Tone(offset=229.0, **base))  # type: ignore[arg-type]  # the sensor's grey taken for black
    assert not plausible(Tone(offset=0.0, **{**base, "matrix": (0.1, 0.0, 0.0, 0.1)}))  # type: ignore[arg-type]


def test_correct_keeps_the_frames_shape_and_type(frames: np.ndarray) -> None:
    tone = Tone(16.0, 219 / 255, 1.0, (0.9, 0.0, 0.0, 0.9), 0.0, 0.0, 5)
    out = correct(frames[:3], tone, chunk=2)
    assert out.shape == frames[:3].shape and out.dtype == np.uint8


def test_a_limited_range_copy_is_read_as_the_original(users_dataset: Path, video: Path, tmp_path: Path) -> None:
    questions = video_questions(users_dataset, video)
    original = perceive_video(video)
    # a full-range picture squeezed into limited range and read back as full range: washed out (white at 235)
    copy = perceive_video(reencoded(video, tmp_path / "washed.mp4", "scale=in_range=pc:out_range=tv"))
    assert original.tone is None and "tone" not in original.scene.meta
    assert copy.tone is not None and copy.scene.meta["tone"] == copy.tone.to_json()
    assert copy.tone.offset > 10.0
    assert_read_alike(original, copy, questions)
