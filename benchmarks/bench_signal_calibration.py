"""Derivative estimator calibration on independent cases (issue 13): coverage of ``derivative_std``.

Every estimator of ``longprofile.signal`` (``longprofile differentiate``) prints ``derivative_std``. Here it is
checked against the true derivative on random signals with effects beyond the estimators' models (a polynomial of
degree d over the window for the FIR methods, a random-walk (degree+1)-th derivative for the Kalman methods, white
noise of known std for all), drawn at random per family:

* ``smooth``            -- band-limited noise: 30 sines with frequencies uniform up to a cut-off drawn log-uniform
  in 0.5-20 Hz (so the window is from far shorter to far longer than the signal's time scale), white noise of
  1e-4-3e-2 x the signal RMS, ``noise_std`` estimated (the default);
* ``smooth, noise given`` -- the same draws with the true ``noise_std`` given;
* ``sines``             -- 1-4 sines, 0.3-15 Hz (log-uniform), amplitudes 0.1-1;
* ``chirp``             -- a linear chirp from 0.2-2 Hz to 5-20 Hz over the record;
* ``triangle``          -- a triangle wave of period 0.3-2 s (kinks: the derivative steps);
* ``square-ish``        -- tanh(sin(2 pi t / P) / w), P 0.3-2 s, w 0.02-0.3 (near-steps for small w);
* ``AR(1) noise``       -- the smooth signal with AR(1) noise, correlation 0.3-0.95 per sample (model: white);
* ``heavy tails``       -- the smooth signal with Student-t noise, 2.5-5 degrees of freedom (outliers);
* ``quantised``         -- the smooth signal quantised in steps of 3e-4-3e-2 x its RMS, with a dither of
  1e-5-1e-4 x its RMS (the quantisation error is neither white nor independent of the signal); ``noise_std`` is
  given as sqrt(step^2 / 12 + dither^2) (the estimate is 0 on such data, which the Kalman method refuses).

Methods: ``ml`` degrees 1-3, ``polyfit`` degrees 1 and 2, ``backward`` n = 1 and 2, ``kalman`` (filter and
``smooth=True``, degree 2). Per draw and method the error-optimal setting is found on a grid against the truth (16
windows log-spaced from the degree to 1200 samples; q/r dt^6 = 1e-20 .. 1: 21 decades), then the setting a user
would pick is drawn around it: the window times u, u log-uniform in 0.5-3 (longer windows: more bias), q/r times
u^-6 for the Kalman (the same factor on its time scale); ``backward`` has no setting. 5000 samples of 1 ms; the
first 1000 (or the window + 1) are left out. Coverage = share of samples whose true derivative is inside
derivative +- 1.645 derivative_std (target 85-95 %); z = error / std, its RMS (target ~1); PIT = Phi(z) decile
shares (target 10 % each).

Each method runs with the default ``std`` and, as the peer in the same run, with ``std="noise"`` (the noise-only
std that was the only one before issue 13).

Seeds: the rows use seed 0; the constants of ``std="total"`` were chosen on ``calibrate(..., seed=1000)``, so the
rows are out-of-sample.

Run: ``python -m benchmarks signal_calibration`` (full: 96 draws per family; 24 until 2026-12-06 session 27) or ``--quick`` (2 draws of two
families, seconds).
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks._common import BenchRow, CoverageScore

AREA = "signal_calibration"
DT, N_SAMPLES, SKIP = 1e-3, 5000, 1000
FAMILIES = ("smooth", "smooth, noise given", "sines", "chirp", "triangle", "square-ish", "AR(1) noise",
            "heavy tails", "quantised")
#: (label, registry method, fixed options, tuned option or None)
METHODS = (("ml d=1", "ml", {"degree": 1}, "window"), ("ml d=2", "ml", {"degree": 2}, "window"),
           ("ml d=3", "ml", {"degree": 3}, "window"), ("polyfit d=1", "polyfit", {"degree": 1}, "window"),
           ("polyfit d=2", "polyfit", {"degree": 2}, "window"), ("backward n=1", "backward", {"degree": 1}, None),
           ("backward n=2", "backward", {"degree": 2}, None),
           ("kalman filter", "kalman", {"degree": 2}, "q_over_r"),
           ("kalman smoother", "kalman", {"degree": 2, "smooth": True}, "q_over_r"))
MAX_WINDOW = 1200


def _smooth(rng, t):
    fc = 10 ** rng.uniform(np.log10(0.5), np.log10(20.0))
    f = rng.uniform(0.0, fc, 30)
    a, ph = rng.standard_normal(30) / np.sqrt(30), rng.uniform(0, 2 * np.pi, 30)
    arg = 2 * np.pi * f[:, None] * t + ph[:, None]
    return (a[:, None] * np.sin(arg)).sum(0), (a[:, None] * 2 * np.pi * f[:, None] * np.cos(arg)).sum(0)


def _sines(rng, t):
    k = rng.integers(1, 5)
    f = 10 ** rng.uniform(np.log10(0.3), np.log10(15.0), k)
    a, ph = 10 ** rng.uniform(-1, 0, k), rng.uniform(0, 2 * np.pi, k)
    arg = 2 * np.pi * f[:, None] * t + ph[:, None]
    return (a[:, None] * np.sin(arg)).sum(0), (a[:, None] * 2 * np.pi * f[:, None] * np.cos(arg)).sum(0)


def _chirp(rng, t):
    f0, f1, span = rng.uniform(0.2, 2.0), rng.uniform(5.0, 20.0), t[-1]
    ph = 2 * np.pi * (f0 * t + (f1 - f0) * t ** 2 / (2 * span)) + rng.uniform(0, 2 * np.pi)
    return np.sin(ph), np.cos(ph) * 2 * np.pi * (f0 + (f1 - f0) * t / span)


def _triangle(rng, t):
    period, phase = rng.uniform(0.3, 2.0), rng.uniform()
    u = (t / period + phase) % 1.0
    return 2 * np.abs(2 * u - 1) - 1, np.where(u < 0.5, -4.0, 4.0) / period


def _square(rng, t):
    period, width, phase = rng.uniform(0.3, 2.0), rng.uniform(0.02, 0.3), rng.uniform(0, 2 * np.pi)
    s = np.tanh(np.sin(2 * np.pi * t / period + phase) / width)
    return s, (1 - s ** 2) * np.cos(2 * np.pi * t / period + phase) * 2 * np.pi / (period * width)


SIGNALS = {"sines": _sines, "chirp": _chirp, "triangle": _triangle, "square-ish": _square}


def draw_case(family: str, rng) -> tuple[np.ndarray, np.ndarray, float | None]:
    """One random test signal of ``family``: (noisy x, true derivative, noise_std to give or None)."""
    from scipy.signal import lfilter

    t = np.arange(N_SAMPLES) * DT
    clean, truth = SIGNALS.get(family, _smooth)(rng, t)
    rms = float(np.sqrt(np.mean(clean ** 2)))
    sigma = rms * 10 ** rng.uniform(-4.0, np.log10(3e-2))
    w = rng.standard_normal(N_SAMPLES)
    given = None
    if family == "AR(1) noise":
        rho = rng.uniform(0.3, 0.95)
        noise = sigma * np.sqrt(1 - rho ** 2) * lfilter([1.0], [1.0, -rho], w)
    elif family == "heavy tails":
        noise = sigma * rng.standard_t(rng.uniform(2.5, 5.0), N_SAMPLES)
    elif family == "quantised":
        step = rms * 10 ** rng.uniform(np.log10(3e-4), np.log10(3e-2))
        dither = rms * 10 ** rng.uniform(-5.0, -4.0)
        # the noise estimate is 0 on such data (the estimators ask for noise_std): the user gives step / sqrt(12)
        return step * np.round((clean + dither * w) / step), truth, float(np.hypot(step / np.sqrt(12), dither))
    else:
        noise = sigma * w
        if family == "smooth, noise given":
            given = sigma
    return clean + noise, truth, given


def _run(method, options, x, noise_std, extra=None):
    from longprofile.signal import derivative

    return derivative(x, DT, method=method, noise_std=noise_std, **options, **(extra or {}))


def _grid(tuned, degree):
    if tuned == "window":
        return sorted({max(degree, int(round(w))) for w in np.geomspace(degree, MAX_WINDOW, 16)})
    return [10.0 ** k / DT ** 6 for k in range(-20, 1)]


def _grid_estimate(method, options, tuned, value, x):
    """The derivative at one grid setting (FIR methods by ``lfilter`` on the float taps: the same numbers to
    round-off, without the exact-rational variance gain that only ``derivative_std`` needs)."""
    from scipy.signal import lfilter

    from longprofile.signal import ml_coefficients_float, polyfit_coefficients_float

    if tuned == "q_over_r":
        return _run(method, {**options, tuned: value}, x, 1.0).derivative
    taps = (ml_coefficients_float if method == "ml" else polyfit_coefficients_float)(value, options["degree"], 1)
    out = lfilter(taps / DT, 1.0, x)
    out[:value] = np.nan
    return out


def _rms(err):
    return float(np.sqrt(np.nanmean(err[SKIP:] ** 2)))


def user_setting(method, options, tuned, x, truth, rng) -> dict:
    """The options a user would pick: the error-optimal grid setting times a random factor in 0.5-3."""
    if tuned is None:
        return dict(options)
    grid = _grid(tuned, options["degree"])
    errors = [_rms(_grid_estimate(method, options, tuned, g, x) - truth) for g in grid]
    best = grid[int(np.nanargmin(errors))]
    u = float(np.exp(rng.uniform(np.log(0.5), np.log(3.0))))
    if tuned == "window":
        return {**options, "window": int(min(MAX_WINDOW, max(options["degree"], round(best * u))))}
    return {**options, "q_over_r": best * u ** -6}


def calibrate(family: str, draws: int, *, seed: int = 0, methods=METHODS, stds=None) -> dict:
    """Scores {(method label, std option): CoverageScore} of one family over ``draws`` random signals.

    ``std`` option ``"default"`` calls the estimators without ``std`` (what a user gets), any other value is
    passed as ``std=``; None: both when the estimators take ``std`` (see :func:`_std_options`).
    """
    stds = _std_options() if stds is None else stds
    rng = np.random.default_rng([seed, sum(map(ord, family))])
    scores = {(label, s): CoverageScore() for label, *_ in methods for s in stds}
    for _ in range(draws):
        x, truth, given = draw_case(family, rng)
        for label, method, options, tuned in methods:
            setting = user_setting(method, options, tuned, x, truth, rng)
            skip = max(SKIP, setting.get("window", 0) + 1)
            for s in stds:
                res = _run(method, setting, x, given, None if s == "default" else {"std": s})
                scores[(label, s)].add((res.derivative - truth)[skip:], res.derivative_std[skip:])
    return scores


def run(quick: bool) -> list[BenchRow]:
    families, draws = FAMILIES, 96
    if quick:  # a smoke run: two draws of two families
        families, draws = ("smooth", "triangle"), 2
    rows = []
    for family in families:
        t0 = time.perf_counter()
        scores = calibrate(family, draws)
        elapsed = time.perf_counter() - t0
        for (label, s), sc in scores.items():
            rows.append(_row(family, label, s, sc, draws, elapsed, quick))
    return rows


def _std_options():
    """("default", "noise") when the estimators take ``std``, else ("default",) (the code before issue 13)."""
    import inspect

    from longprofile.signal import derivative

    return ("default", "noise") if "std" in inspect.signature(derivative).parameters else ("default",)


def _row(family, label, s, sc, draws, elapsed, quick) -> BenchRow:
    peer = s != "default"
    return BenchRow(AREA, f"{family}: {label} derivative_std 90 % coverage" + (f", std={s!r}" if peer else ""),
                    100 * sc.coverage, "%", target=None if quick or peer else 85.0,
                    target_max=None if quick or peer else 95.0,
                    detail=f"{sc.detail()}; {draws} draws, {elapsed:.1f} s")
