"""The reader's small-window morphology equals scipy.ndimage's on any mask (the measurements depend on it)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage as ndi

from craft_dsl.reader.morphology import close_disk, disk, fill_holes, grow, shrink

masks = st.tuples(st.integers(1, 30), st.integers(1, 30)).flatmap(
    lambda hw: arrays(bool, hw, elements=st.booleans()))


@settings(max_examples=200, deadline=None)
@given(masks, st.integers(1, 5))
def test_close_disk_is_scipy_closing_of_the_padded_mask(mask: np.ndarray, radius: int) -> None:
    expected = ndi.binary_closing(np.pad(mask, radius), structure=disk(radius))[radius:-radius, radius:-radius]
    assert np.array_equal(close_disk(mask, radius), expected)


@settings(max_examples=200, deadline=None)
@given(masks)
def test_fill_holes_is_scipys(mask: np.ndarray) -> None:
    assert np.array_equal(fill_holes(mask), ndi.binary_fill_holes(mask))


@settings(max_examples=200, deadline=None)
@given(masks, st.integers(1, 3))
def test_grow_and_shrink_are_scipys_cross_dilation_and_erosion(mask: np.ndarray, iterations: int) -> None:
    assert np.array_equal(grow(mask, iterations), ndi.binary_dilation(mask, iterations=iterations))
    assert np.array_equal(shrink(mask, iterations), ndi.binary_erosion(mask, iterations=iterations, border_value=1))


def test_a_ring_is_filled_and_a_notched_disk_closed() -> None:
    ring = disk(6) & ~np.pad(disk(3), 3)
    assert fill_holes(ring).sum() == disk(6).sum()
    notched = disk(8).copy()
    notched[6:9, 6:11] = False  # an eye-sized notch inside the body
    assert np.array_equal(close_disk(notched, 4), disk(8))


stacks = st.tuples(st.integers(1, 4), st.integers(1, 20), st.integers(1, 20)).flatmap(
    lambda nhw: arrays(bool, nhw, elements=st.booleans()))


@settings(max_examples=100, deadline=None)
@given(stacks, st.integers(1, 4))
def test_a_stack_of_masks_is_each_mask_on_its_own(stack: np.ndarray, radius: int) -> None:
    for op in (lambda m: close_disk(m, radius), fill_holes, lambda m: grow(m, radius), lambda m: shrink(m, radius)):
        together = op(stack)
        assert together.shape == stack.shape
        for i, mask in enumerate(stack):
            assert np.array_equal(together[i], op(mask))
