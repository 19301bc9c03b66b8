"""Benchmarks of the linear state-space engine (``python -m benchmarks statespace``).

Figures (issue 2, section 2):

* time-varying filter + RTS smoother, n = 4 states, m = 2 observations, T = 20 000:
  speed ratio vs statsmodels' Cython ``KalmanSmoother`` (target >= 4) and vs filterpy's
  ``KalmanFilter`` predict/update loop + ``rts_smoother`` (target >= 40), on the same data;
  the smoothed means of both peers are checked against ours before timing;
* means-only filter throughput (samples/s, time-varying model);
* batched filter + smoother throughput (samples/s over all series);
* exact fixed-lag smoother (time-varying gains) against the term-by-term lag sum it replaced (the L future
  innovations' gains propagated one lag step at a time over all t, vectorised NumPy: O(T L n^2 k)), same data,
  means and covariances checked equal before timing.

numba compilation is excluded (every kernel is warmed up first).
"""

from __future__ import annotations

import numpy as np

from benchmarks._common import BenchRow, best_time
from longprofile.statespace import StateSpaceModel, fixed_lag_smoother, kalman_filter, rts_smoother, simulate

AREA = "statespace"


def _tv_model(T: int, n: int = 4, m: int = 2, seed: int = 0):
    """A random stable time-varying model (per-step F_k, H_k, Q_k, R_k) and data drawn from it."""
    rng = np.random.default_rng(seed)
    F = np.empty((T - 1, n, n))
    base = rng.normal(size=(n, n))
    base = 0.95 * base / np.max(np.abs(np.linalg.eigvals(base)))
    for k in range(T - 1):
        F[k] = base + 0.02 * np.sin(0.001 * k) * np.eye(n)
    H = rng.normal(size=(m, n)) + 0.1 * np.sin(0.003 * np.arange(T))[:, None, None]
    q = 0.1 + 0.05 * np.cos(0.002 * np.arange(T - 1))
    Q = q[:, None, None] * np.eye(n)
    r = 0.5 + 0.2 * np.sin(0.004 * np.arange(T))
    R = r[:, None, None] * np.array([[1.0, 0.3], [0.3, 1.0]])[:m, :m]
    model = StateSpaceModel(F, H, Q, R, np.zeros(n), np.eye(n))
    _x, y = simulate(model, T, rng=seed)
    return model, y


def _interleaved_best(fns, repeat: int) -> list[float]:
    """Best wall time of each function, timed in alternation so that load changes on a shared
    machine hit every contender alike (the ratio is what is reported)."""
    best = [float("inf")] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            best[i] = min(best[i], best_time(fn, repeat=1))
    return best


def _ours(model, y):
    f = kalman_filter(model, y)
    return rts_smoother(model, f)


def _statsmodels_setup(model, y):
    from statsmodels.tsa.statespace.kalman_smoother import (
        SMOOTHER_STATE,
        SMOOTHER_STATE_AUTOCOV,
        SMOOTHER_STATE_COV,
        KalmanSmoother,
    )
    T, m = y.shape
    n = model.n_states
    ks = KalmanSmoother(k_endog=m, k_states=n, k_posdef=n)
    ks.bind(np.asfortranarray(y.T))
    ks["design"] = np.asfortranarray(model.observation.transpose(1, 2, 0))
    ks["obs_cov"] = np.asfortranarray(model.obs_cov.transpose(1, 2, 0))
    # statsmodels needs T transition matrices (the last one is never used)
    Fs = np.concatenate([model.transition, model.transition[-1:]], axis=0)
    Qs = np.concatenate([model.process_cov, model.process_cov[-1:]], axis=0)
    ks["transition"] = np.asfortranarray(Fs.transpose(1, 2, 0))
    ks["selection"] = np.eye(n)
    ks["state_cov"] = np.asfortranarray(Qs.transpose(1, 2, 0))
    ks.initialize_known(np.asarray(model.initial_mean), np.asarray(model.initial_cov))
    # same outputs as ours: smoothed states, their covariances and the lag-one autocovariances
    output = SMOOTHER_STATE | SMOOTHER_STATE_COV | SMOOTHER_STATE_AUTOCOV

    def run():
        ks._filter()
        return ks._smooth(smoother_output=output)

    return run


def _filterpy_run(model, y):
    from filterpy.kalman import KalmanFilter
    from filterpy.kalman import rts_smoother as fp_rts
    T, m = y.shape
    n = model.n_states
    F, H, Q, R = model.transition, model.observation, model.process_cov, model.obs_cov
    Fs = list(F) + [F[-1]]
    Qs = list(Q) + [Q[-1]]

    def run():
        kf = KalmanFilter(dim_x=n, dim_z=m)
        kf.x = np.array(model.initial_mean)
        kf.P = np.array(model.initial_cov)
        xs = np.empty((T, n))
        Ps = np.empty((T, n, n))
        for k in range(T):
            if k:
                kf.predict(F=F[k - 1], Q=Q[k - 1])
            kf.update(y[k], R=R[k], H=H[k])
            xs[k] = kf.x
            Ps[k] = kf.P
        return fp_rts(xs, Ps, Fs, Qs)

    return run


def _term_by_term_fixed_lag(model, y, lag):
    """The peer: E[x_t | y_0..t+L] of all states by the lag sum propagated one lag step at a time (complete data)."""
    filt = kalman_filter(model, y, store_covariances=True)
    T, n = filt.mean.shape
    H = np.broadcast_to(model.observation, (T, y.shape[1], n)) if model.observation.ndim == 2 else model.observation
    chol = np.linalg.cholesky(filt.innovation_cov)
    Hw = np.linalg.solve(chol, H)
    ew = np.linalg.solve(chol, filt.innovation[..., None])
    HwT = np.swapaxes(Hw, 1, 2)
    closed = np.eye(n) - (filt.pred_cov[:-1] @ HwT[:-1]) @ Hw[:-1]
    closed_T = np.swapaxes(model.transition @ closed, 1, 2)
    mean, cov, psi = filt.mean.copy(), filt.cov.copy(), filt.pred_cov.copy()
    for i in range(1, min(lag, T - 1) + 1):
        rows = T - i
        psi = psi[:rows] @ closed_T[i - 1:i - 1 + rows]
        c = psi @ HwT[i:]
        mean[:rows] += (c @ ew[i:])[..., 0]
        cov[:rows] -= c @ np.swapaxes(c, 1, 2)
    return mean, cov


def _fixed_lag_row(quick: bool) -> BenchRow:
    T, lag = (2_000, 100) if quick else (20_000, 1_000)
    model, y = _tv_model(T, seed=3)
    ours = fixed_lag_smoother(model, y, lag)  # warm-up (numba cache load)
    ref_mean, ref_cov = _term_by_term_fixed_lag(model, y, lag)
    err = max(float(np.max(np.abs(ours.mean - ref_mean))), float(np.max(np.abs(ours.cov - ref_cov))))
    if not err < 1e-9:
        raise RuntimeError(f"fixed-lag smoother and the term-by-term lag sum disagree (max diff {err:.3g})")
    t_ours, t_peer = _interleaved_best([lambda: fixed_lag_smoother(model, y, lag),
                                        lambda: _term_by_term_fixed_lag(model, y, lag)], 2 if quick else 3)
    return BenchRow(AREA, f"exact fixed-lag smoother vs term-by-term lag sum (n=4, m=2, T={T}, L={lag})",
                    t_peer / t_ours, "x", target=5.0,
                    detail=f"ours {t_ours * 1e3:.1f} ms (filter included), term by term {t_peer * 1e3:.0f} ms; "
                           f"max |diff| {err:.1e}")


def run(quick: bool) -> list[BenchRow]:
    T = 2_000 if quick else 20_000
    repeat = 2 if quick else 7
    model, y = _tv_model(T)
    ours = _ours(model, y)  # warm-up (numba compile / cache load)
    rows = []

    sm_run = _statsmodels_setup(model, y)
    sm_res = sm_run()
    err_sm = float(np.max(np.abs(np.asarray(sm_res.smoothed_state).T - ours.mean)))
    err_sm_cov = float(np.max(np.abs(np.asarray(sm_res.smoothed_state_cov).transpose(2, 0, 1) - ours.cov)))
    if not (err_sm < 1e-8 and err_sm_cov < 1e-8):
        raise RuntimeError("statsmodels and longprofile disagree on the smoothed moments "
                           f"(max diff means {err_sm:.3g}, covariances {err_sm_cov:.3g})")
    t_ours, t_sm = _interleaved_best([lambda: _ours(model, y), sm_run], repeat)
    rows.append(BenchRow(AREA, f"TV filter+smoother vs statsmodels (n=4, m=2, T={T})", t_sm / t_ours, "x",
                         target=4.0, detail=f"ours {t_ours * 1e3:.2f} ms, statsmodels {t_sm * 1e3:.2f} ms; "
                                            f"max |diff| means {err_sm:.1e}, covs {err_sm_cov:.1e}"))

    fp_run = _filterpy_run(model, y)
    fp_res = fp_run()
    err_fp = float(np.max(np.abs(fp_res[0] - ours.mean)))
    if not err_fp < 1e-8:
        raise RuntimeError(f"filterpy and longprofile disagree on the smoothed means (max diff {err_fp:.3g})")
    t_ours_fp, t_fp = _interleaved_best([lambda: _ours(model, y), fp_run], 1 if quick else 2)
    t_ours = min(t_ours, t_ours_fp)
    rows.append(BenchRow(AREA, f"TV filter+smoother vs filterpy (n=4, m=2, T={T})", t_fp / t_ours, "x",
                         target=40.0, detail=f"ours {t_ours * 1e3:.2f} ms, filterpy {t_fp * 1e3:.1f} ms; "
                                             f"max |mean diff| {err_fp:.1e}"))

    # means-only filter throughput on a long time-varying series
    Tl = 20_000 if quick else 1_000_000
    long_model, long_y = _tv_model(Tl, seed=1)
    t_mo = best_time(lambda: kalman_filter(long_model, long_y, store_covariances=False), repeat=repeat if quick else 3)
    rows.append(BenchRow(AREA, f"means-only TV filter throughput (n=4, m=2, T={Tl})", Tl / t_mo, "samples/s",
                         detail=f"{t_mo * 1e3:.1f} ms"))

    # batched filter + smoother: B series of the same (time-varying) model
    nb = 8 if quick else 32
    rng = np.random.default_rng(2)
    yb = y[None] + 0.1 * rng.normal(size=(nb,) + y.shape)
    _ours(model, yb)
    t_b = best_time(lambda: _ours(model, yb), repeat=repeat if quick else 3)
    rows.append(BenchRow(AREA, f"batched TV filter+smoother throughput (B={nb}, T={T})", nb * T / t_b, "samples/s",
                         detail=f"{t_b * 1e3:.1f} ms"))
    rows.append(_fixed_lag_row(quick))
    return rows
