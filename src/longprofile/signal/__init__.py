"""Derivative estimators of noisy sampled signals (paper 002: recursive maximum-likelihood differentiators).

Estimators (one calling convention: ``f(x, dt, *, <options>, axis=0) -> DerivativeResult``)
------------------------------------------------------------------------------------------
derivative                   -- dispatch to any registered method by name.
derivative_ml                -- paper 002 §3 ML polynomial differentiator (causal, recursive, O(d^2)/sample).
derivative_polyfit           -- causal least-squares polynomial fit (Savitzky-Golay end point).
derivative_backward          -- backward differences of order n (paper 002 Table 1a).
derivative_kalman            -- Kalman differentiator, random-jerk model (paper 002 §2.3), filter or RTS smoother.
DERIVATIVE_METHODS           -- registry: name -> DerivativeMethod (function, options, description).
DerivativeResult             -- value, derivative, derivative_std, method, params.
DerivativeMethod             -- one registry entry.
check_derivative_options     -- validate a method's options once (unknown method, options it does not take,
                                missing required ones, with a hint); returns the keyword arguments.
StreamingDerivative          -- O(1)-per-sample streaming estimator fed block by block.
estimate_noise_std           -- robust white-noise std from high-order differences (MAD).
model_check                  -- lack-of-fit check: is the window (q/r) short enough for derivative_std to hold?
ModelCheck                   -- its result (residual ratio, unexplained share, adequate).
kalman_differentiator_model  -- StateSpaceModel of the Kalman differentiator.
plot_derivative              -- deprecated alias of ``longprofile.report.plot_derivative`` (figures live in report).

Coefficients and properties (exact rationals with fractions.Fraction)
---------------------------------------------------------------------
ml_coefficients              -- taps of the ML differentiator for window N, degree d, order r.
ml_coefficients_float        -- the same as float64.
ml_model_variance            -- variance factor under the paper's own model (eq. 5 and §3.2-3.3).
polyfit_coefficients         -- taps of the causal least-squares fit (exact).
polyfit_coefficients_float   -- the same as float64.
backward_difference_coefficients        -- Table 1a taps (Taylor / Lagrange), exact.
backward_difference_coefficients_float  -- the same as float64.
power_sum                    -- P_j(N) = sum_{n=1}^N n^j (exact).
variance_gain                -- sum of squared taps (white-noise variance gain).
static_gain                  -- sum of taps (zero-frequency gain).
frequency_response           -- H(f) in SI units via scipy.signal.freqz.
polynomial_bias              -- exact bias on a polynomial signal.

Taps ``h[n]`` multiply ``x[k-n]`` (newest first) and are in sample units: divide by ``dt**order``.
"""

from .._lazy import lazy_namespace

#: Lazy namespace (PEP 562): importing ``longprofile.signal`` loads no submodule (nor numba) until a name is used.
_EXPORTS = {
    "._coefficients": ("backward_difference_coefficients", "backward_difference_coefficients_float",
                       "frequency_response", "ml_coefficients", "ml_coefficients_float", "ml_model_variance",
                       "polyfit_coefficients", "polyfit_coefficients_float", "polynomial_bias", "power_sum",
                       "static_gain", "variance_gain"),
    "._derivative": ("DERIVATIVE_METHODS", "DerivativeMethod", "DerivativeResult", "check_derivative_options",
                     "derivative", "derivative_backward", "derivative_kalman", "derivative_ml", "derivative_polyfit",
                     "estimate_noise_std", "kalman_differentiator_model"),
    "._adequacy": ("ModelCheck", "model_check"),
    "._deprecated": ("plot_derivative",),
    "._streaming": ("StreamingDerivative",),
}


__all__ = [
    "derivative",
    "derivative_ml",
    "derivative_polyfit",
    "derivative_backward",
    "derivative_kalman",
    "DERIVATIVE_METHODS",
    "DerivativeResult",
    "DerivativeMethod",
    "check_derivative_options",
    "StreamingDerivative",
    "estimate_noise_std",
    "model_check",
    "ModelCheck",
    "kalman_differentiator_model",
    "plot_derivative",
    "ml_coefficients",
    "ml_coefficients_float",
    "ml_model_variance",
    "polyfit_coefficients",
    "polyfit_coefficients_float",
    "backward_difference_coefficients",
    "backward_difference_coefficients_float",
    "power_sum",
    "variance_gain",
    "static_gain",
    "frequency_response",
    "polynomial_bias",
]

__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
