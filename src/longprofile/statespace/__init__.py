"""The state-space engine: the only place in longprofile with filter, smoother and likelihood loops.

Models
------
StateSpaceModel        -- linear-Gaussian model x[k+1] = F x + B u + c + w, y = H x + D u + d + v.

Linear inference
----------------
kalman_filter          -- Kalman filter (Joseph form, NaN = missing, batched).
rts_smoother           -- Rauch-Tung-Striebel smoother with lag-one cross-covariances.
log_likelihood         -- prediction-error log-likelihood.
shared_covariance_smoother -- filter + RTS smoother of a batch sharing one model and NaN pattern (covariances once).
smoother_noise_covariance -- covariance of the smoothed mean from the observation noise alone (fixed truth).
posterior_sample       -- forward-filter backward-sample draws of the state trajectory; simulate -- draw (x, y) from a model.

Stationary (constant-gain) inference
------------------------------------
steady_state_gain      -- stationary Kalman gain and covariances (DARE); SteadyStateGain result.
steady_state_filter    -- constant-gain Kalman filter as a compiled LTI recursion (> 1e7 samples/s).
steady_state_smoother  -- zero-lag fixed-interval counterpart, O(T n) memory.
steady_state_smoothed_cov -- the constant smoothed covariance of steady_state_smoother.
fixed_lag_smoother     -- E[x_t | y_0..t+L]: real-time smoother with a latency of L samples; FixedLagResult.

Records of any length (exact, bounded working memory)
-----------------------------------------------------
long_record_smoother   -- RTS smoother: exact start, constant gains once converged, chunked; LongRecordResult.
long_record_filter     -- the same forward pass as a filter; long_record_log_likelihood -- its exact likelihood.
chunked_kalman_filter  -- the exact time-varying filter chunk by chunk (no detectability needed).

Nonlinear inference
-------------------
NonlinearStateSpaceModel -- x' = f(x, u, k) + w, y = h(x, u, k) + v (numba-jitted f, h or fused steps run compiled).
extended_kalman_filter -- EKF (Joseph form, NaN = missing), stores the Jacobians used; compiled loop cached on disk.
extended_rts_smoother  -- EKF smoother on the stored linearisations and predicted moments.
block_extended_kalman_filter -- decentralised EKF: local EKFs per state block, coupled through the means (thesis 003).

Observers
---------
luenberger_gain        -- observer gain L by pole placement (continuous or discrete).
luenberger_observer    -- run a Luenberger observer over data (exact ZOH for continuous models); ObserverResult.

Estimation
----------
fit_mle                -- maximum-likelihood parameters of build(theta) -> model, Hessian standard errors; MLEResult.

Deterministic propagation
-------------------------
linear_recursion       -- x[k+1] = A_k x[k] + B_k u[k], constant or per-step matrices (compiled; IRI golden car).

Results
-------
FilterResult           -- filtered/predicted moments, innovations, log-likelihood.
SmootherResult         -- smoothed moments and cross-covariances.

Timing convention (all functions): ``initial_mean``/``initial_cov`` are the prior
of x_0 before y_0; ``pred_mean[t]`` = E[x_t | y_<t]; ``mean[t]`` = E[x_t | y_<=t];
``cross_cov[t]`` = Cov(x_t, x_{t+1} | y).
"""

from ._block_ekf import block_extended_kalman_filter
from ._ekf import NonlinearStateSpaceModel, extended_kalman_filter, extended_rts_smoother
from ._fixed_lag import FixedLagResult, fixed_lag_smoother
from ._kalman import kalman_filter, log_likelihood, rts_smoother
from ._long_record import (ChunkedFilterResult, LongRecordResult, chunked_kalman_filter, long_record_filter,
                           long_record_log_likelihood, long_record_smoother)
from ._mle import MLEResult, fit_mle
from ._model import StateSpaceModel
from ._observer import ObserverResult, luenberger_gain, luenberger_observer
from ._propagate import LinearRecursionResult, linear_recursion
from ._results import FilterResult, SmootherResult
from ._sampling import posterior_sample, simulate
from ._shared_cov import shared_covariance_smoother, smoother_noise_covariance
from ._steady import (SteadyStateGain, steady_state_filter, steady_state_gain, steady_state_smoothed_cov,
                      steady_state_smoother)

__all__ = [
    "StateSpaceModel",
    "kalman_filter",
    "rts_smoother",
    "log_likelihood",
    "posterior_sample",
    "shared_covariance_smoother",
    "smoother_noise_covariance",
    "simulate",
    "FilterResult",
    "SmootherResult",
    "SteadyStateGain",
    "steady_state_gain",
    "steady_state_filter",
    "steady_state_smoother",
    "steady_state_smoothed_cov",
    "fixed_lag_smoother",
    "FixedLagResult",
    "long_record_smoother",
    "long_record_filter",
    "long_record_log_likelihood",
    "LongRecordResult",
    "chunked_kalman_filter",
    "ChunkedFilterResult",
    "NonlinearStateSpaceModel",
    "extended_kalman_filter",
    "extended_rts_smoother",
    "block_extended_kalman_filter",
    "ObserverResult",
    "luenberger_gain",
    "luenberger_observer",
    "fit_mle",
    "MLEResult",
    "linear_recursion",
    "LinearRecursionResult",
]
