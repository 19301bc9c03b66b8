"""An identified trailer re-discretised for another sampling step (probe finding 4: a 7.5 ms bench, 5 cm surveys).

Oracle: ``scipy.signal.cont2discrete`` (zero-order hold) of one continuous trailer at both steps; the end-to-end
case identifies that trailer from a 7.5 ms bench and reconstructs a 5 cm record it made.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from longprofile.errors import ModelError
from longprofile.road.apl import apl_model_from_polynomials, resample_model

# a continuous trailer of eq. (1)'s shape: RC high-pass (tau = 0.4 pi s), pendulum high-pass (0.22 Hz),
# damper low-pass (20 Hz, damping 0.3)
_TAU, _W1, _W2 = 0.4 * np.pi, 2 * np.pi * 0.22, 2 * np.pi * 20.0
_NUM = np.polymul(np.polymul([_TAU, 0.0], [1.0, 0.0, 0.0]), [_W2**2])
_DEN = np.polymul(np.polymul([_TAU, 1.0], [1.0, _W1, _W1**2]), [1.0, 0.6 * _W2, _W2**2])


def _zoh(dt, speed=None, dx=None):
    b, a, _ = signal.cont2discrete((_NUM, _DEN), dt, method="zoh")
    return apl_model_from_polynomials(np.ravel(b), a, dt=dt, speed=speed, dx=dx)


@pytest.mark.parametrize("source,target", [(7.5e-3, 2.5e-3), (2.5e-3, 7.5e-3), (1 / 120, 0.05 / 6)])
def test_resampling_a_zoh_model_gives_the_zoh_model_at_the_other_step(source, target):
    got = resample_model(_zoh(source), target, speed=20.0, dx=20.0 * target)
    want = _zoh(target)
    f = np.linspace(0.02, 0.45 / max(source, target), 400)
    h = want.response_at(f)
    assert np.max(np.abs(got.response_at(f) - h)) < 1e-4 * np.max(np.abs(h))  # both sides: roots near 1
    assert got.delay == 1 and got.dt == target and got.dx == pytest.approx(20.0 * target)
    np.testing.assert_allclose(np.sort_complex(got.poles), np.sort_complex(want.poles), rtol=1e-7)  # roots of a clustered polynomial
    back = resample_model(got, source)
    assert np.max(np.abs(back.response_at(f) - _zoh(source).response_at(f))) < 1e-4 * np.max(np.abs(h))


def test_a_model_the_samples_do_not_resolve_is_refused():
    m = _zoh(7.5e-3)
    neg = apl_model_from_polynomials(np.convolve(m.numerator, [1.0, 0.0]), np.convolve(m.denominator, [1.0, 0.2]),
                                     dt=m.dt)  # a pole at -0.2: a sampling artefact
    with pytest.raises(ModelError, match="negative real axis.*--orders 4 4 1"):
        resample_model(neg, 2.5e-3)
    with pytest.raises(ModelError, match="beyond 0.5 of the Nyquist"):
        resample_model(_zoh(2.5e-3), 15e-3)  # the 20 Hz damper at 0.6 of the 33 Hz Nyquist of 15 ms
    delayed = apl_model_from_polynomials(np.concatenate([[0.0], m.numerator]), m.denominator, dt=m.dt)
    with pytest.raises(ModelError, match="dead time"):
        resample_model(delayed, 2.5e-3)


def test_a_bench_identified_at_7_5_ms_reconstructs_a_5_cm_record(tmp_path):
    """The trailer identified from a 7.5 ms bench (paper 000 §4.1's Te), re-discretised for a 5 cm record at 20 m/s:
    reconstruction error near that of the model identified from a 2.5 ms bench (measured: see docs/road-apl.md)."""
    import json

    import pandas as pd

    from longprofile.cli.app import main
    from longprofile.road import iso8608_profile
    from longprofile.road.apl import detrend_profile, identify_trailer, save_model

    rng = np.random.default_rng(7)
    road = iso8608_profile(400.0, 0.05, "C", rng=3)
    z = road.elevation[:, 0]
    m25 = _zoh(2.5e-3)
    y = signal.lfilter(m25.numerator, m25.denominator, z)
    y = y + rng.normal(0, 0.02 * y.std(), y.size)
    truth = detrend_profile(z - z[0], 0.05)
    rec_file = tmp_path / "rec.csv"
    pd.DataFrame({"distance_m": road.distance, "apl_m": y}).to_csv(rec_file, index=False)
    errors = {}
    for dt in (2.5e-3, 7.5e-3):
        k = np.arange(6000)
        u = np.where(((k + 300) // 600) % 2 == 1, 0.01, 0.0)  # crenels, held between samples
        m = _zoh(dt)
        out = signal.lfilter(m.numerator, m.denominator, u)
        model, _ = identify_trailer(u, out + rng.normal(0, 2e-5, u.size), speed=20.0, dx=20.0 * dt)
        path = save_model(tmp_path / f"m{dt}.json", model)
        out_file = tmp_path / f"p{dt}.csv"
        assert main(["road", "reconstruct", str(rec_file), "--model", str(path), "-o", str(out_file)]) == 0
        prof = pd.read_csv(out_file, comment="#")
        errors[dt] = float(np.sqrt(np.mean((prof["elevation_m"].to_numpy() - truth) ** 2)))
        warnings = json.loads([ln for ln in out_file.read_text().splitlines() if ln.startswith("# warnings")][0]
                              .split(": ", 1)[1])
        assert any("re-discretised" in w for w in warnings) == (dt != 2.5e-3)
    assert errors[7.5e-3] < 1.02 * errors[2.5e-3], errors  # measured 1.4225 vs 1.4224 mm
