"""Total-error standard deviation of the derivative estimators (issue 13): noise plus a plug-in bias term (private).

The noise-only std (``std="noise"``) is what the estimators printed before issue 13: white noise of std sigma
through the estimator (FIR taps or Kalman covariance). It leaves out the model error (bias, lag), which dominates
when the window is long or q/r small for the signal. ``std="total"`` adds a plug-in estimate of the squared bias:

* the bias of the estimate is estimated by its difference from a *companion* estimate that has less bias on the
  same data -- for the polynomial FIRs the degree-(d+1) estimator of the same kind on the same window (Fan &
  Gijbels, *Local Polynomial Modelling and Its Applications*, 1996, §3.2-3.3 and §4.2: the degree-d local
  polynomial's leading bias term is the next-degree coefficient, estimated by a fit of higher degree), for the
  Kalman differentiator the same model with a time scale ``_KALMAN_SPEEDUP`` times shorter (q/r x
  speedup^(2 degree + 2));
* the difference delta = estimate - companion is a linear filter of the data, so its *noise* variance
  ``sigma^2 sum g^2`` is known (FIR: the difference of the taps; Kalman: the impulse response of the converged
  filters / smoothers);
* the squared bias is ``max(0, mean(delta^2) - sigma^2 sum g^2)``, the mean over a moving window of ``_SPAN``
  times the estimator's memory (trailing for causal estimators, centred for the smoother), as in the variance
  matching of Mehra (1972, "Approaches to adaptive filtering", IEEE TAC 17(5)): an observed second moment
  minus its predicted noise part;
* ``std_total = sqrt(std_noise^2 + _BIAS_GAIN * bias^2)``. For the Kalman methods std_noise is the posterior std
  scaled to the white-noise part of the converged filter (the posterior also holds the model's own random-jerk
  uncertainty, which the plug-in bias replaces) and the bias is scaled by :func:`kalman_bias_scale` (the part
  the companion keeps).

The constants were set a priori and checked on the calibration harness's tuning seed
(``benchmarks/bench_signal_calibration.py``, ``calibrate(..., seed=1000)``); the benchmark reports seed 0.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["STD_OPTIONS", "check_std", "bias_variance", "kalman_bias_scale", "kalman_impulse_gains",
           "kalman_time_scale"]

#: Accepted values of the estimators' ``std`` option.
STD_OPTIONS = ("total", "noise")
#: The moving mean of delta^2 spans this many times the estimator's memory (N + 1 samples, or the Kalman time scale).
_SPAN = 4.0
#: The companion Kalman estimate runs on a time scale this many times shorter.
_KALMAN_SPEEDUP = 2.0
#: Multiplier of the estimated squared bias.
_BIAS_GAIN = 1.0


def check_std(std) -> str:
    """Validate the ``std`` option ("total" or "noise")."""
    if not isinstance(std, str) or std not in STD_OPTIONS:
        raise InputError(f"std must be one of {STD_OPTIONS} ('total': noise and model error, 'noise': the "
                         f"white-noise part only); got {std!r}.")
    return std


def _moving_mean_square(v: np.ndarray, width: int, centred: bool) -> np.ndarray:
    """Mean of the squares of the finite values of each row of v (B, T) over a moving window of ``width`` samples.

    Trailing (samples k - width + 1 .. k) or centred (k - width // 2 .. k + width - width // 2 - 1); shorter at the
    ends; NaN where the window has no finite value (compiled: :func:`._kernels.moving_mean_square_kernel`, the
    squares taken inside it: no (B, T) temporary).
    """
    from ._kernels import moving_mean_square_kernel

    before, after = (width // 2, width - width // 2) if centred else (width - 1, 1)
    out = np.empty(v.shape)
    moving_mean_square_kernel(np.ascontiguousarray(v, dtype=float), before, after, out)
    return out


def bias_variance(delta: np.ndarray, noise_var: np.ndarray, memory: float, *, centred: bool) -> np.ndarray:
    """Plug-in squared bias (B, T) from delta = estimate - companion (B, T) and its noise variance (B,).

    ``max(0, moving mean of delta^2 - noise_var) * _BIAS_GAIN`` over ``_SPAN * memory`` samples; 0 where no delta
    is finite yet. The positive part of a zero-mean estimate makes it over-state a little where noise dominates
    (docs/signal.md, Calibration).
    """
    width = max(int(np.ceil(_SPAN * memory)), 1)
    excess = _moving_mean_square(delta, width, centred)
    excess -= np.asarray(noise_var, dtype=float)[:, None]
    np.fmax(excess, 0.0, out=excess)  # fmax: 0 where excess is NaN
    excess *= _BIAS_GAIN
    return excess


def kalman_time_scale(dt: float, q_over_r: float, degree: int) -> float:
    """The Kalman differentiator's time scale in samples, (q/r dt^(2d+2))^(-1/(2d+2)) (at least 1)."""
    return max(1.0, (q_over_r * dt ** (2 * degree + 2)) ** (-1.0 / (2 * degree + 2)))


def kalman_impulse_gains(model, companion, order: int, smooth: bool, time_scale: float,
                         max_length: int = 50_000) -> tuple[float, float, float]:
    """Noise gains of the Kalman derivative (component ``order``), from its converged response g to a unit impulse.

    Returns (sum g^2, sum (g - g_companion)^2, the posterior variance P_rr there); multiplied by r = noise_std^2:
    the white-noise variance of the estimate, of its difference from the companion, and the model's posterior
    variance. Both models (noise_std 1: the means do not depend on r) filter, or smooth, a record of 2L + 1 zeros
    with a unit impulse at its centre, L = 40 time scales + 20 samples (at most ``max_length``): the exact filter's
    gains have converged there and its response has decayed.
    """
    from ..statespace import kalman_filter, rts_smoother

    length = int(min(40 * time_scale + 20, max_length))
    y = np.zeros((2 * length + 1, 1))
    y[length] = 1.0
    resp, post_var = [], 0.0
    for m in (model, companion):
        post = kalman_filter(m, y)
        if smooth:
            post = rts_smoother(m, post)
        resp.append(post.mean[:, order])
        post_var = post_var or float(post.cov[length, order, order])
    return float(np.sum(resp[0] ** 2)), float(np.sum((resp[0] - resp[1]) ** 2)), post_var


def kalman_bias_scale(degree: int, order: int, smooth: bool) -> float:
    """1 / (1 - s^-p): the companion (time scale / s) keeps s^-p of the bias, which delta therefore misses.

    p = degree + 1 - order for the filter (exact on polynomials of degree ``degree``: the leading bias is the
    next derivative times T^p); p = 2 (degree + 1) - order for the smoother (the RTS smoother of this model is a
    smoothing spline penalising the (degree + 1)-th derivative, whose equivalent kernel has order 2 (degree + 1):
    Silverman 1984, Ann. Statist. 12(3)).
    """
    p = (2 * (degree + 1) if smooth else degree + 1) - order
    return 1.0 / (1.0 - _KALMAN_SPEEDUP ** -p)
