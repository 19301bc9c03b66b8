"""The printed std of a reconstruction inside and around gaps of the APL record (issue 13; paper 000, §5).

The Kalman reconstructions bridge missing samples (NaN), and their per-sample posterior std (``raw_std``) grows
there. The printed std of the *detrended* profile, ``profile.std``, is the stationary error of the detrended
estimate (:func:`smoother_error_std`, :func:`fixed_lag_error_std`): it did not know about gaps, and inside a
10 m gap of the README's class C record it covered the truth at 11 % (smoother) and 30 % (fixed-lag) instead of 90 %.
(The smoother's ``raw_std`` cannot stand in for it: with the Wiener road model the absolute level is not observable
and its variance grows along the record, gap or not; the detrending removes that part.)

Here the variance that the gaps add to the detrended error is measured by Monte Carlo on the model itself, with
common random numbers: records are drawn from the reconstruction's own state-space model (the same q, r, road
model), on a window of two high-pass wavelengths either side of each cluster of gaps; each draw is estimated twice
by the method's own pass -- with the record's NaN pattern and complete -- and both errors are detrended like the
profile. The excess, mean over the draws of the squared detrended error with gaps minus without, clipped at 0,
is added to the variance of ``profile.std``:

    std^2 = std_stationary^2 (+ instrument terms) + max(0, E[e_gap^2] - E[e_complete^2]).

Assumptions (named): (1) the error the gaps add follows the reconstruction's model (the same assumption as the
stationary std; model mismatch is the instrument uncertainty's business); (2) a gap's influence ends within two
high-pass wavelengths (beyond, the estimate with and without the gap agree to round-off: the detrending forgets
longer waves); (3) a fixed number of draws (:data:`GAP_DRAWS`, seeded, so that a reconstruction is reproducible):
the excess carries a Monte Carlo relative error of about sqrt(2 / GAP_DRAWS) on its variance.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...statespace import StateSpaceModel, simulate

__all__ = ["GAP_DRAWS", "gap_windows", "gap_error_variance"]

#: Monte Carlo draws per cluster of gaps (each estimated with and without the gaps).
GAP_DRAWS = 48


def gap_windows(missing: np.ndarray, margin: int) -> list[tuple[int, int]]:
    """Half-open sample ranges [start, stop) covering each run of ``missing`` samples with ``margin`` samples either
    side (clipped to the record), overlapping ranges merged; [] without missing samples."""
    idx = np.flatnonzero(missing)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate(([idx[0]], idx[breaks + 1]))
    stops = np.concatenate((idx[breaks] + 1, [idx[-1] + 1]))
    out: list[tuple[int, int]] = []
    for a, b in zip(starts, stops):
        lo, hi = max(0, int(a) - margin), min(missing.size, int(b) + margin)
        if out and lo <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def gap_error_variance(missing: np.ndarray, model: StateSpaceModel, estimate: Callable[[np.ndarray], np.ndarray],
                       detrend: Callable[[np.ndarray], np.ndarray], margin: int, *, n_draws: int = GAP_DRAWS,
                       rng=0, window_model: Callable[[int, int], StateSpaceModel] | None = None) -> np.ndarray | None:
    """Per-sample variance (m^2) that the missing samples add to the error of the detrended estimate.

    Parameters
    ----------
    missing : (T,) bool ndarray
        True where the record has no sample.
    model : StateSpaceModel
        The reconstruction's state-space model; its last state is the elevation.
    estimate : callable
        ``estimate(Y)`` with Y (B, Tw, 1) of one NaN pattern -> (B, Tw) elevation estimates: the method's pass.
    detrend : callable
        ``detrend(E)`` with E (Tw, B) -> the detrended columns, as the profile is detrended.
    margin : int
        Samples either side of a gap over which its influence is measured (assumption 2 of the module).
    n_draws : int
        Monte Carlo draws per cluster of gaps.
    rng : int or numpy.random.Generator
        Seed of the draws (fixed by default: the same record gives the same std).
    window_model : callable, optional
        ``window_model(lo, hi)`` -> the model of samples [lo, hi) of a time-varying ``model`` (a record towed at a
        varying speed): the draws of a window come from it and ``estimate`` is called as ``estimate(Y, model)``.
        Default None: ``model`` for every window, ``estimate(Y)``.

    Returns
    -------
    (T,) ndarray or None
        The excess variance, 0 away from the gaps; None when nothing is missing.
    """
    windows = gap_windows(np.asarray(missing, bool), margin)
    if not windows:
        return None
    gen = np.random.default_rng(rng)
    out = np.zeros(missing.size)
    for lo, hi in windows:
        tw = hi - lo
        wmodel = model if window_model is None else window_model(lo, hi)

        def run(Y, wmodel=wmodel):
            return estimate(Y) if window_model is None else estimate(Y, wmodel)
        # draws in chunks: the estimates of a chunk hold (chunk, tw, n) means (about 40 MB at most per chunk)
        chunk = int(max(1, min(n_draws, 5e6 // max(1, tw * model.n_states))))
        excess = np.zeros(tw)
        for start in range(0, n_draws, chunk):
            draws = [simulate(wmodel, tw, rng=gen) for _ in range(min(chunk, n_draws - start))]
            truth = np.stack([x[:, -1] for x, _ in draws])
            complete = np.stack([y for _, y in draws])
            gapped = complete.copy()
            gapped[:, missing[lo:hi]] = np.nan
            e_gap = detrend((truth - run(gapped)).T)
            e_full = detrend((truth - run(complete)).T)
            excess += np.sum(e_gap ** 2 - e_full ** 2, axis=1)
        out[lo:hi] = np.maximum(excess / n_draws, 0.0)
    return out
