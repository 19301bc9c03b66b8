"""The synthetic site's thermal lag is a property of the sensor, not of the logger's sampling interval.

Until session 37 ``rail simulate`` held the temperature over each sampling interval (a step-held first-order
response): its lag was ~h/2 shorter than the sensor's, so the farebersviller-like site read hourly was another site
(and not the first-order lag the estimator fits: 14 % coverage of the daily bands on seed 0, where every 10 min gave
82 %). Oracle: the closed-form steady-state response of a first-order lag to a sine, A / sqrt(1 + (w tau)^2)
sin(w t - atan(w tau)).
"""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.rail._synthetic import lagged_temperature


@settings(max_examples=40, deadline=None)
@given(tau_h=st.floats(0.5, 8.0), dt_min=st.sampled_from([5.0, 10.0, 20.0, 30.0, 60.0, 120.0]),
       amplitude=st.floats(1.0, 20.0), mean=st.floats(-10.0, 30.0))
def test_the_lag_follows_the_continuous_response_whatever_the_interval(tau_h, dt_min, amplitude, mean):
    dt_h = dt_min / 60.0
    w = 2.0 * np.pi / 24.0  # the daily cycle
    t = np.arange(0.0, 10 * 24.0 + 1e-9, dt_h)
    felt = lagged_temperature(mean + amplitude * np.sin(w * t), dt_h, tau_h)
    steady = t > 12.0 * tau_h  # the start's transient (equilibrium at t = 0) decays as exp(-t / tau)
    exact = mean + amplitude / np.hypot(1.0, w * tau_h) * np.sin(w * t - np.arctan(w * tau_h))
    # linear interpolation of the sine between samples: error <= A (w h)^2 / 8 (1 % of A at h = 2 h)
    tol = amplitude * ((w * dt_h) ** 2 / 8.0 + 1e-6)
    assert np.max(np.abs(felt[steady] - exact[steady])) <= tol


def test_a_constant_temperature_is_felt_as_it_is():
    felt = lagged_temperature(np.full(50, 12.5), 1.0, 3.0)
    np.testing.assert_allclose(felt, 12.5, rtol=0, atol=1e-12)
