"""The state-space engine: the only place in longprofile with filter, smoother and likelihood loops.

Models
------
StateSpaceModel        -- linear-Gaussian model x[k+1] = F x + B u + c + w, y = H x + D u + d + v.

Linear inference
----------------
kalman_filter          -- Kalman filter (Joseph form, NaN = missing, batched; per-series Q, R, P0: series_cov).
rts_smoother           -- Rauch-Tung-Striebel smoother with lag-one cross-covariances.
log_likelihood         -- prediction-error log-likelihood.
shared_covariance_smoother -- filter + RTS smoother of a batch sharing one model and NaN pattern (covariances once).
shared_covariance_log_likelihood -- the same batch's per-series log-likelihoods, forward pass only.
process_scale_log_likelihood -- those log-likelihoods as a function of a scale of Q (ML searches).
grouped_covariance_smoother -- many such batches in one compiled call, group g with Q -> s_g Q and its own R_g.
grouped_log_likelihood -- their per-series log-likelihoods, forward pass only (one candidate per series).
smoother_noise_covariance -- covariance of the smoothed mean from the observation noise alone (fixed truth).
process_noise_moments  -- E[w w^T | y] of the process noise from a smoother (the EM statistic of Q).
process_noise_energy   -- E[w^T W w | y] per series and step, one compiled pass (the EM statistic of a scale of Q).
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
linear_recursion_columns -- K independent columns of one constant recursion in one compiled call.

Second-order-section filters (scipy.signal's sosfilt / sosfiltfilt bit for bit, without importing scipy.signal)
-------------------------------------------------------------------------------------------------------------
sos_filter             -- causal cascade of second-order sections along axis 0 (optional initial / final state).
sos_filtfilt           -- zero-phase forward-backward filtering with odd extension (scipy's padtype="odd").
sos_filter_zi          -- initial state of sos_filter in the steady state of a unit step (scipy's sosfilt_zi).
filter_design          -- a scipy.signal filter design (butter, bilinear, zpk2sos, ...) cached on disk.

Results
-------
FilterResult           -- filtered/predicted moments, innovations, log-likelihood.
SmootherResult         -- smoothed moments and cross-covariances.

Timing convention (all functions): ``initial_mean``/``initial_cov`` are the prior
of x_0 before y_0; ``pred_mean[t]`` = E[x_t | y_<t]; ``mean[t]`` = E[x_t | y_<=t];
``cross_cov[t]`` = Cov(x_t, x_{t+1} | y).
"""

from .._lazy import lazy_namespace

# PEP 562 lazy loading: each public name -> the submodule defining it, imported on first access, so that
# ``from longprofile.statespace import linear_recursion`` loads neither the EKF, the block EKF, the
# steady-state nor the fixed-lag modules (nor scipy.optimize / scipy.signal).
_LAZY = {
    "block_extended_kalman_filter": "_block_ekf",
    "NonlinearStateSpaceModel": "_ekf", "extended_kalman_filter": "_ekf", "extended_rts_smoother": "_ekf",
    "FixedLagResult": "_fixed_lag", "fixed_lag_smoother": "_fixed_lag",
    "kalman_filter": "_kalman", "log_likelihood": "_kalman", "rts_smoother": "_kalman",
    "ChunkedFilterResult": "_long_record", "LongRecordResult": "_long_record",
    "chunked_kalman_filter": "_long_record", "long_record_filter": "_long_record",
    "long_record_log_likelihood": "_long_record", "long_record_smoother": "_long_record",
    "MLEResult": "_mle", "fit_mle": "_mle",
    "process_noise_moments": "_em", "process_noise_energy": "_em",
    "StateSpaceModel": "_model",
    "ObserverResult": "_observer", "luenberger_gain": "_observer", "luenberger_observer": "_observer",
    "filter_design": "_design_cache",
    "sos_filter": "_sos", "sos_filtfilt": "_sos", "sos_filter_zi": "_sos",
    "LinearRecursionResult": "_propagate", "linear_recursion": "_propagate", "linear_recursion_columns": "_propagate",
    "FilterResult": "_results", "SmootherResult": "_results",
    "posterior_sample": "_sampling", "simulate": "_sampling",
    "shared_covariance_smoother": "_shared_cov", "smoother_noise_covariance": "_shared_cov",
    "shared_covariance_log_likelihood": "_shared_cov", "process_scale_log_likelihood": "_shared_cov",
    "GroupedSmootherResult": "_grouped", "grouped_covariance_smoother": "_grouped",
    "grouped_log_likelihood": "_grouped",
    "SteadyStateGain": "_steady", "steady_state_filter": "_steady", "steady_state_gain": "_steady",
    "steady_state_smoothed_cov": "_steady", "steady_state_smoother": "_steady",
}

__all__ = [
    "StateSpaceModel",
    "kalman_filter",
    "rts_smoother",
    "log_likelihood",
    "posterior_sample",
    "shared_covariance_smoother",
    "shared_covariance_log_likelihood",
    "process_scale_log_likelihood",
    "grouped_covariance_smoother",
    "grouped_log_likelihood",
    "GroupedSmootherResult",
    "smoother_noise_covariance",
    "process_noise_moments",
    "process_noise_energy",
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
    "linear_recursion_columns",
    "LinearRecursionResult",
    "sos_filter",
    "sos_filtfilt",
    "sos_filter_zi",
    "filter_design",
]


_BY_MODULE: dict[str, list[str]] = {}
for _name, _module in _LAZY.items():
    _BY_MODULE.setdefault(f".{_module}", []).append(_name)
__getattr__, __dir__ = lazy_namespace(__name__, _BY_MODULE, __all__)
del _name, _module
