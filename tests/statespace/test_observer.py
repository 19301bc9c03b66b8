"""Luenberger observer: pole placement, error decay, exact continuous-time discretisation."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy import signal

from longprofile.errors import InputError, ModelError, ShapeError
from longprofile.statespace import ObserverResult, luenberger_gain, luenberger_observer

A_OSC = np.array([[0.0, 1.0], [-4.0, -0.4]])  # lightly damped oscillator (continuous)
B_OSC = np.array([[0.0], [1.0]])
C_OSC = np.array([[1.0, 0.0]])


@pytest.mark.parametrize("poles", [[-5.0, -6.0], [-3.0 + 2.0j, -3.0 - 2.0j]])
def test_continuous_gain_places_poles(poles):
    L = luenberger_gain(A_OSC, C_OSC, poles)
    assert L.shape == (2, 1)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A_OSC - L @ C_OSC)),
                               np.sort_complex(np.array(poles, dtype=complex)), atol=1e-9)


def test_discrete_gain_multi_output_places_poles():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((4, 4))
    C = rng.standard_normal((2, 4))
    poles = [0.5, 0.4, 0.3 + 0.2j, 0.3 - 0.2j]
    L = luenberger_gain(A, C, poles, discrete=True)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A - L @ C)),
                               np.sort_complex(np.array(poles, dtype=complex)), atol=1e-9)


def test_discrete_error_decays_exactly_with_closed_loop_matrix():
    rng = np.random.default_rng(1)
    Ad, Bd, *_ = signal.cont2discrete((A_OSC, B_OSC, C_OSC, np.zeros((1, 1))), 0.05)
    poles = [0.6, 0.7]
    L = luenberger_gain(Ad, C_OSC, poles, discrete=True)
    T = 60
    u = rng.standard_normal((T, 1))
    x = np.empty((T, 2))
    x[0] = [1.0, -2.0]
    for k in range(T - 1):
        x[k + 1] = Ad @ x[k] + Bd @ u[k]
    y = x @ C_OSC.T
    res = luenberger_observer(Ad, Bd, C_OSC, L, y, u=u)
    assert isinstance(res, ObserverResult)
    err = x - res.state
    M = Ad - L @ C_OSC
    expected = np.array([np.linalg.matrix_power(M, k) @ err[0] for k in range(T)])
    np.testing.assert_allclose(err, expected, atol=1e-12)
    # decays at the slowest placed pole's rate
    ratio = np.linalg.norm(err[40]) / np.linalg.norm(err[20])
    assert 0.7 ** 20 / 10 < ratio < 0.7 ** 20 * 10
    np.testing.assert_allclose(res.output_error[:, 0], y[:, 0] - res.state[:, 0], atol=1e-14)


def test_continuous_observer_matches_scipy_lsim_and_reconstructs_state():
    dt = 1e-3
    poles = [-8.0, -10.0]
    L = luenberger_gain(A_OSC, C_OSC, poles)
    t = np.arange(0.0, 4.0, dt)
    u = np.sin(3.0 * t)[:, None]
    # truth from scipy (exact ZOH discretisation of the plant)
    plant = signal.StateSpace(A_OSC, B_OSC, C_OSC, np.zeros((1, 1)))
    _, y, x = signal.lsim(plant, u[:, 0], t, X0=[0.5, 0.0], interp=False)
    res = luenberger_observer(A_OSC, B_OSC, C_OSC, L, y, u=u, dt=dt)
    np.testing.assert_allclose(np.linalg.eigvals(res.transition), np.exp(np.array(poles) * dt)[::-1], rtol=1e-10)
    # oracle for the discretisation: scipy's ZOH simulation of the observer ODE driven by [u, y]
    obs_sys = signal.StateSpace(A_OSC - L @ C_OSC, np.hstack([B_OSC, L]), np.eye(2), np.zeros((2, 2)))
    _, _, xo = signal.lsim(obs_sys, np.column_stack([u[:, 0], y]), t, X0=[0.0, 0.0], interp=False)
    np.testing.assert_allclose(res.state, xo, atol=1e-10)
    err = np.linalg.norm(x - res.state, axis=1)
    assert err[0] > 0.4  # starts wrong ...
    assert err[t >= 2.0].max() < 1e-2 * np.abs(x).max()  # ... and converges (sample-and-hold floor ~ dt)


def test_observer_errors():
    with pytest.raises(InputError, match="negative real parts"):
        luenberger_gain(A_OSC, C_OSC, [1.0, -2.0])
    with pytest.raises(InputError, match="inside the unit circle"):
        luenberger_gain(A_OSC, C_OSC, [1.5, 0.2], discrete=True)
    with pytest.raises(InputError, match="n = 2 entries"):
        luenberger_gain(A_OSC, C_OSC, [-1.0])
    with pytest.raises(ModelError, match="observability matrix: 1 of 2"):
        luenberger_gain(np.diag([-1.0, -2.0]), np.array([[1.0, 0.0]]), [-3.0, -4.0])
    L = luenberger_gain(A_OSC, C_OSC, [-5.0, -6.0])
    y = np.ones(10)
    y[3] = np.nan
    with pytest.raises(InputError, match="NaN"):
        luenberger_observer(A_OSC, None, C_OSC, L, y, dt=0.01)
    with pytest.raises(ShapeError, match=r"pass u with shape \(T, 1\)"):
        luenberger_observer(A_OSC, B_OSC, C_OSC, L, np.ones(10), dt=0.01)
    with pytest.raises(InputError, match="dt must be finite and > 0"):
        luenberger_observer(A_OSC, None, C_OSC, L, np.ones(10), dt=0.0)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), n=st.integers(1, 4), discrete=st.booleans())
@example(seed=3188, n=4, discrete=False)  # A - L C non-normal (kappa 4e7): its eigenvalues read 5e-4 off a right gain
def test_single_output_gain_is_the_one_place_poles_finds(seed, n, discrete):
    """Oracle: scipy.signal.place_poles on the dual system. With one output the gain is unique, so the
    Ackermann path (which spares every observer command the scipy.signal import) must give it."""
    from scipy.signal import place_poles

    rng = np.random.default_rng(seed)
    A = rng.normal(0.0, 1.0, (n, n))
    C = rng.normal(0.0, 1.0, (1, n))
    if discrete:
        poles = np.sort(rng.uniform(0.1, 0.9, n)) * rng.choice([-1.0, 1.0], n)
    else:
        poles = -np.sort(rng.uniform(0.5, 5.0, n))
    if np.min(np.diff(np.sort(poles))) < 0.05 if n > 1 else False:
        return  # nearly repeated poles: ill-conditioned for any method
    O = np.vstack([C @ np.linalg.matrix_power(A, k) for k in range(n)])
    if np.linalg.cond(O) > 1e6:
        return  # nearly unobservable
    L = luenberger_gain(A, C, poles, discrete=discrete)
    ref = place_poles(A.T, C.T, poles).gain_matrix.T
    np.testing.assert_allclose(L, ref, rtol=1e-6, atol=1e-9 * max(1.0, np.abs(ref).max()))


def test_the_slope_observer_does_not_import_scipy_signal():
    """Start-up: ``vehicle slope`` placed its two poles with scipy.signal (0.5-1 s to import); not any more."""
    import subprocess
    import sys

    code = ("import sys; from longprofile.vehicle import default_vehicle; "
            "from longprofile.vehicle.planar import slope_observer_gain; "
            "slope_observer_gain(default_vehicle()); print('scipy.signal' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == "False"
