"""sos_filter / sos_filtfilt / sos_filter_zi: bit for bit scipy.signal's sosfilt / sosfiltfilt / sosfilt_zi (the oracle).

Equality is ``np.array_equal`` (not a tolerance) plus equal signed zeros and equal strides: the engine's loop
performs scipy's floating-point operations in scipy's order, the forward-backward wrapper builds the odd extension
and the initial states with the same numpy operations, and the results have scipy's memory layout (a numpy
reduction of a result sums in an order that depends on its strides: found on the vertical-vehicle tables, where a
C-ordered result changed eps in the 15th digit).
"""

import numpy as np
import pytest
import scipy.signal as ss
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, ShapeError
from longprofile.statespace import sos_filter, sos_filter_zi, sos_filtfilt


def _identical(got, want) -> bool:
    """Same shape, strides, values and signs of zero."""
    return (got.shape == want.shape and got.strides == want.strides and np.array_equal(got, want)
            and np.array_equal(np.signbit(got), np.signbit(want)))


def _random_sections(rng, n_sections: int, first_order_share: float = 0.25) -> np.ndarray:
    """Random stable sections: complex or real pole pairs inside the unit circle, random numerators; some
    sections first order (b2 = a2 = 0, as scipy's odd-order designs)."""
    sos = np.zeros((n_sections, 6))
    for s in range(n_sections):
        sos[s, :3] = rng.normal(size=3) * 10 ** rng.uniform(-3, 1)
        sos[s, 3] = 1.0
        if rng.uniform() < first_order_share:
            sos[s, 2] = 0.0
            sos[s, 4] = -rng.uniform(-0.999, 0.999)
        elif rng.uniform() < 0.5:
            r, th = rng.uniform(0.0, 0.999), rng.uniform(0.0, np.pi)
            sos[s, 4], sos[s, 5] = -2.0 * r * np.cos(th), r * r
        else:
            p1, p2 = rng.uniform(-0.999, 0.999, 2)
            sos[s, 4], sos[s, 5] = -(p1 + p2), p1 * p2
    return sos


def _samples(rng, n, tail):
    return rng.normal(size=(n,) + tail) * 10 ** rng.uniform(-6, 3) + rng.normal() * 10 ** rng.uniform(-3, 3)


_TAILS = [(), (3,), (2, 2), (1,)]


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_sections=st.integers(1, 6), n=st.integers(1, 400),
       tail=st.sampled_from(_TAILS), with_zi=st.booleans())
def test_sos_filter_equals_scipy_bit_for_bit(seed, n_sections, n, tail, with_zi):
    rng = np.random.default_rng(seed)
    sos = _random_sections(rng, n_sections)
    x = _samples(rng, n, tail)
    if with_zi:
        zi = rng.normal(size=(n_sections, 2) + tail)
        y, zf = sos_filter(sos, x, zi=zi)
        y_ref, zf_ref = ss.sosfilt(sos, x, axis=0, zi=zi)
        assert _identical(zf, zf_ref)
    else:
        y, y_ref = sos_filter(sos, x), ss.sosfilt(sos, x, axis=0)
    assert y.dtype == np.float64
    assert _identical(y, y_ref)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_sections=st.integers(1, 6), n=st.integers(2, 400),
       tail=st.sampled_from(_TAILS), pad=st.sampled_from(["default", "zero", "random", "max"]))
def test_sos_filtfilt_equals_scipy_bit_for_bit(seed, n_sections, n, tail, pad):
    rng = np.random.default_rng(seed)
    sos = _random_sections(rng, n_sections)
    x = _samples(rng, n, tail)
    padlen = {"default": None, "zero": 0, "random": int(rng.integers(0, n)), "max": n - 1}[pad]
    try:
        ref = ss.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen)
    except ValueError:  # too short for scipy's default pad: ours refuses it too
        with pytest.raises(ShapeError):
            sos_filtfilt(sos, x, padlen=padlen)
        return
    got = sos_filtfilt(sos, x, padlen=padlen)
    assert _identical(got, ref)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_sections=st.integers(1, 8))
def test_sos_filter_zi_equals_scipy_bit_for_bit(seed, n_sections):
    sos = _random_sections(np.random.default_rng(seed), n_sections)
    assert _identical(sos_filter_zi(sos), ss.sosfilt_zi(sos))


@pytest.mark.parametrize("order,wn,btype", [(1, 0.01, "high"), (2, 0.2, "low"), (2, 0.001, "highpass"),
                                            (5, [0.1, 0.3], "bandpass"), (8, 0.05, "low"), (3, 0.9, "high")])
def test_butterworth_designs_as_the_domains_use_them(order, wn, btype):
    sos = ss.butter(order, wn, btype=btype, output="sos")
    rng = np.random.default_rng(order)
    x = np.cumsum(rng.normal(size=(3000, 2)), axis=0)
    assert _identical(sos_filter(sos, x), ss.sosfilt(sos, x, axis=0))
    assert _identical(sos_filter(sos, x[:, 0]), ss.sosfilt(sos, x[:, 0]))
    for padlen in (None, 0, 600, 2999):
        assert _identical(sos_filtfilt(sos, x, padlen=padlen),
                          ss.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=padlen))


def test_blocks_carry_the_state():
    sos = ss.butter(4, 0.1, output="sos")
    x = np.random.default_rng(1).normal(size=(500, 3))
    zi = sos_filter_zi(sos)[:, :, None] * x[0]
    y1, z1 = sos_filter(sos, x[:200], zi=zi)
    y2, _ = sos_filter(sos, x[200:], zi=z1)
    y, _ = sos_filter(sos, x, zi=zi)
    assert np.array_equal(np.concatenate([y1, y2]), y)


def test_inputs_are_not_modified_and_empty_records_pass():
    sos = ss.butter(2, 0.1, output="sos")
    x = np.random.default_rng(2).normal(size=50)
    zi = np.ones((1, 2))
    x0, zi0 = x.copy(), zi.copy()
    sos_filter(sos, x, zi=zi)
    assert np.array_equal(x, x0) and np.array_equal(zi, zi0)
    assert sos_filter(sos, np.empty(0)).shape == (0,)  # (scipy's sosfilt refuses an empty 1-D record)


def test_bad_arguments_are_refused():
    sos = ss.butter(2, 0.1, output="sos")
    x = np.zeros(20)
    with pytest.raises(ShapeError):
        sos_filter(np.ones((2, 5)), x)
    with pytest.raises(InputError, match="a0"):
        sos_filter(sos * 2.0, x)
    with pytest.raises(InputError):
        sos_filter(np.full((1, 6), np.nan), x)
    with pytest.raises(ShapeError, match="zi"):
        sos_filter(sos, x, zi=np.zeros((1, 3)))
    with pytest.raises(ShapeError):
        sos_filter(sos, 1.0)
    with pytest.raises(InputError):
        sos_filter(sos, x + 0j)
    with pytest.raises(ShapeError, match="padlen"):
        sos_filtfilt(sos, x, padlen=20)
    with pytest.raises(InputError, match="padlen"):
        sos_filtfilt(sos, x, padlen=-1)
