"""When the reconstruction takes a (shape, size) reading the detector found less likely."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from craft_dsl.reader.reconstruct import keeps_alternative


def test_a_close_call_goes_to_the_run_that_follows_the_video() -> None:
    assert keeps_alternative(5.0, 4.0, 0.55, 0.45)
    assert not keeps_alternative(5.0, 4.9, 0.55, 0.45)  # within 0.2 px: the detector's reading stays


def test_a_near_certain_reading_is_not_given_up_for_a_run_that_strays_less() -> None:
    # a small circle read at odds of 2,500 to 1 whose unanchored run strayed 6 px further than a cube's (seen on
    # the original renderer's videos: physics the reconstruction does not share with the video)
    assert not keeps_alternative(9.06, 3.01, 0.9996, 0.0004)
    assert keeps_alternative(12.0, 3.01, 0.9996, 0.0004)  # a run that far off: the reading was wrong


@given(st.floats(0.0, 30.0), st.floats(0.0, 30.0), st.floats(1e-4, 1.0), st.floats(1e-4, 1.0))
def test_the_margin_grows_with_the_odds_and_never_keeps_a_worse_run(score: float, other: float, p_current: float,
                                                                  p_other: float) -> None:
    kept = keeps_alternative(score, other, p_current, p_other)
    if other >= score - 0.2:
        assert not kept
    if kept and p_other < p_current:
        assert keeps_alternative(score, other, p_current, min(p_other * 2.0, p_current))
