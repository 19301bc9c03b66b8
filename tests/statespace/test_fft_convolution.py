"""The stationary fixed-lag smoother's FFT convolution: bit for bit scipy.signal.fftconvolve(mode="full")."""

import numpy as np
import scipy.signal as ss
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.statespace._fixed_lag import _full_convolution


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 3000), m=st.integers(1, 400), strided=st.booleans())
def test_full_convolution_equals_scipy_fftconvolve(seed, n, m, strided):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 2))[:, 1] if strided else rng.normal(size=n)  # a column view, as the smoother passes
    h = rng.normal(size=m + 1)[:0:-1] * 10 ** rng.uniform(-8, 2)
    got = _full_convolution(x, h)
    want = ss.fftconvolve(x, h, mode="full")
    assert got.shape == want.shape and np.array_equal(got, want)
