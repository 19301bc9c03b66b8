"""APL road-profile reconstruction: accuracy on synthetic ISO 8608 truth, throughput and memory (issue 3).

Accuracy rows (per ISO 8608 class B and C; 1000 m at 20 m/s and dx = 5 cm; measurement noise 2 % of the
APL signal RMS; seeds fixed): error RMS in the 1-50 m waveband as % of the true band RMS, for the raw APL
signal, the double-filtered pseudo-profile, the Kalman filter, the RTS smoother and the real-time fixed-lag
smoother (default lag, and an error-vs-lag curve for case (a)), (a) with the true
instrument model (eq. 1, Table 1) and (b) with an OE(5, 6, 0) model identified from a bench-like crenel
excitation at the same sampling rate (10 fronts, 5000 samples, noise 2 %). q and r are estimated by
maximum likelihood in both cases. Coverage: share of inner samples whose band-passed true profile lies in
the smoother's 90 % band (+/- 1.645 x the stationary band std of :func:`smoother_error_std`).

Metric: e = estimate - (truth - truth[0]); a least-squares quadratic is removed from e and from the truth
(invisible to the APL), both are multiplied by a Tukey window whose tapers cover the first and last 50 m,
band-passed by a sharp FFT mask (1/50 <= n <= 1 cycle/m) and the RMS is taken over the inner samples only
(first and last 50 m excluded: that is how the start of the record, where the filter has not converged, and
the FFT wrap-around are handled).

Speed rows: 2e7 samples (1000 km at 5 cm) through the stationary filter of the deconvolution model
(AR(1) input, detectable) -- samples/s, target >= 2e7 on one core; the full ``reconstruct_profile``
stationary smoother peak memory (tracemalloc peak of the call and ru_maxrss of a fresh subprocess),
target < 2 GB.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import time

import numpy as np
from scipy import signal

from benchmarks._common import BenchRow, best_time

AREA = "road_apl"
DX, SPEED = 0.05, 20.0
BAND = (1.0, 50.0)
EDGE = 50.0  # m excluded at each end


def _tukey_band(x, dx=DX, edge=EDGE):
    n = x.size
    s = np.linspace(-1, 1, n)
    V = np.vander(s, 3)
    x = x - V @ np.linalg.lstsq(V, x, rcond=None)[0]
    alpha = min(1.0, 2 * edge / (n * dx))
    x = x * signal.windows.tukey(n, alpha)
    X = np.fft.rfft(x)
    f = np.fft.rfftfreq(n, dx)
    X[(f < 1 / BAND[1]) | (f > 1 / BAND[0])] = 0
    return np.fft.irfft(X, n)


def _identify_bench_model(true_model, rng):
    """OE(5, 6, 0) from a bench-like crenel excitation through the true instrument, 2 % noise."""
    from longprofile.identify import fit_output_error
    from longprofile.road.apl import apl_filter, apl_model_from_polynomials

    n = 5000
    k = np.arange(n)
    u = np.where(((k + 250) // 500) % 2 == 1, 0.01, 0.0)  # 10 fronts of 10 mm
    y0 = apl_filter(true_model, u, initial="rest")
    y = y0 + rng.normal(0, 0.02 * y0.std(), n)
    est = fit_output_error(u, y, na=5, nb=6, nk=0, dt=true_model.dt)
    return apl_model_from_polynomials(est.numerator, est.denominator, dt=true_model.dt, speed=SPEED, dx=DX,
                                      name="OE(5,6,0) identified on bench crenels"), est


def _accuracy_rows(road_class, length, seed, identified, lag_curve=False):
    from longprofile.road import iso8608_profile
    from longprofile.road.apl import apl_model, apl_response, reconstruct_profile, smoother_error_std

    rng = np.random.default_rng(seed)
    true_model = apl_model(SPEED, DX)
    truth = iso8608_profile(length, DX, road_class, rng=rng).elevation[:, 0]
    truth = truth - truth[0]
    y0 = apl_response(truth, true_model)
    y = y0 + rng.normal(0, 0.02 * y0.std(), y0.size)
    n_edge = int(EDGE / DX)
    inner = slice(n_edge, truth.size - n_edge)
    tb = _tukey_band(truth)[inner]
    ref = np.sqrt(np.mean(tb ** 2))

    def pct(est):
        e = _tukey_band(est - truth)[inner]
        return float(100.0 * np.sqrt(np.mean(e ** 2)) / ref), e

    rows = []
    detail = f"ISO 8608 class {road_class}, {length:g} m, band 1-50 m, ends {EDGE:g} m excluded"
    rows.append(BenchRow(AREA, f"class {road_class}: raw APL signal band error", pct(y)[0], "%", detail=detail))
    models = [("a", true_model)]
    if identified is not None:
        models.append(("b", identified))
    for case, model in models:
        dbl = reconstruct_profile(y, model, method="double", highpass_wavelength=None)
        rows.append(BenchRow(AREA, f"class {road_class} ({case}): double filter band error", pct(dbl.raw_elevation)[0],
                             "%", detail=model.name))
        t0 = time.perf_counter()
        sm = reconstruct_profile(y, model, method="smoother", stationary=False, highpass_wavelength=None)
        t_sm = time.perf_counter() - t0
        flt = reconstruct_profile(y, model, method="filter", q=sm.q, r=sm.r, stationary=False,
                                  highpass_wavelength=None)
        rows.append(BenchRow(AREA, f"class {road_class} ({case}): Kalman filter band error", pct(flt.raw_elevation)[0],
                             "%", detail="causal E[u_k | y_0..k]"))
        err_pct, e = pct(sm.raw_elevation)
        rows.append(BenchRow(AREA, f"class {road_class} ({case}): smoother band error", err_pct, "%",
                             target=5.0 if case == "a" else 10.0, higher_is_better=False,
                             detail=f"ML q = {sm.q:.3g} m^2, r = {sm.r:.3g} m^2, {t_sm:.1f} s incl. ML"))
        sd = smoother_error_std(model, sm.q, sm.r, band=BAND, dx=DX)
        cover = float(100.0 * np.mean(np.abs(e) <= 1.645 * sd))
        rows.append(BenchRow(AREA, f"class {road_class} ({case}): smoother 90% band coverage", cover, "%",
                             target=85.0, detail="target 85-95 %; stationary band std "
                                                  f"{sd * 1e3:.3g} mm"))
        # real-time: fixed-lag smoother at the default lag (4 pendulum time constants), AR(1) 2 m road model
        t0 = time.perf_counter()
        fl = reconstruct_profile(y, model, method="fixed-lag", stationary=False, highpass_wavelength=None)
        t_fl = time.perf_counter() - t0
        rows.append(BenchRow(AREA, f"class {road_class} ({case}): fixed-lag band error", pct(fl.raw_elevation)[0],
                             "%", detail=f"latency {fl.lag_m:.4g} m = {fl.lag_m / SPEED:.2f} s, AR(1) "
                                         f"{fl.correlation_length:g} m, ML q = {fl.q:.3g}, exact gains, "
                                         f"{t_fl:.1f} s incl. ML"))
        if lag_curve and case == "a":
            for lag_m in (0.0, 5.0, 10.0, 20.0, 40.0, 60.0, 83.25, 120.0, 160.0):
                c = reconstruct_profile(y, model, method="fixed-lag", lag_m=lag_m, q=fl.q, r=fl.r, stationary=True,
                                        highpass_wavelength=None)
                rows.append(BenchRow(AREA, f"class {road_class} (a): fixed-lag band error, lag {lag_m:g} m",
                                     pct(c.raw_elevation)[0], "%",
                                     detail=f"{lag_m / SPEED:.2f} s; steady-state gains, q, r of the row above"))
    return rows


_MEMORY_SCRIPT = textwrap.dedent("""
    import json, resource, sys, time, tracemalloc
    import numpy as np
    from longprofile.road.apl import apl_filter, apl_model, reconstruct_profile
    n = int(sys.argv[1])
    traced = sys.argv[2] == "traced"   # tracemalloc's own bookkeeping inflates the RSS: measure separately
    m = apl_model(20.0, 0.05)
    rng = np.random.default_rng(0)
    y = apl_filter(m, np.cumsum(rng.normal(0, 1e-3, n)))
    y += rng.normal(0, 1e-4, n)
    reconstruct_profile(y[:300_000], m, q=1e-6, r=1e-8, method="smoother", stationary=True,
                        input_model="ar1", correlation_length=500.0)   # compile outside the measurement
    with open("/proc/self/statm") as fh:
        rss_before = int(fh.read().split()[1]) * resource.getpagesize()
    if traced:
        tracemalloc.start()
    t0 = time.perf_counter()
    rec = reconstruct_profile(y, m, q=1e-6, r=1e-8, method="smoother", stationary=True,
                              input_model="ar1", correlation_length=500.0)
    dt = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1] if traced else None
    if traced:
        tracemalloc.stop()
    # VmHWM (peak RSS of this address space), not ru_maxrss: on Linux ru_maxrss survives execve, so a child
    # of a big benchmark process would report the parent's peak
    with open("/proc/self/status") as fh:
        hwm = next(int(line.split()[1]) * 1024 for line in fh if line.startswith("VmHWM:"))
    print(json.dumps(dict(seconds=dt, traced_peak=peak, rss_before=rss_before, maxrss=hwm)))
""")


def _speed_rows(n_samples, memory):
    from longprofile.road.apl import apl_deconvolution_model, apl_filter, apl_model
    from longprofile.statespace import steady_state_filter

    m = apl_model(SPEED, DX)
    rng = np.random.default_rng(1)
    y = apl_filter(m, np.cumsum(rng.normal(0, 1e-3, n_samples))) + rng.normal(0, 1e-4, n_samples)
    model = apl_deconvolution_model(m, 1e-6, 1e-8, input_model="ar1", correlation_length=500.0)
    steady_state_filter(model, y[:1000])  # compile
    steady_state_filter(model, y[:1000], store_predictions=False)
    repeat = 2 if n_samples > 1e6 else 5
    # what reconstruct_profile(method="filter") runs on long records: filtered means only
    t = best_time(lambda: steady_state_filter(model, y, store_predictions=False), repeat=repeat)
    t_full = best_time(lambda: steady_state_filter(model, y), repeat=repeat)
    rows = [BenchRow(AREA, "stationary filter throughput (reconstruction path)", float(n_samples / t), "samples/s",
                     target=2e7, detail=f"{n_samples:.3g} samples, n = {model.n_states} states, one core; "
                                        "filtered means (store_predictions=False), as reconstruct_profile uses"),
            BenchRow(AREA, "stationary filter throughput (every per-step output)", float(n_samples / t_full),
                     "samples/s", detail="also stores predicted means, innovations and per-step log-likelihood")]
    if memory:
        res = {}
        for mode in ("traced", "rss"):
            out = subprocess.run([sys.executable, "-c", _MEMORY_SCRIPT, str(n_samples), mode], capture_output=True,
                                 text=True, check=True)
            res[mode] = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(BenchRow(AREA, "stationary smoother reconstruction peak memory (tracemalloc)",
                             res["traced"]["traced_peak"] / 2 ** 30, "GiB", target=2.0, higher_is_better=False,
                             detail=f"{n_samples:.3g} samples, reconstruct_profile incl. detrending "
                                    "(numba allocations untraced)"))
        r = res["rss"]
        rows.append(BenchRow(AREA, "stationary smoother reconstruction RSS growth",
                             (r["maxrss"] - r["rss_before"]) / 2 ** 30, "GiB", target=2.0, higher_is_better=False,
                             detail="max RSS of a fresh subprocess (no tracemalloc) minus its RSS just before the "
                                    f"call; {r['seconds']:.1f} s"))
        rows.append(BenchRow(AREA, "stationary smoother whole-process max RSS", r["maxrss"] / 2 ** 30, "GiB",
                             target=2.0, higher_is_better=False,
                             detail="subprocess incl. imports, numba code, data generation and the 160 MB input"))
    return rows


def run(quick: bool) -> list[BenchRow]:
    if quick:
        rows = _accuracy_rows("C", 200.0, 0, None)
        rows += _speed_rows(200_000, memory=False)
        return rows
    rng = np.random.default_rng(7)
    identified, _ = _identify_bench_model(__import__("longprofile.road.apl", fromlist=["apl_model"]).apl_model(SPEED, DX),
                                          rng)
    rows = []
    for cls, seed in (("B", 1), ("C", 2)):
        rows += _accuracy_rows(cls, 1000.0, seed, identified, lag_curve=True)
    rows += _speed_rows(20_000_000, memory=True)
    return rows
