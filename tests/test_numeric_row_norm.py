"""catadioptric._numeric.row_norm: np.linalg.norm over the last axis to the same bits (the line fits
and the crossing fits take it of millions of 2- and 3-vectors a pose), rows of any length, strided
or not, with NaN, inf, overflowing and subnormal components."""
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import array_shapes, arrays

from catadioptric._numeric import row_norm

anything = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)


@settings(max_examples=300, deadline=None)
@given(arrays(float, array_shapes(min_dims=1, max_dims=3, min_side=0, max_side=9), elements=anything))
def test_row_norm_gives_numpys_bits(v):
    with np.errstate(over="ignore", invalid="ignore"):
        assert np.array_equal(row_norm(v), np.linalg.norm(v, axis=-1), equal_nan=True)
        w = np.swapaxes(v, 0, -1)  # rows strided in memory
        assert np.array_equal(row_norm(w), np.linalg.norm(w, axis=-1), equal_nan=True)
