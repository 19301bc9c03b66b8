"""The error of a towing speed off the APL model's (docs/road-apl.md, "Towing speed ... constant towing speed").

``OPENBLAS_NUM_THREADS=1 python -m benchmarks.road_speed_tolerance mismatch 20 0,0.01,-0.01``: a record towed at
V (1 + e) — the Table 1 trailer re-discretised at that speed (``trailer_at_speed``) — reconstructed with the model of
V; RMS error and coverage of the printed 90 % band, two road seeds.

``... vary 0,0.02,0.05``: the speed 20 (1 + a sin(2 pi t / 30 s)); the 20 m/s, 5 cm model run as a time-domain
system at dt = 2.5 ms on the road at x(t) (the user probe's simulator), the signal taken at every 5 cm of distance,
reconstructed with the 20 m/s model; error and coverage split by the local speed deviation.

Not a ``bench_`` module: ``python -m benchmarks`` does not run it (minutes per line).
"""

from __future__ import annotations

import sys

import numpy as np

from longprofile.core import Profile
from longprofile.road import iso8608_profile
from longprofile.road.apl import (
    apl_filter,
    apl_model,
    apl_response,
    check_speed_samples,
    detrend_profile,
    reconstruct_profile,
    trailer_at_speed,
)

DX, LENGTH, MARGIN = 0.05, 2000.0, 100.0


def _errors(x, y, truth_x, truth_z, model):
    """(error, printed std, inner mask) of the default reconstruction of ``y`` against the detrended truth."""
    rec = reconstruct_profile(Profile(x, y), model)
    tz = np.interp(x, truth_x, truth_z)
    td = np.asarray(detrend_profile(tz - tz[0], DX)).ravel()
    inner = (x > MARGIN) & (x < x[-1] - MARGIN)
    return rec.profile.elevation[:, 0] - td, rec.profile.std[:, 0], inner


def mismatch(speed: float, e: float, seed: int):
    road = iso8608_profile(LENGTH, DX, "C", rng=seed)
    towed = apl_model(speed, DX) if e == 0 else trailer_at_speed(speed * (1 + e), DX, table_speed=speed)
    y = apl_response(road, towed).elevation[:, 0]
    y = y + np.random.default_rng(seed + 100).normal(0, 0.02 * np.std(y), y.size)
    err, std, inner = _errors(road.distance, y, road.distance, road.elevation[:, 0], apl_model(speed, DX))
    return 1e3 * np.sqrt(np.mean(err[inner] ** 2)), 100 * np.mean(np.abs(err[inner]) <= 1.645 * std[inner])


def vary(amplitude: float, seed: int = 1, period: float = 30.0) -> str:
    road = iso8608_profile(LENGTH + 50, 0.01, "C", rng=seed)
    model, dt = apl_model(20.0, DX), DX / 20.0
    t = np.arange(int(1.3 * LENGTH / (17 * dt))) * dt
    v = 20.0 * (1 + amplitude * np.sin(2 * np.pi * t / period))
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    keep = x < LENGTH
    x, v = x[keep], v[keep]
    y = np.asarray(apl_filter(model, np.interp(x, road.distance, road.elevation[:, 0])))
    y = y + np.random.default_rng(seed + 7).normal(0, 0.02 * np.std(y), y.size)
    grid = np.arange(0, x[-1], DX)
    vg = np.interp(grid, x, v)
    err, std, inner = _errors(grid, np.interp(grid, x, y), road.distance, road.elevation[:, 0], model)
    dev = np.abs(vg / 20 - 1)
    ok = check_speed_samples(grid, vg, 20.0).ok
    cells = [f"all: rms {1e3 * np.sqrt(np.mean(err[inner] ** 2)):.2f} mm cov "
             f"{100 * np.mean(np.abs(err[inner]) <= 1.645 * std[inner]):.1f} %; not flagged {100 * np.mean(ok[inner]):.1f} %"]
    for lo, hi in [(0, .0025), (.0025, .005), (.005, .01), (.01, .02), (.02, .05), (.05, .1), (.1, .2), (.2, 1)]:
        b = inner & (dev >= lo) & (dev < hi)
        if b.sum() > 200:
            cells.append(f"[{100 * lo:g}-{100 * hi:g} %: rms {1e3 * np.sqrt(np.mean(err[b] ** 2)):.2f} mm cov "
                         f"{100 * np.mean(np.abs(err[b]) <= 1.645 * std[b]):.0f} %]")
    return " ".join(cells)


def main(argv) -> int:
    if argv[:1] == ["mismatch"]:
        speed = float(argv[1])
        for e in (float(a) for a in argv[2].split(",")):
            res = [mismatch(speed, e, s) for s in (1, 2)]
            print(f"V={speed:g} e={100 * e:+g} %: rms " + " / ".join(f"{r[0]:.3f}" for r in res) + " mm, coverage "
                  + " / ".join(f"{r[1]:.1f}" for r in res) + " %", flush=True)
        return 0
    if argv[:1] == ["vary"]:
        for a in (float(a) for a in argv[1].split(",")):
            print(f"amplitude {100 * a:g} %: {vary(a)}", flush=True)
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
