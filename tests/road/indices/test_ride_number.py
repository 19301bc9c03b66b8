"""Ride Number filter: oracles are an independent continuous-time simulation (scipy.signal.lsim) and the closed-form
frequency response of the same quarter car on a sine; RN = 5 exp(-160 PI) is checked on its definition."""

import numpy as np
import pytest

from longprofile.errors import InputError
from longprofile.road import Profile
from longprofile.road.indices._ride_number import RN_CAR, RN_SPEED, ride_number, ride_number_filter


def _continuous(car):
    k1, k2, c, mu = (car[k] for k in ("k1", "k2", "c", "mu"))
    a = np.array([[0, 1, 0, 0], [-k2, -c, k2, c], [0, 0, 0, 1], [k2 / mu, c / mu, -(k1 + k2) / mu, -c / mu]], float)
    b = np.array([[0], [0], [0], [k1 / mu]], float)
    return a, b, np.array([[1.0, 0, -1.0, 0]])


def test_filter_matches_scipy_lsim():
    # Oracle: scipy.signal.lsim with first-order hold (linear interpolation of the slope input is not the same
    # hold), so feed lsim the piecewise-constant slope on a fine time grid: exact zero-order hold per step.
    from scipy.signal import StateSpace, lsim

    dx = 0.25
    x = np.arange(0, 120.0, dx)
    rng = np.random.default_rng(0)
    z = np.cumsum(rng.normal(0, 1e-3, x.size)) * 0.1
    prof = Profile(distance=x, elevation=z)
    _, out, _, applied = ride_number_filter(prof, moving_average=False)
    assert not applied
    a, b, c = _continuous(RN_CAR)
    slope = np.diff(z) / dx
    sub = 20
    t = np.arange(slope.size * sub + 1) * (dx / sub) / RN_SPEED
    u = np.append(np.repeat(slope, sub), slope[-1])
    n_lead = 44
    s0 = (z[n_lead] - z[0]) / (n_lead * dx)
    _, y, _ = lsim(StateSpace(a, b, c, np.zeros((1, 1))), u, t, X0=[s0, 0, s0, 0], interp=False)
    assert np.allclose(out[:, 0], y[sub::sub], rtol=0, atol=1e-6 * np.max(np.abs(y)))


@pytest.mark.parametrize("wavelength", [0.8, 2.0, 5.0, 15.0])
def test_sine_rms_matches_frequency_response(wavelength):
    # Oracle: steady-state RMS = |H(j w)| A k / sqrt(2), H = C (jw I - A)^-1 B, w = 2 pi v / lambda.
    dx = 0.02
    x = np.arange(0, 400.0, dx)
    amp = 1e-3
    k = 2 * np.pi / wavelength
    prof = Profile(distance=x, elevation=amp * np.sin(k * x))
    st, out, _, _ = ride_number_filter(prof, moving_average=False)
    a, b, c = _continuous(RN_CAR)
    w = k * RN_SPEED
    h = (c @ np.linalg.solve(1j * w * np.eye(4) - a, b))[0, 0]
    # the per-step (zero-order-hold) slope is the mean slope over the step: amplitude sinc(k dx / 2)
    expected = abs(h) * amp * k * np.sinc(k * dx / 2 / np.pi) / np.sqrt(2)
    periods = np.floor((st[-1] - 100.0) / wavelength)
    steady = out[(st > 100.0) & (st <= 100.0 + periods * wavelength + 1e-9), 0]  # whole periods after transients
    rms = np.sqrt(np.mean(steady ** 2))
    assert rms == pytest.approx(expected, rel=2e-3)


def test_ride_number_definition_and_two_tracks():
    rng = np.random.default_rng(3)
    x = np.arange(0, 300.0, 0.05)
    z = np.cumsum(rng.normal(0, 2e-4, (x.size, 2)), axis=0)
    res = ride_number(Profile(distance=x, elevation=z, tracks=("left", "right")))
    assert res.metadata["moving_average_applied"]  # 50 mm step: k = 5 samples in the 250 mm base
    pil, pir = res.profile_index
    assert res.combined_profile_index == pytest.approx(np.sqrt((pil ** 2 + pir ** 2) / 2))
    assert res.ride_number == pytest.approx(5 * np.exp(-160 * res.combined_profile_index))
    assert 0 < res.ride_number < 5
    flat = ride_number(Profile(distance=x, elevation=0.01 * x))
    assert flat.ride_number == pytest.approx(5.0, abs=1e-9)


def test_irregular_profile_refused():
    x = np.cumsum(np.random.default_rng(0).uniform(0.05, 0.1, 500))
    with pytest.raises(InputError, match="constant sample interval"):
        ride_number(Profile(distance=x, elevation=x * 0))
