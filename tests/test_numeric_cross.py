"""catadioptric._numeric.cross: np.cross of 3-vectors to the same bits, broadcast, without its
per-call overhead (the two-view refinement's finite differences call it tens of thousands of
times)."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from catadioptric._numeric import cross

finite = st.floats(-1e150, 1e150, allow_nan=False, allow_subnormal=True)


@settings(max_examples=200, deadline=None)
@given(arrays(float, (6, 3), elements=finite), arrays(float, (6, 3), elements=finite))
def test_cross_gives_numpys_bits(a, b):
    with np.errstate(over="ignore", invalid="ignore"):
        assert np.array_equal(cross(a, b), np.cross(a, b), equal_nan=True)
        assert np.array_equal(cross(a[:, None], b[None, :3]), np.cross(a[:, None], b[None, :3]), equal_nan=True)

