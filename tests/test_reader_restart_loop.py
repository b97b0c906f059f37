"""How many restarts a reconstruction makes: each must push the first stray later, and at most MAX_ANCHORS are made.

The run, its strays and the restarts are stand-ins here (a run is the frame its first body strays at), so the test
reads the loop of :func:`craft_dsl.reader.reconstruct.reconstruct` alone; the restarts themselves are tested in
``test_reader_restarts.py``."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from craft_dsl.reader import reconstruct as R

FRAMES = 600


class _Fit:
    def __init__(self, *_args: Any, **_kwargs: Any) -> None:
        pass

    def values(self, *_args: Any) -> dict[str, float]:
        return {}


def _reconstruct(monkeypatch: pytest.MonkeyPatch, restart: Any, strays_at: int = 100) -> tuple[R.Reconstruction,
                                                                                               list[tuple[int, int]]]:
    """``reconstruct`` of a first run straying at ``strays_at``, with ``restart(run, back)`` as the restart: a run is
    the frame its first body strays at (``FRAMES``: none strays); the (stray, back) of every restart tried."""
    tried: list[tuple[int, int]] = []

    def reanchor(sim: int, _fit: Any, _frames: int, first_stray: int, _eng: Any, _refresh: Any, back: int,
                 _window: int) -> int | None:
        assert first_stray == sim
        tried.append((sim, back))
        return restart(sim, back)

    def stray(sim: int, _fit: Any, frames: int, start: int = 0) -> tuple[dict[int, float], dict[int, int]]:
        return ({0: 10.0}, {0: sim}) if sim < frames else ({}, {})

    monkeypatch.setattr(R, "StartFit", _Fit)
    monkeypatch.setattr(R, "reanchor", reanchor)
    monkeypatch.setattr(R, "stray", stray)
    monkeypatch.setattr(R, "body_scores", lambda *_args: {})
    monkeypatch.setattr(R, "_score", lambda *_args, **_kwargs: 0.0)
    attempt = R._Attempt(np.zeros(0), {}, strays_at, {0: 10.0}, {0: strays_at}, 0, 0, 1.0)  # type: ignore[arg-type]
    opening = R.FirstRun(None, np.arange(1, FRAMES + 1), [], [], attempt)  # type: ignore[arg-type]
    out = R.reconstruct(None, {}, [], FRAMES, FRAMES, opening=opening)  # type: ignore[arg-type]
    return out, tried


def test_restarts_go_on_while_each_pushes_the_stray_later_up_to_max_anchors(monkeypatch: pytest.MonkeyPatch) -> None:
    out, tried = _reconstruct(monkeypatch, lambda run, back: run + 10)
    assert out.anchors == R.MAX_ANCHORS == len(tried)
    assert out.simulation == 100 + 10 * R.MAX_ANCHORS
    assert out.first_stray == {0: 100 + 10 * R.MAX_ANCHORS}


def test_restarts_end_when_the_run_follows_the_video_to_its_end(monkeypatch: pytest.MonkeyPatch) -> None:
    out, tried = _reconstruct(monkeypatch, lambda run, back: FRAMES if run >= 130 else run + 10)
    assert out.anchors == 4 and out.first_stray == {} and out.simulation == FRAMES
    assert [run for run, _ in tried] == [100, 110, 120, 130]


def test_a_restart_that_strays_no_later_is_not_kept_and_the_next_kind_is_tried(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The default restart pushes the stray later twice, then no longer: each other kind is tried in turn (a
    restart after the stray is compared from its own frame on), and none progressing ends the restarts."""
    out, tried = _reconstruct(monkeypatch, lambda run, back: run + 10 if run < 120 else run)
    assert out.anchors == 2 and out.simulation == 120
    assert tried == [(100, R.ANCHOR_BACK), (110, R.ANCHOR_BACK)] + [(120, back) for back, _ in R.ANCHOR_TRIES]
