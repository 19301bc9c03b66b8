"""Rail settlement (paper 004): speed of the daily posteriors, O(N) vs the dense formula, the temperature fill's
throughput, accuracy on synthetic truth.

Run: ``python -m benchmarks rail`` (full) or ``python -m benchmarks --quick rail``.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks._common import BenchRow, best_time

AREA = "rail"
Z90 = 1.6448536269514722


def _speed_rows(quick: bool) -> list[BenchRow]:
    from longprofile.rail import measurement_std, rigidity_posterior, rigidity_posterior_dense

    rows = []
    rng = np.random.default_rng(0)
    n_sensors, n_days = (500, 30) if quick else (10_000, 365)
    x = np.cumsum(rng.uniform(2.8, 3.2, n_sensors))
    slopes = rng.normal(0, 1.5e-5, (n_days, n_sensors))
    slopes[:, [7, n_sensors // 2]] = np.nan  # two dead sensors, every day
    kw3 = dict(sigma=1.5e-5, rigidity=1e-12, penalty_order=3)
    for order, kw in ((2, dict(sigma=1.5e-5)), (3, kw3)):  # compile
        rigidity_posterior(x[:50], slopes[:2, :50], **kw)
        measurement_std(x[:50], slopes[:2, :50], **kw)

    def daily(kw):
        rigidity_posterior(x, slopes, **kw)
        measurement_std(x, slopes, **kw)

    t3 = best_time(lambda: daily(kw3), repeat=1 if not quick else 2)
    t2 = best_time(lambda: daily(dict(sigma=1.5e-5)), repeat=1 if not quick else 2)
    rows.append(BenchRow(AREA, f"daily posteriors {n_sensors} sensors x {n_days} days", float(t3), "s",
                         target=None if quick else 5.0, higher_is_better=False,
                         detail="default settlement prior (penalty order 3): rigidity_posterior (means, stds = the "
                                "90 % bands, station and lag-one covariances of every day) + measurement_std (the "
                                f"noise-only column); the paper's order-2 prior: {t2:.3g} s"))
    N = 200 if quick else 2000
    xs, s1 = x[:N], slopes[0, :N]
    t_dense = best_time(lambda: rigidity_posterior_dense(xs, s1, sigma=1.5e-5), repeat=1 if not quick else 2)
    t_ss = best_time(lambda: rigidity_posterior(xs, s1, sigma=1.5e-5), repeat=5)
    rows.append(BenchRow(AREA, f"O(N) posterior speed-up vs dense at N = {N}", float(t_dense / t_ss), "x",
                         target=None if quick else 100.0,
                         detail=f"the paper's model (order 2): dense {t_dense:.3g} s, state-space {t_ss * 1e3:.3g} ms, "
                                "same run"))
    return rows


def _fill_row(quick: bool) -> BenchRow:
    """Throughput of ``fill_temperature`` (docs/rail.md, "A failed temperature channel") on the README preset read
    every 10 minutes with 8 of its 58 temperature channels empty (all the record, and from half-way: the sensors' own
    offsets), against ``validate_site`` (without the fill) on the same readings in the same run."""
    import pandas as pd

    from longprofile.rail import fill_temperature, simulate_site, validate_site

    syn = simulate_site("mittersheim-like", seed=0, n_days=10 if quick else 365, sampling_minutes=10)
    r = syn.readings.copy()
    r.loc[r["sensor_id"].isin(list(syn.sensors["sensor_id"])[10:18]), "temperature_c"] = np.nan
    r["timestamp"] = pd.to_datetime(r["timestamp"])
    n_lost = int(r["temperature_c"].isna().sum())
    t_fill = best_time(lambda: fill_temperature(r, syn.sensors), repeat=2 if quick else 1)
    t_val = best_time(lambda: validate_site(syn.sensors, r, syn.survey, temperature_fill=False),
                      repeat=2 if quick else 1)
    intact = r.assign(temperature_c=syn.readings["temperature_c"].to_numpy())
    t_none = best_time(lambda: fill_temperature(intact, syn.sensors), repeat=2 if quick else 1)
    half = r["timestamp"] < r["timestamp"].min() + (r["timestamp"].max() - r["timestamp"].min()) / 2
    mid = r.assign(temperature_c=r["temperature_c"].where(~half, intact["temperature_c"]))  # failed half-way
    t_mid = best_time(lambda: fill_temperature(mid, syn.sensors), repeat=2 if quick else 1)
    return BenchRow(AREA, f"temperature fill: {n_lost} of {len(r)} readings without a temperature", n_lost / t_fill,
                    "readings/s", detail=f"fill_temperature {t_fill:.3g} s, validate_site without the fill {t_val:.3g} s "
                                         f"on the same readings: the fill costs {t_fill / t_val:.2f} x the validation; "
                                         f"with every temperature there (the stuck test only) {t_none:.3g} s; "
                                         f"the 8 channels failed half-way (their offsets too) {t_mid:.3g} s")


def _accuracy_rows(quick: bool) -> list[BenchRow]:
    from longprofile.rail import estimate_settlement, simulate_site, validate_site

    rows = []
    seeds = (0,) if quick else (0, 1, 2, 3, 4)
    rms, cover, cover_sm, cover_paper, std_paper, found, elapsed, orders, n_read = [], [], [], [], [], [], [], [], 0
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
        cover.append(100 * (np.abs(err) <= Z90 * res.dz_std)[1:, 1:-1].mean())
        sm_err = res.smoothed.mean - syn.truth.settlement
        cover_sm.append(100 * (np.abs(sm_err) <= Z90 * res.smoothed.std)[1:, 1:-1].mean())
        orders.append(res.penalty_order)
        found.append({s: st for s, st, _ in res.health.flagged()} == syn.truth.bad_sensors)
        if not quick:  # the paper's fixed r = 1e-8 and cubic prior, for comparison
            paper = estimate_settlement(site, rigidity=1e-8, n_monte_carlo=0, through_time=False)
            cover_paper.append(100 * (np.abs(paper.dz - syn.truth.settlement) <= Z90 * paper.dz_std)[1:, 1:-1].mean())
            std_paper.append(1e3 * np.median(paper.dz_std[1:, 1:-1]))
    rows.append(BenchRow(AREA, "mittersheim-like settlement RMS error (worst seed)", float(max(rms)), "mm",
                         target=2.0, higher_is_better=False,
                         detail=f"seeds {list(seeds)}: {', '.join(f'{v:.3f}' for v in rms)} mm; {n_read} readings, "
                                f"whole job {np.mean(elapsed):.2f} s"))
    rows.append(BenchRow(AREA, "mittersheim-like 90 % posterior band coverage (mean over seeds)", float(np.mean(cover)),
                         "%", target=None if quick else 85.0,
                         detail=f"target 85-95 %; per seed {', '.join(f'{v:.1f}' for v in cover)} %; ML prior order "
                                f"{orders}; through-time bands {', '.join(f'{v:.1f}' for v in cover_sm)} %; days after "
                                "the reference day, interior stations"))
    if not quick:
        rows.append(BenchRow(AREA, "mittersheim-like coverage with the paper's r = 1e-8 (mean over seeds)",
                             float(np.mean(cover_paper)), "%",
                             detail=f"per seed {', '.join(f'{v:.1f}' for v in cover_paper)} %; median posterior std "
                                    f"{np.median(std_paper):.2f} mm (over-wide: the reason r is fitted)"))
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
                                    f"{100 * c.inside_90.mean():.0f} %; control noise 2 mm x sqrt 2; prior order "
                                    f"{res.penalty_order}"))
    return rows


def run(quick: bool) -> list[BenchRow]:
    """Benchmark rows of the rail area (module docstring)."""
    return _speed_rows(quick) + [_fill_row(quick)] + _accuracy_rows(quick)
