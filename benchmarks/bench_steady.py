"""Steady-state filter/smoother throughput and compiled-EKF step time (issue 2 §2, issues 6 and 7 speed needs).

Rows
----
- steady-state filter, n=6 states, m=1 observation (APL-deconvolution size): samples/s, target >= 2e7
  on one core (the public ``steady_state_filter`` call as users make it, DARE included, returning the
  full FilterResult: filtered and predicted means, innovations, per-step log-likelihood). The detail
  also gives the process CPU time of the same calls, which a loaded shared machine inflates less.
- the same with ``store_predictions=False`` (filtered means and total log-likelihood only).
- its ratio to the general ``kalman_filter`` (means only) measured in the same run.
- steady-state smoother (``store_filtered=False``, the road helper's low-memory mode): samples/s.
- EKF with numba-jitted f, h and Jacobians, n=3, m=2: microseconds per step (target <= 2), and the ratio
  of filterpy's ``ExtendedKalmanFilter`` time per step to ours (same model, same data).
- Luenberger observer, continuous model n=2 m=1 run at 1 kHz: real-time factor on a one-hour log (issue 6
  asks EKF + observer >= 500x real time).
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit

from benchmarks._common import BenchRow, best_time
from longprofile.statespace import (
    NonlinearStateSpaceModel,
    StateSpaceModel,
    extended_kalman_filter,
    kalman_filter,
    luenberger_gain,
    luenberger_observer,
    steady_state_filter,
    steady_state_smoother,
)

AREA = "steady"


def _apl_size_model(n=6, m=1, seed=0):
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((n, n))
    F *= 0.98 / max(abs(np.linalg.eigvals(F)))
    H = rng.standard_normal((m, n))
    A = rng.standard_normal((n, n))
    return StateSpaceModel(F, H, 0.1 * A @ A.T + 1e-3 * np.eye(n), 0.5 * np.eye(m), np.zeros(n), np.eye(n))


# ------------------------------------------------------------------ EKF model: 2-D tracking, range/bearing-like
_DT = 0.001


@njit
def _f(x, u, k):
    out = np.empty(3)
    out[0] = x[0] + _DT * x[2] * np.cos(x[1])
    out[1] = x[1] + _DT * 0.5 * np.sin(x[0])
    out[2] = 0.999 * x[2]
    return out


@njit
def _fj(x, u, k):
    J = np.zeros((3, 3))
    J[0, 0] = 1.0
    J[0, 1] = -_DT * x[2] * np.sin(x[1])
    J[0, 2] = _DT * np.cos(x[1])
    J[1, 0] = _DT * 0.5 * np.cos(x[0])
    J[1, 1] = 1.0
    J[2, 2] = 0.999
    return J


@njit
def _h(x, u, k):
    out = np.empty(2)
    out[0] = np.sqrt(1.0 + x[0] * x[0])
    out[1] = x[1] * x[2]
    return out


@njit
def _hj(x, u, k):
    J = np.zeros((2, 3))
    J[0, 0] = x[0] / np.sqrt(1.0 + x[0] * x[0])
    J[1, 1] = x[2]
    J[1, 2] = x[1]
    return J


_Q = np.diag([1e-6, 1e-6, 1e-5])
_R = np.diag([1e-3, 1e-3])
_X0 = np.array([0.5, 0.2, 1.0])


def _wall_and_cpu(fn, repeat):
    """Best wall-clock and best process-CPU time (s) of ``fn()`` over ``repeat`` runs."""
    wall = cpu = float("inf")
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        c1, t1 = time.process_time(), time.perf_counter()
        wall, cpu = min(wall, t1 - t0), min(cpu, c1 - c0)
    return wall, cpu


def _filterpy_ekf_time(y):
    from filterpy.kalman import ExtendedKalmanFilter

    class EKF(ExtendedKalmanFilter):
        def predict_x(self, u=0):
            self.x = _f.py_func(self.x[:, 0], None, 0)[:, None]

    def run():
        ekf = EKF(dim_x=3, dim_z=2)
        ekf.x, ekf.P, ekf.Q, ekf.R = _X0[:, None].copy(), np.eye(3), _Q.copy(), _R.copy()
        hj = lambda x: _hj.py_func(x[:, 0], None, 0)  # noqa: E731
        hx = lambda x: _h.py_func(x[:, 0], None, 0)[:, None]  # noqa: E731
        for k in range(len(y)):
            if k:
                ekf.F = _fj.py_func(ekf.x[:, 0], None, 0)
                ekf.predict()
            ekf.update(y[k][:, None], hj, hx)

    return best_time(run, repeat=2)


def run(quick: bool) -> list[BenchRow]:
    rows = []
    # ---------------------------------------------------------- steady-state filter / smoother
    T = 100_000 if quick else 10_000_000
    T_general = 10_000 if quick else 200_000
    model = _apl_size_model()
    y = np.random.default_rng(1).standard_normal(T)
    steady_state_filter(model, y[:100])  # compile / load the cached kernels
    steady_state_filter(model, y[:100], store_predictions=False)
    steady_state_smoother(model, y[:100], store_filtered=False)
    t_ss, c_ss = _wall_and_cpu(lambda: steady_state_filter(model, y), 3)  # includes solving the DARE
    rate = T / t_ss
    # targets apply to the full sizes only (quick mode is dominated by fixed per-call costs)
    rows.append(BenchRow(AREA, "steady_state_filter n=6 m=1", rate, "samples/s", target=None if quick else 2e7,
                         detail=f"T={T}, full FilterResult (means, pred means, innovations, loglik); "
                                f"CPU time {T / c_ss:.3g} samples/s"))
    t_lean, c_lean = _wall_and_cpu(lambda: steady_state_filter(model, y, store_predictions=False), 3)
    rows.append(BenchRow(AREA, "steady_state_filter n=6 m=1 (store_predictions=False)", T / t_lean, "samples/s",
                         detail=f"T={T}, filtered means + total loglik; CPU time {T / c_lean:.3g} samples/s"))
    kalman_filter(model, y[:100], store_covariances=False)
    t_kf = best_time(lambda: kalman_filter(model, y[:T_general], store_covariances=False), repeat=2)
    rows.append(BenchRow(AREA, "steady_state_filter vs kalman_filter (means only)", rate / (T_general / t_kf), "x",
                         detail=f"general filter {T_general / t_kf:.3g} samples/s on T={T_general}"))
    t_sm = best_time(lambda: steady_state_smoother(model, y, store_filtered=False), repeat=2)
    rows.append(BenchRow(AREA, "steady_state_smoother n=6 m=1 (store_filtered=False)", T / t_sm, "samples/s",
                         detail=f"T={T}, forward + backward pass"))
    # ---------------------------------------------------------- EKF with jitted model functions
    T_ekf = 20_000 if quick else 1_000_000
    T_fp = 500 if quick else 20_000
    ekf_model = NonlinearStateSpaceModel(_f, _h, _Q, _R, _X0, np.eye(3), _fj, _hj)
    rng = np.random.default_rng(2)
    y2 = np.column_stack([np.sqrt(1.25) + 0.03 * rng.standard_normal(T_ekf), 0.2 + 0.03 * rng.standard_normal(T_ekf)])
    extended_kalman_filter(ekf_model, y2[:10])  # compile (once per process for these functions)
    t_e = best_time(lambda: extended_kalman_filter(ekf_model, y2), repeat=3)
    us = t_e / T_ekf * 1e6
    rows.append(BenchRow(AREA, "EKF n=3 m=2 jitted f/h/Jacobians", us, "us/step", target=None if quick else 2.0,
                         higher_is_better=False, detail=f"T={T_ekf}, covariances and Jacobians stored"))
    t_lean = best_time(lambda: extended_kalman_filter(ekf_model, y2, store_covariances=False), repeat=3)
    rows.append(BenchRow(AREA, "EKF n=3 m=2 jitted, means only", t_lean / T_ekf * 1e6, "us/step",
                         higher_is_better=False, detail=f"T={T_ekf}"))
    t_fp = _filterpy_ekf_time(y2[:T_fp])
    rows.append(BenchRow(AREA, "EKF speed-up vs filterpy ExtendedKalmanFilter", (t_fp / T_fp) / (t_e / T_ekf), "x",
                         detail=f"filterpy {t_fp / T_fp * 1e6:.3g} us/step on T={T_fp}"))
    # ---------------------------------------------------------- Luenberger observer at 1 kHz
    T_obs = 100_000 if quick else 3_600_000
    A = np.array([[0.0, 1.0], [0.0, -0.1]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[1.0, 0.0]])
    L = luenberger_gain(A, C, [-5.0, -6.0])
    y3 = np.random.default_rng(3).standard_normal(T_obs)
    u3 = np.ones((T_obs, 1))
    luenberger_observer(A, B, C, L, y3[:10], u=u3[:10], dt=1e-3)
    t_o = best_time(lambda: luenberger_observer(A, B, C, L, y3, u=u3, dt=1e-3), repeat=3)
    rows.append(BenchRow(AREA, "luenberger_observer n=2 m=1 at 1 kHz", (T_obs * 1e-3) / t_o, "x real time",
                         detail=f"T={T_obs} samples ({T_obs * 1e-3:.0f} s of log)"))
    return rows
