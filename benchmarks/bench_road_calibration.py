"""APL reconstruction calibration on independent cases (issue 13): coverage of every printed std.

``road reconstruct`` prints two standard deviations per sample: ``std_m`` for the detrended elevation a user gets
(``elevation_m``) and ``raw_std_m`` for the undetrended estimate (``raw_m``). Here each is checked against the truth
on recordings with effects the reconstruction's model does not have, drawn at random per family:

* ``own model``        -- ISO 8608 class C, the nominal trailer, 2 % white noise (the model's best case);
* ``road classes``     -- ISO classes A..E, random seeds;
* ``short waves``      -- class C with the n^-2 law continued from ISO's 2.83 cycles/m up to the 10 cycles/m the
  5 cm sampling carries (megatexture-scale waves, which ISO 8608's generator range leaves out and the models
  assume);
* ``noise levels``     -- white measurement noise of 0.5-10 % of the signal RMS;
* ``short waves, noisy`` -- the ``short waves`` road with 5-10 % white noise: the trailer then resolves the road only
  to about 2.1-2.4 cycles/m, as on the noisiest ``noise levels`` draws, and the record cannot tell this road from
  those (docs/road-apl.md, "The noise-levels cell and the short-wave continuation", 2026-12-06);
* ``coloured noise``   -- AR(1) measurement noise (correlation 0.5-5 m), 2-5 %; the model has white noise;
* ``trailer mismatch`` -- the recording made by a trailer whose pendulum and damper frequencies are 0.8-1.2 x and
  gain 0.95-1.05 x the model's (speed, wear, calibration); scored twice on the same draws: without and with the
  instrument-uncertainty term (``reconstruct_profile(instrument_uncertainty=...)``) at the tolerance a user would
  declare for such a trailer, +-20 % on each frequency and +-5 % on the gain read as uniform: 1-sigma
  20 % / sqrt(3) = 11.5 % and 5 % / sqrt(3) = 2.9 % (the declared tolerance, the same for every draw, not each
  draw's truth);
* ``signal drift``     -- a slow random-walk drift of the sensor added to the signal;
* ``low speed``        -- ISO classes A..E towed at 6 m/s (Table 1's other calibrated speed; the other families run at
  20 m/s), the nominal 6 m/s trailer, 2 % noise: the fixed-lag at its default lag there;
* ``gaps``             -- the own-model recording with 1-3 dropouts (NaN) of 1-20 m each at random places; besides
  the whole record, ``std_m`` is scored on the samples inside the gaps alone (the Kalman methods bridge them);
* ``measured road``    -- the Sroubek-Sorel measured profile (../shared/reference-data, 0.25 m resampled to
  0.05 m, 543 m) with random noise (skipped when the reference data are absent).

Per draw: 2 km at 5 cm, 20 m/s (but ``low speed``), ``reconstruct_profile`` with its defaults for ``smoother`` and ``fixed-lag``
(the ``road reconstruct`` call); the first and last 100 m are left out. Coverage = share of samples whose truth is
inside estimate +- 1.645 std (target 85-95 %); z = error / std, its RMS (target ~1); PIT = Phi(z), the share of
samples in each tenth (10 % each when calibrated: a U shape says too narrow, a hump too wide, a slope biased).
The truth of ``elevation_m``
is the true profile through the same detrending (``detrend_profile``); the truth of ``raw_m`` is the true
profile itself (its offset and longest waves are unobservable: a calibrated ``raw_std_m`` must say so).

Run: ``python -m benchmarks road_calibration`` (full: 32 draws per family; 8 until 2026-12-06 session 27) or ``--quick`` (one 600 m draw of two
families, the trailer mismatch with and without the declared tolerance).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks._common import BenchRow, CoverageScore

AREA = "road_calibration"
#: The trailer-mismatch tolerance as the user declares it (uniform +-20 % frequencies, +-5 % gain -> 1-sigma).
DECLARED_TOLERANCE = dict(frequency=0.20 / np.sqrt(3), gain=0.05 / np.sqrt(3))
#: Scored families: (row label, recording family, declared instrument uncertainty or None).
FAMILIES = [(f, f, None) for f in ("own model", "road classes", "short waves", "noise levels", "short waves, noisy",
                                   "coloured noise", "trailer mismatch")] + [
    ("trailer mismatch, declared tolerance", "trailer mismatch", DECLARED_TOLERANCE),
    ("signal drift", "signal drift", None), ("low speed", "low speed", None), ("gaps", "gaps", None),
    ("measured road", "measured road", None)]
LOW_SPEED = 6.0
LENGTH, DX, SPEED, EDGE = 2000.0, 0.05, 20.0, 100.0
CLASSES = ("A", "B", "C", "D", "E")
SOREL = Path(__file__).resolve().parents[1] / ".." / "shared" / "reference-data" / "sorel-iri-profile" / "profile_1.txt"


def _ar1(rng, n, corr_m, std):
    """Stationary AR(1) noise of correlation length ``corr_m`` and std ``std`` (scipy's lfilter, started in steady
    state)."""
    from scipy.signal import lfilter

    phi = np.exp(-DX / corr_m)
    e = rng.normal(0.0, std * np.sqrt(1 - phi ** 2), n)
    return lfilter([1.0], [1.0, -phi], e, zi=[phi * rng.normal(0.0, std)])[0]


def _truth(family, rng, n):
    from longprofile.road import iso8608_profile

    if family == "measured road":
        data = np.loadtxt(SOREL)
        x = np.arange(data[0, 0], data[-1, 0], DX)
        z = np.interp(x, data[:, 0], data[:, 1])
        return z - z[0]
    cls = rng.choice(CLASSES) if family in ("road classes", "low speed") else "C"
    band = (0.011, 0.5 / DX) if family.startswith("short waves") else None
    return iso8608_profile(n * DX - DX / 2, DX, cls, rng=rng, band=band).elevation.reshape(-1)[:n]


def _recording(family, rng, nominal, length=LENGTH):
    """(true profile, APL signal) of one draw."""
    from longprofile.road.apl import TrailerPoles, apl_model, apl_response

    n = int(round(length / DX))
    u = _truth(family, rng, n)
    instrument = nominal
    gain = 1.0
    if family == "trailer mismatch":
        from longprofile.road.apl import TABLE1_CONFIGURATIONS

        p = TABLE1_CONFIGURATIONS[(SPEED, DX)]
        instrument = apl_model(SPEED, DX, poles=TrailerPoles(p.pendulum_modulus,
                                                             p.pendulum_frequency * rng.uniform(0.8, 1.2),
                                                             p.damper_modulus,
                                                             p.damper_frequency * rng.uniform(0.8, 1.2)))
        gain = rng.uniform(0.95, 1.05)
    y0 = gain * apl_response(u, instrument)
    rms = float(np.sqrt(np.mean(y0 ** 2)))
    frac = {"noise levels": (0.005, 0.10), "short waves, noisy": (0.05, 0.10)}.get(family)
    frac = 0.02 if frac is None else rng.uniform(*frac)
    if family == "coloured noise":
        noise = _ar1(rng, u.size, rng.uniform(0.5, 5.0), rng.uniform(0.02, 0.05) * rms)
    else:
        noise = rng.normal(0.0, frac * rms, u.size)
    if family == "signal drift":
        noise = noise + np.cumsum(rng.normal(0.0, 0.002 * rms, u.size))  # ~0.4 x RMS over the record
    y = y0 + noise
    if family == "gaps":
        edge = int(EDGE / DX)
        for _ in range(int(rng.integers(1, 4))):
            width = int(rng.uniform(1.0, 20.0) / DX)
            start = int(rng.integers(edge, u.size - edge - width))
            y[start:start + width] = np.nan
    return u, y


def calibrate(family: str, draws: int, seed: int = 0, length: float = LENGTH,
              instrument_uncertainty: dict | None = None) -> dict:
    """Scores per printed std: {"smoother std_m": CoverageScore, ...} for one family (the draws depend on the family
    and the seed only; ``instrument_uncertainty``: the InstrumentUncertainty fields passed to the reconstruction)."""
    from longprofile.road.apl import InstrumentUncertainty, apl_model, detrend_profile, reconstruct_profile

    unc = None if instrument_uncertainty is None else InstrumentUncertainty(**instrument_uncertainty)

    nominal = apl_model(LOW_SPEED if family == "low speed" else SPEED, DX)
    rng = np.random.default_rng([seed, sum(map(ord, family))])
    keys = ["smoother std_m", "smoother raw_std_m", "fixed-lag std_m", "fixed-lag raw_std_m"]
    if family == "gaps":
        keys += ["smoother std_m in gaps", "fixed-lag std_m in gaps"]
    scores = {k: CoverageScore() for k in keys}
    rms = {"smoother": [], "fixed-lag": []}
    for _ in range(draws):
        u, y = _recording(family, rng, nominal, length)
        keep = slice(int(EDGE / DX), u.size - int(EDGE / DX))
        u_det = detrend_profile(u, DX)
        for method in ("smoother", "fixed-lag"):
            rec = reconstruct_profile(y, nominal, method=method, instrument_uncertainty=unc)
            err = rec.profile.elevation.reshape(-1) - u_det
            rms[method].append(float(np.sqrt(np.mean(err[keep] ** 2))))
            if rec.profile.std is not None:
                std = np.asarray(rec.profile.std).reshape(-1)
                scores[f"{method} std_m"].add(err[keep], std[keep])
                gaps = np.isnan(y)
                if gaps.any():
                    scores[f"{method} std_m in gaps"].add(err[gaps], std[gaps])
            if rec.raw_std is not None:
                scores[f"{method} raw_std_m"].add((rec.raw_elevation - u)[keep], rec.raw_std[keep])
    return {"scores": scores, "rms_mm": {m: 1e3 * np.median(v) for m, v in rms.items()}}


def run(quick: bool) -> list[BenchRow]:
    families = FAMILIES
    length = LENGTH
    if quick:  # a smoke run: three rows, one short draw each
        families, length = [f for f in FAMILIES if f[1] in ("own model", "trailer mismatch")], 600.0
    if not SOREL.exists():
        families = [f for f in families if f[1] != "measured road"]
    draws = 1 if quick else 32
    rows = []
    for family, recording, uncertainty in families:
        t0 = time.perf_counter()
        out = calibrate(recording, draws, length=length, instrument_uncertainty=uncertainty)
        dt = time.perf_counter() - t0
        for key, sc in out["scores"].items():
            if sc.n == 0:
                rows.append(BenchRow(AREA, f"{family}: {key} 90 % coverage", float("nan"), "%",
                                     detail="not printed (NaN column): no interval to check"))
                continue
            rows.append(BenchRow(AREA, f"{family}: {key} 90 % coverage", 100 * sc.coverage, "%",
                                 target=None if quick else 85.0, target_max=None if quick else 95.0,
                                 detail=sc.detail()))
        rows.append(BenchRow(AREA, f"{family}: detrended elevation RMS error, smoother / fixed-lag",
                             out["rms_mm"]["smoother"], "mm", higher_is_better=False,
                             detail=f"fixed-lag {out['rms_mm']['fixed-lag']:.3f} mm (median over draws); "
                                    f"{draws} draw(s) of {length / 1000:g} km, {dt:.0f} s"))
    return rows
