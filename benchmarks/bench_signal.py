"""Derivative estimators (paper 002): accuracy against PyNumDiff, and throughput.

Accuracy: RMS derivative error on PyNumDiff's own simulated test signals
(``pynumdiff.utils.simulate``: sine, triangle, lorenz_x, pi_cruise_control) with
white noise, every method tuned by the same kind of small grid search against
the known truth (the best setting is reported). Errors are measured on the
middle 80 % of the record, so neither the causal warm-up of our FIR
estimators nor the end effects of the non-causal peers count. Causal and
non-causal estimators are reported separately (a causal estimator must lag).

Throughput: ``derivative(x, dt, method="ml", window=45, degree=2)`` (the
paper's §4 setting) on 10^7 samples (10^5 in quick mode), with the default
``std="total"`` and with ``std="noise"``, and scipy's ``lfilter`` on the same
46 taps as the peer in the same run.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from benchmarks._common import BenchRow, best_time

AREA = "signal"


def _pynumdiff():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pynumdiff warns at import about optional CVXPY methods
        import pynumdiff
        from pynumdiff.utils import simulate
    return pynumdiff, simulate


def _grids(quick: bool):
    pnd, _ = _pynumdiff()
    windows = (5, 10, 20) if quick else (5, 10, 20, 30, 45, 60, 90, 120, 180)
    qs = (1e4, 1e8) if quick else tuple(10.0 ** k for k in range(2, 15))
    ours = {
        "ml (causal)": [dict(method="ml", degree=d, window=w) for d, w in itertools.product((1, 2, 3), windows)
                        if w >= d],
        "polyfit (causal)": [dict(method="polyfit", degree=d, window=w)
                             for d, w in itertools.product((1, 2, 3), windows) if w >= d],
        "backward (causal)": [dict(method="backward", degree=d) for d in (1, 2)],
        "kalman filter (causal)": [dict(method="kalman", degree=d, q_over_r=q * 1e4 ** (d - 2))
                                   for d, q in itertools.product((2, 3), qs)],
        "kalman smoother": [dict(method="kalman", degree=d, q_over_r=q * 1e4 ** (d - 2), smooth=True)
                            for d, q in itertools.product((2, 3), qs)],
    }
    peers = {
        "pynumdiff.finitediff": [(pnd.finitediff, dict(num_iterations=i, order=o))
                                 for i, o in itertools.product((1, 2, 4, 8) if not quick else (1,), (2, 4))],
        "pynumdiff.savgoldiff": [(pnd.savgoldiff, dict(degree=d, window_size=w, smoothing_win=s))
                                 for d, w, s in itertools.product((2, 3), (11, 21, 41, 61, 91) if not quick else (21,),
                                                                  (1, 11, 21) if not quick else (11,))],
        "pynumdiff.butterdiff": [(pnd.butterdiff, dict(filter_order=o, cutoff_freq=c))
                                 for o, c in itertools.product((2, 3), (0.02, 0.05, 0.1, 0.2, 0.4) if not quick
                                                               else (0.1,))],
        "pynumdiff.rtsdiff": [(pnd.rtsdiff, dict(order=o, log_qr_ratio=q, forwardbackward=True))
                              for o, q in itertools.product((2, 3), range(-2, 14, 2) if not quick else (4,))],
    }
    return ours, peers


def _rms(est, truth, sl):
    err = np.asarray(est)[sl] - truth[sl]
    if not np.all(np.isfinite(err)):
        return np.inf
    return float(np.sqrt(np.mean(err ** 2)))


def accuracy_rows(quick: bool) -> list[BenchRow]:
    from longprofile.signal import derivative

    _, sim = _pynumdiff()
    dt, noise = 0.01, 0.1
    duration = 4 if quick else 20
    signals = {"sine": sim.sine} if quick else {"sine": sim.sine, "triangle": sim.triangle,
                                                "lorenz_x": sim.lorenz_x, "pi_cruise_control": sim.pi_cruise_control}
    ours, peers = _grids(quick)
    rows = []
    for sig_name, make in signals.items():
        x, _, truth = make(duration=duration, noise_parameters=(0, noise), dt=dt, random_seed=1)
        n = x.size
        sl = slice(n // 10, n - n // 10)
        best = {}
        for name, options in ours.items():
            errs = [(_rms(derivative(x, dt, noise_std=noise, **opt).derivative, truth, sl), opt) for opt in options
                    if opt.get("window", 0) <= n // 10]
            best[name] = min(errs, key=lambda e: e[0])
        for name, options in peers.items():
            errs = []
            for fn, opt in options:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    _, dxdt = fn(x, dt, **opt)
                errs.append((_rms(dxdt, truth, sl), opt))
            best[name] = min(errs, key=lambda e: e[0])
        for name, (err, opt) in best.items():
            settings = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in opt.items()
                                 if k != "method")
            rows.append(BenchRow(AREA, f"rms {sig_name}: {name}", err, "1/s", None, False,
                                 f"best of grid: {settings}; noise std {noise}, dt {dt}, {n} samples"))
        causal_ours = min(best[k][0] for k in best if "(causal)" in k)
        peers_all = min(best[k][0] for k in best if k.startswith("pynumdiff"))
        smooth_ours = best["kalman smoother"][0]
        rows.append(BenchRow(AREA, f"rms {sig_name}: best non-causal ours / best pynumdiff",
                             smooth_ours / peers_all, "ratio", None, False,
                             "< 1 means our RTS Kalman differentiator beats every pynumdiff method tried"))
        rows.append(BenchRow(AREA, f"rms {sig_name}: best causal ours / best pynumdiff (non-causal)",
                             causal_ours / peers_all, "ratio", None, False,
                             "causal estimators lag; all pynumdiff methods tried are non-causal"))
    return rows


def throughput_rows(quick: bool) -> list[BenchRow]:
    from scipy.signal import lfilter

    from longprofile.signal import StreamingDerivative, derivative, ml_coefficients_float

    n = 100_000 if quick else 10_000_000
    dt = 1e-3
    x = np.cumsum(np.random.default_rng(0).standard_normal(n)) * 1e-3
    derivative(x[:1000], dt, method="ml", window=45, degree=2, noise_std=1.0)  # JIT / cache load
    repeat = 3 if quick else 5
    t_ours = best_time(lambda: derivative(x, dt, method="ml", window=45, degree=2, noise_std=1.0), repeat=repeat)
    t_noise = best_time(lambda: derivative(x, dt, method="ml", window=45, degree=2, noise_std=1.0, std="noise"),
                        repeat=repeat)
    taps = ml_coefficients_float(45, 2) / dt
    t_lfilter = best_time(lambda: lfilter(taps, 1.0, x), repeat=repeat)

    def stream():
        est = StreamingDerivative(dt, window=45, degree=2)
        for block in np.array_split(x, 100):
            est.update(block)

    t_stream = best_time(stream, repeat=repeat)
    size = f"{n:.0e} samples, window 45, degree 2"
    return [
        BenchRow(AREA, "derivative(method='ml') throughput", n / t_ours / 1e6, "M samples/s",
                 None if quick else 50.0, True, f"{size}; value + derivative + derivative_std (default std='total': "
                                                "the kernel twice, the moving mean of the bias term)"),
        BenchRow(AREA, "derivative(method='ml', std='noise') throughput", n / t_noise / 1e6, "M samples/s",
                 None, True, f"{size}; value + derivative + noise-only derivative_std (the std before issue 13)"),
        BenchRow(AREA, "ml throughput / scipy lfilter (same taps)", t_lfilter / t_ours, "ratio", None, True,
                 f"{size}; lfilter computes the derivative only"),
        BenchRow(AREA, "StreamingDerivative throughput (100 blocks)", n / t_stream / 1e6, "M samples/s", None, True,
                 size),
    ]


def run(quick: bool) -> list[BenchRow]:
    return throughput_rows(quick) + accuracy_rows(quick)
