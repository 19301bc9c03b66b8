"""Model-adequacy check of a derivative estimate: is the window (or q/r) short enough for the signal? (private)

``derivative_std="total"`` takes the bias of an estimate from a *companion* (the degree-(d+1) fit on the same window,
or the Kalman filter with half the time scale; ``_total_std``), which assumes the companion is much less biased
(docs/signal.md, Calibration, assumption 2). When the window spans the signal's own time scale (a 1 s window on a
2 Hz sine) both fits miss the signal alike, their difference is small, and the printed band collapses (coverage
12-20 % measured on such a case). The fits' residuals show it: the signal minus the fitted value holds the bias the
companion does not explain.

The test (a lack-of-fit test, as the residual chi-square of a local polynomial fit; Fan & Gijbels 1996, §4.10):

* ``r = x - v_d``: the residual of the estimate's own fitted value (for ``ml`` and ``backward``, whose value is x
  itself, the causal least-squares fit of the same window and degree); its white-noise power is at most sigma^2
  (a projection, or a filter's innovation times 1 - K);
* ``delta = v_d - v_c``: the fitted value's difference from the companion's, the bias the total std accounts for;
* alarm when ``mean r^2 > RESIDUAL_RATIO^2 sigma^2`` (the residuals are far beyond the noise) **and**
  ``mean r^2 - sigma^2 > UNEXPLAINED * mean delta^2`` (the companion explains little of that excess).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ModelCheck", "model_check", "RESIDUAL_RATIO", "UNEXPLAINED"]

#: The residuals' RMS over the noise std above which the fit is not following the signal.
RESIDUAL_RATIO = 5.0
#: The residuals' excess power over the companion's difference power above which the total std misses the bias.
UNEXPLAINED = 4.0
#: The share of the record where both hold above which the estimate is flagged.
MAX_SHARE = 0.1


@dataclass(frozen=True)
class ModelCheck:
    """Result of :func:`model_check` (one series).

    Attributes
    ----------
    residual_ratio : float
        RMS of x minus the fitted value, over the noise std (about 1 or less where the model holds).
    unexplained : float
        (mean r^2 - sigma^2) / mean delta^2: the residual bias power over what the companion accounts for.
    share : float
        The share of the samples where both exceed their limits (local means over 4 memories).
    adequate : bool
        False when both exceed :data:`RESIDUAL_RATIO` and :data:`UNEXPLAINED`: the derivative is biased beyond its
        ``derivative_std``.
    """

    residual_ratio: float
    unexplained: float
    share: float
    adequate: bool


def model_check(x, dt, *, method: str, noise_std: float, window: int | None = None, degree: int | None = None,
                q_over_r: float | None = None, smooth: bool = False, steady_state: bool = False,
                skip: int = 0) -> ModelCheck:
    """Lack-of-fit check of a 1-D derivative estimate's model (module docstring); ``skip`` leading samples ignored.

    ``noise_std`` is the one the estimate used (``result.params["noise_std"]``); a zero noise std makes every
    residual an excess (the check then says whether the companion explains it). Runs the fit and its companion once
    more (two FIR kernel passes, or two Kalman runs with the estimate's ``smooth`` and ``steady_state``).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(5000) * 1e-3
    >>> x = np.sin(2 * np.pi * 2 * t) + 1e-3 * np.random.default_rng(0).standard_normal(t.size)
    >>> model_check(x, 1e-3, method="ml", window=1000, degree=1, noise_std=1e-3).adequate
    False
    >>> model_check(x, 1e-3, method="ml", window=45, degree=2, noise_std=1e-3).adequate
    True
    """
    from ._derivative import derivative_kalman, derivative_polyfit
    from ._total_std import _KALMAN_SPEEDUP

    x = np.asarray(x, dtype=float)
    if method == "kalman":
        d = 2 if degree is None else degree
        kw = dict(degree=d, noise_std=max(noise_std, 1e-300), smooth=bool(smooth), steady_state=bool(steady_state),
                  std="noise")
        own = derivative_kalman(x, dt, q_over_r=q_over_r, **kw).value
        comp = derivative_kalman(x, dt, q_over_r=q_over_r * _KALMAN_SPEEDUP ** (2 * d + 2), **kw).value
    else:
        d = (2 if method != "backward" else 1) if degree is None else degree
        n = d if method == "backward" else window
        own = derivative_polyfit(x, dt, window=n, degree=d, noise_std=1.0, std="noise").value
        comp = derivative_polyfit(x, dt, window=max(n, d + 1), degree=d + 1, noise_std=1.0, std="noise").value
    from ._total_std import _SPAN, _moving_mean_square, kalman_time_scale

    memory = kalman_time_scale(dt, q_over_r, d) if method == "kalman" else (n + 1)
    width = max(int(np.ceil(_SPAN * memory)), 1)
    r, delta = (x - own)[skip:], (own - comp)[skip:]
    ok = np.isfinite(r) & np.isfinite(delta)
    if not ok.any():
        return ModelCheck(float("nan"), float("nan"), 0.0, True)
    var = float(noise_std) ** 2
    r2 = _moving_mean_square(np.where(ok, r, np.nan)[None, :], width, True)[0]
    d2 = _moving_mean_square(np.where(ok, delta, np.nan)[None, :], width, True)[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(r2 / var) if var > 0 else np.full(r2.shape, np.inf)
        unexplained = (r2 - var) / d2
    flag = (ratio > RESIDUAL_RATIO) & (unexplained > UNEXPLAINED)
    share = float(np.mean(flag[ok]))
    worst = int(np.nanargmax(np.where(ok, np.where(ratio > RESIDUAL_RATIO, unexplained, -np.inf), -np.inf)))
    return ModelCheck(float(ratio[worst]), float(unexplained[worst]), share, share <= MAX_SHARE)
