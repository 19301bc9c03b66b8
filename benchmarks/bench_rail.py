"""Rail settlement (paper 004): speed of the daily posteriors, O(N) vs the dense formula, accuracy on synthetic truth.

Run: ``python -m benchmarks rail`` (full) or ``python -m benchmarks --quick rail``.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks._common import BenchRow, best_time

AREA = "rail"


def _speed_rows(quick: bool) -> list[BenchRow]:
    from longprofile.rail import measurement_std, rigidity_posterior, rigidity_posterior_dense

    rows = []
    rng = np.random.default_rng(0)
    n_sensors, n_days = (500, 30) if quick else (10_000, 365)
    x = np.cumsum(rng.uniform(2.8, 3.2, n_sensors))
    slopes = rng.normal(0, 1.5e-5, (n_days, n_sensors))
    slopes[:, [7, n_sensors // 2]] = np.nan  # two dead sensors, every day
    rigidity_posterior(x[:50], slopes[:2, :50], sigma=1.5e-5)  # compile
    measurement_std(x[:50], slopes[:2, :50], sigma=1.5e-5)  # compile

    def daily():
        rigidity_posterior(x, slopes, sigma=1.5e-5)
        measurement_std(x, slopes, sigma=1.5e-5)

    t = best_time(daily, repeat=1 if not quick else 2)
    rows.append(BenchRow(AREA, f"daily posteriors {n_sensors} sensors x {n_days} days", float(t), "s",
                         target=None if quick else 5.0, higher_is_better=False,
                         detail="rigidity_posterior (means, stds, station and lag-one covariances of every day) "
                                "+ measurement_std (the 90 % bands)"))
    N = 200 if quick else 2000
    xs, s1 = x[:N], slopes[0, :N]
    t_dense = best_time(lambda: rigidity_posterior_dense(xs, s1, sigma=1.5e-5), repeat=1 if not quick else 2)
    t_ss = best_time(lambda: rigidity_posterior(xs, s1, sigma=1.5e-5), repeat=5)
    rows.append(BenchRow(AREA, f"O(N) posterior speed-up vs dense at N = {N}", float(t_dense / t_ss), "x",
                         target=None if quick else 100.0,
                         detail=f"dense {t_dense:.3g} s, state-space {t_ss * 1e3:.3g} ms, same run"))
    return rows


def _accuracy_rows(quick: bool) -> list[BenchRow]:
    from longprofile.rail import estimate_settlement, simulate_site, validate_site

    rows = []
    seeds = (0,) if quick else (0, 1, 2, 3, 4)
    rms, cover, found, elapsed, n_read = [], [], [], [], 0
    for seed in seeds:
        syn = simulate_site("mittersheim-like", seed=seed, sampling_minutes=60 if quick else 10,
                            n_days=10 if quick else None)
        site = validate_site(syn.sensors, syn.readings, syn.survey)
        t0 = time.perf_counter()
        res = estimate_settlement(site, n_monte_carlo=0 if quick else 1000)
        elapsed.append(time.perf_counter() - t0)
        n_read = len(site.readings)
        err = res.dz - syn.truth.settlement
        rms.append(1e3 * np.sqrt(np.mean(err**2)))
        cover.append(100 * (np.abs(err) <= 1.6448536269514722 * res.dz_std)[1:, 1:-1].mean())
        found.append({s: st for s, st, _ in res.health.flagged()} == syn.truth.bad_sensors)
    rows.append(BenchRow(AREA, "mittersheim-like settlement RMS error (worst seed)", float(max(rms)), "mm",
                         target=2.0, higher_is_better=False,
                         detail=f"seeds {list(seeds)}: {', '.join(f'{v:.3f}' for v in rms)} mm; {n_read} readings, "
                                f"whole job {np.mean(elapsed):.2f} s"))
    rows.append(BenchRow(AREA, "mittersheim-like 90 % band coverage (mean over seeds)", float(np.mean(cover)), "%",
                         target=None if quick else 85.0,
                         detail=f"target 85-95 %; per seed {', '.join(f'{v:.1f}' for v in cover)} %; days after the "
                                "reference day, interior stations"))
    rows.append(BenchRow(AREA, "mittersheim-like dead + reversed sensors found", float(np.mean(found)), "fraction",
                         target=None if quick else 1.0, detail=f"seeds {list(seeds)}"))
    if quick:
        return rows
    syn = simulate_site("farebersviller-like", seed=0, sampling_minutes=30)
    site = validate_site(syn.sensors, syn.readings, syn.survey, syn.controls)
    for thermal in ("none", "linear", "lagged"):
        res = estimate_settlement(site, thermal=thermal, n_monte_carlo=0)
        c = res.controls
        rms_c = 1e3 * np.sqrt(np.mean((c.dz_control_m - c.dz_estimate_m) ** 2))
        rms_t = 1e3 * np.sqrt(np.mean((res.dz - syn.truth.settlement) ** 2))
        rows.append(BenchRow(AREA, f"farebersviller-like {thermal} thermal: RMS vs controls", float(rms_c), "mm",
                             higher_is_better=False,
                             detail=f"RMS vs truth {rms_t:.2f} mm; controls inside 90 %: "
                                    f"{100 * c.inside_90.mean():.0f} %; control noise 2 mm x sqrt 2"))
    return rows


def run(quick: bool) -> list[BenchRow]:
    """Benchmark rows of the rail area (module docstring)."""
    return _speed_rows(quick) + _accuracy_rows(quick)
