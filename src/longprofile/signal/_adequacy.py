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

A second test in the derivative domain (session 41; needs the estimate, ``estimate=``; FIR methods ``ml`` and
``polyfit``): where the polynomial follows the signal, the derivative of order ``o`` equals the rate of change of the
same fit's derivative of order ``o - 1`` (its fitted value for ``o = 1``): ``c[k] = D_o[k] - (D_{o-1}[k] -
D_{o-1}[k-1]) / dt`` is noise plus a small ``dt`` term. Both are FIR filters of ``x``, so the white-noise part of
``c`` has the known power ``sigma^2 ||h_o - (h_{o-1} - shift h_{o-1})||^2 / dt^{2o}``; the excess power beyond it is
bias. Alarm when its RMS exceeds :data:`CONSISTENCY_RATIO` times the RMS of ``derivative_std``: the band is narrower
than the estimate's own inconsistency. It covers what the first test misses when the window spans the signal and the
degree-(d+1) companion is as lost as the fit (a 2 Hz sine, ``ml`` N = 1000 d = 2: coverage 14 %, and 8 % for the
second derivative; the first test's power ratio was 1.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ModelCheck", "model_check", "RESIDUAL_RATIO", "UNEXPLAINED", "CONSISTENCY_RATIO"]

#: The residuals' RMS over the noise std above which the fit is not following the signal.
RESIDUAL_RATIO = 5.0
#: The residuals' excess power over the companion's difference power above which the total std misses the bias.
UNEXPLAINED = 4.0
#: The share of the record where both hold above which the estimate is flagged.
MAX_SHARE = 0.1
#: The derivative-domain test (module docstring): the RMS of the estimate's inconsistency beyond its noise, over the
#: RMS of ``derivative_std``, above which it is flagged. Calibrated in session 41 (docs/signal.md, Model check).
CONSISTENCY_RATIO = 1.3
#: The inconsistency's power must exceed its white-noise power this many times to count (its mean square over a
#: record of a few windows is an average of a few independent values).
_NOISE_MARGIN = 4.0
#: The inconsistency is averaged over window / this many samples (its lag-1 form is mostly the noise of a difference
#: quotient; a lag of a whole window would average out the very oscillation a too-long window misses).
_LAG_DIVISOR = 16


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
        False when both exceed :data:`RESIDUAL_RATIO` and :data:`UNEXPLAINED` on more than :data:`MAX_SHARE` of the
        record, or :attr:`inconsistency` exceeds :data:`CONSISTENCY_RATIO`: the derivative is biased beyond its
        ``derivative_std``.
    inconsistency : float
        RMS of the derivative's inconsistency with the rate of change of the next lower order beyond its noise, over
        the RMS of ``derivative_std`` (module docstring); nan when not computed (no ``estimate``, or Kalman and
        ``backward``).
    """

    residual_ratio: float
    unexplained: float
    share: float
    adequate: bool
    inconsistency: float = float("nan")

    @property
    def reason(self) -> str | None:
        """Why the estimate is flagged: ``"residuals"`` (the lack-of-fit test), ``"inconsistency"`` (the derivative-
        domain test alone), None when adequate."""
        if self.adequate:
            return None
        return "residuals" if self.share > MAX_SHARE else "inconsistency"


def model_check(x, dt, *, method: str, noise_std: float, window: int | None = None, degree: int | None = None,
                q_over_r: float | None = None, smooth: bool = False, steady_state: bool = False,
                skip: int = 0, estimate=None) -> ModelCheck:
    """Lack-of-fit check of a 1-D derivative estimate's model (module docstring); ``skip`` leading samples ignored.

    With ``estimate`` (the :class:`DerivativeResult` checked, ``ml`` or ``polyfit``) the derivative-domain test runs
    too (:attr:`ModelCheck.inconsistency`, at the estimate's order).

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
    incons = float("nan")
    if estimate is not None and method in ("ml", "polyfit"):
        incons = _inconsistency(x, dt, method, n, d, noise_std, estimate, skip)
    return ModelCheck(float(ratio[worst]), float(unexplained[worst]), share,
                      share <= MAX_SHARE and not incons > CONSISTENCY_RATIO, incons)


def _inconsistency(x, dt, method, window, degree, noise_std, estimate, skip) -> float:
    """RMS of ``D_o - diff(D_{o-1}) / dt`` beyond its white-noise part, over the RMS of ``derivative_std``
    (module docstring); nan where undefined (a constant record, no finite sample)."""
    from ._coefficients import ml_coefficients_float, polyfit_coefficients_float
    from ._derivative import derivative_ml, derivative_polyfit

    order = int(estimate.params.get("order", 1))
    taps = ml_coefficients_float if method == "ml" else polyfit_coefficients_float
    run = derivative_ml if method == "ml" else derivative_polyfit
    if order == 1:  # the fitted value (ml's value is x itself: its polyfit, as above)
        lower = derivative_polyfit(x, dt, window=window, degree=degree, noise_std=1.0, std="noise").value
        low_taps = polyfit_coefficients_float(window, degree, 0)
    else:
        lower = run(x, dt, window=window, degree=degree, order=order - 1, noise_std=1.0, std="noise").derivative
        low_taps = taps(window, degree, order - 1)
    own = np.asarray(taps(window, degree, order), dtype=float)
    lag = max(int(window) // _LAG_DIVISOR, 1)
    trapezoid = np.r_[0.5, np.ones(lag - 1), 0.5] / lag  # the mean of D_o over the last lag steps, dt * D_o summed
    kernel = np.zeros(max(own.size + lag, low_taps.size + lag))  # trapezoid * h_o - (h_{o-1} - h_{o-1} delayed) / lag
    kernel[: own.size + lag] += np.convolve(own, trapezoid)
    kernel[: low_taps.size] -= low_taps / lag
    kernel[lag: lag + low_taps.size] += low_taps / lag
    noise_power = float(noise_std) ** 2 * float(np.sum(kernel ** 2)) / dt ** (2 * order)
    d_o = np.asarray(estimate.derivative, dtype=float)
    mean_d = np.convolve(d_o, trapezoid)[lag: d_o.size]  # row k: the trapezoid over rows k - lag .. k
    c = (mean_d - (lower[lag:] - lower[:-lag]) / (lag * dt))[max(skip - lag, 0):]
    std = np.asarray(estimate.derivative_std, dtype=float)[lag:][max(skip - lag, 0):]
    ok = np.isfinite(c) & np.isfinite(std)
    if not ok.any():
        return float("nan")
    band = float(np.sqrt(np.mean(std[ok] ** 2)))
    power = float(np.mean(c[ok] ** 2))
    if power < _NOISE_MARGIN * noise_power:  # within the noise: no evidence of bias (a few independent spans only)
        return 0.0
    excess = power - noise_power
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(np.sqrt(excess) / band) if band > 0 else (float("inf") if excess > 0 else float("nan"))
