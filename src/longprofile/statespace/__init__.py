"""The state-space engine: the only place in longprofile with filter, smoother and likelihood loops.

Models
------
StateSpaceModel        -- linear-Gaussian model x[k+1] = F x + B u + c + w, y = H x + D u + d + v.

Linear inference
----------------
kalman_filter          -- Kalman filter (Joseph form, NaN = missing, batched).
rts_smoother           -- Rauch-Tung-Striebel smoother with lag-one cross-covariances.
log_likelihood         -- prediction-error log-likelihood.

Results
-------
FilterResult           -- filtered/predicted moments, innovations, log-likelihood.
SmootherResult         -- smoothed moments and cross-covariances.

Timing convention (all functions): ``initial_mean``/``initial_cov`` are the prior
of x_0 before y_0; ``pred_mean[t]`` = E[x_t | y_<t]; ``mean[t]`` = E[x_t | y_<=t];
``cross_cov[t]`` = Cov(x_t, x_{t+1} | y).
"""

from ._kalman import kalman_filter, log_likelihood, rts_smoother
from ._model import StateSpaceModel
from ._results import FilterResult, SmootherResult

__all__ = [
    "StateSpaceModel",
    "kalman_filter",
    "rts_smoother",
    "log_likelihood",
    "FilterResult",
    "SmootherResult",
]
