"""Profile comparison (Karamihas cross-correlation, AASHTO R 56 practice).

Oracles: (1) a profile against a copy of itself shifted by a known number of samples -- the offset found must
be the injected one to within one sample; (2) a real measured profile (michalsorel/iri profile_1, see
/work/shared/reference-data/sorel-iri-profile/SOURCE.md) against itself plus white noise at an instrument's
level (0.1 mm RMS, an assumption about "instrument level") must give >= 0.99; (3) the normalised correlation
at each lag against numpy.corrcoef-free direct sums over the overlap (independent brute force).
"""


import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError
from longprofile.road import Profile, iso8608_profile
from longprofile.road.smoothness._compare import (
    _full_correlation,
    _xcorr,
    certify_profiler,
    compare_profiles,
    filter_for_comparison,
    resample_profile,
)
from tests._reference_data import reference_file


@pytest.fixture(scope="module")
def long_profile():
    return iso8608_profile(700.0, 0.05, "B", rng=7)


@settings(max_examples=20, deadline=None)
@given(shift=st.integers(-80, 80))
def test_injected_offset_found_within_one_sample(long_profile, shift):
    x, z = long_profile.distance, long_profile.elevation[:, 0]
    dx, n, base = 0.05, 8000, 100
    ref = Profile(distance=x[:n], elevation=z[base:base + n])
    rng = np.random.default_rng(abs(shift))
    run = Profile(distance=x[:n], elevation=z[base + shift:base + shift + n] + rng.normal(0, 5e-5, n))
    c = compare_profiles(ref, run, max_offset=5.0)
    assert abs(c.offset - shift * dx) <= dx + 1e-9
    assert c.correlation > 0.99


def test_offset_with_different_start_stations(long_profile):
    # the same road recorded from station 1000.0 by one run and 1002.0 by the other: stations agree, offset 0
    x, z = long_profile.distance, long_profile.elevation[:, 0]
    ref = Profile(distance=1000.0 + x[:6000], elevation=z[:6000])
    run = Profile(distance=1002.0 + x[:6000], elevation=z[40:6040])
    assert compare_profiles(ref, run).offset == pytest.approx(0.0, abs=1e-9)
    # a DMI error: the run labels the same place 1.5 m further on
    run = Profile(distance=1003.5 + x[:6000], elevation=z[40:6040])
    assert compare_profiles(ref, run).offset == pytest.approx(-1.5, abs=0.05)


def test_measured_profile_with_instrument_noise():
    data = np.loadtxt(reference_file("sorel-iri-profile", "profile_1.txt"))
    ref = Profile(distance=data[:, 0], elevation=data[:, 1], name="profile_1")
    rng = np.random.default_rng(0)
    runs = [Profile(distance=data[:, 0], elevation=data[:, 1] + rng.normal(0, 1e-4, len(data)), name=f"r{i}")
            for i in range(3)]
    for r in runs:
        c = compare_profiles(ref, r)
        assert c.correlation >= 0.99 and c.offset == 0.0
    cert = certify_profiler(ref, runs)
    assert cert.passed and cert.repeatability["left"] >= 0.99 and cert.accuracy["left"] >= 0.99
    assert len(cert.pairs) == 3 and len(cert.runs) == 3


def test_xcorr_matches_brute_force():
    rng = np.random.default_rng(2)
    p, q = rng.normal(size=300), rng.normal(size=280)
    lags, rho, ratio, n = _xcorr(p, q, -20, 25, 10)
    for l, r, m in zip(lags, rho, n):
        i = np.arange(max(0, -l), min(p.size, q.size - l))
        a, b = p[i], q[i + l]
        assert m == i.size
        assert r == pytest.approx(a @ b / np.sqrt((a @ a) * (b @ b)), rel=1e-10)


def test_unrelated_profiles_fail_certification():
    a = iso8608_profile(300.0, 0.05, "C", rng=1)
    b = iso8608_profile(300.0, 0.05, "C", rng=2)
    cert = certify_profiler(a, [a, b])
    assert not cert.passed
    assert cert.accuracy["left"] < 0.9


def test_different_intervals_refused_or_resampled_explicitly():
    x1, x2 = np.arange(0, 200, 0.05), np.arange(0, 200, 0.1)
    f = lambda x: 1e-3 * np.sin(2 * np.pi * x / 7.0) + 5e-4 * np.sin(2 * np.pi * x / 2.3)  # noqa: E731
    a, b = Profile(distance=x1, elevation=f(x1)), Profile(distance=x2, elevation=f(x2))
    with pytest.raises(InputError, match="different sample intervals"):
        compare_profiles(a, b)
    c = compare_profiles(a, b, spacing=0.1)
    assert c.correlation > 0.99
    assert resample_profile(a, 0.1).spacing == pytest.approx(0.1)


def test_bandpass_filter_and_bad_input():
    x = np.arange(0, 200, 0.05)
    a = Profile(distance=x, elevation=1e-3 * np.sin(2 * np.pi * x / 5.0))
    y = filter_for_comparison(a, "left", filter="bandpass", band=(1.0, 20.0))
    assert np.std(y[1000:-1000]) == pytest.approx(np.std(a.elevation[1000:-1000, 0]), rel=0.05)
    with pytest.raises(InputError, match="band"):
        filter_for_comparison(a, "left", filter="bandpass")
    with pytest.raises(InputError, match="unknown filter"):
        filter_for_comparison(a, "left", filter="xyz")
    with pytest.raises(InputError, match="unknown threshold key 'repeat'"):
        certify_profiler(a, [a], thresholds={"repeat": 0.9})
    irregular = Profile(distance=np.cumsum(np.random.default_rng(0).uniform(0.04, 0.06, 4000)),
                        elevation=np.zeros(4000))
    with pytest.raises(InputError, match="irregular"):
        compare_profiles(a, irregular)


def _cli():
    import typer

    from longprofile.cli._road_compare import register

    app = typer.Typer()
    register(app)

    @app.command("noop")
    def _noop():  # a second command keeps typer from collapsing the group
        pass

    return app


def test_cli_compare_erd_runs(tmp_path, long_profile):
    from typer.testing import CliRunner

    from longprofile.io import write_profile

    x, z = long_profile.distance, long_profile.elevation[:, 0]
    rng = np.random.default_rng(5)
    ref = write_profile(Profile(distance=x[:6000], elevation=z[100:6100], tracks=("left",)), tmp_path / "ref.erd")
    runs = []
    for i, shift in enumerate([0, 12, -7]):
        p = Profile(distance=x[:6000], elevation=z[100 + shift:6100 + shift] + rng.normal(0, 5e-5, 6000),
                    tracks=("left",))
        runs.append(str(write_profile(p, tmp_path / f"run{i + 1}.erd")))
    out = tmp_path / "compare"
    res = CliRunner().invoke(_cli(), ["compare", str(ref), *runs, "-o", str(out), "--plot"])
    assert res.exit_code == 0, res.output
    import pandas as pd

    table = pd.read_csv(out / "runs.csv")
    assert np.allclose(table.offset_m, [0.0, 0.6, -0.35], atol=0.05 + 1e-9)
    assert (table.accuracy_correlation > 0.99).all()
    assert (out / "correlation.png").stat().st_size > 1000
    assert "PASS" in res.output
    bad = CliRunner().invoke(_cli(), ["compare", str(ref), runs[0], "-o", str(out), "--filter", "bandpass",
                                      "--overwrite"])
    assert isinstance(bad.exception, InputError) and "band" in str(bad.exception)


@settings(max_examples=40, deadline=None)
@given(n_q=st.integers(1, 3000), n_p=st.integers(1, 3000), seed=st.integers(0, 2**16))
def test_full_correlation_equals_scipy_signal_correlate(n_q, n_p, seed):
    """The FFT cross-correlation of the alignment (scipy.fft) against the oracle scipy.signal.correlate."""
    from scipy.signal import correlate

    rng = np.random.default_rng(seed)
    q, p = rng.normal(size=n_q), rng.normal(size=n_p)
    want = correlate(q, p, mode="full", method="direct")
    np.testing.assert_allclose(_full_correlation(q, p), want, atol=1e-9 * max(1.0, np.abs(want).max()))


def test_a_run_without_the_reference_track_is_named_with_the_fix():
    x = np.arange(4000) * 0.05
    z = 1e-3 * np.sin(2 * np.pi * x / 9.0)
    ref = Profile(distance=x, elevation=z, tracks=("left",), name="ref")
    good = Profile(distance=x, elevation=z, tracks=("left",), name="run1")
    other = Profile(distance=x, elevation=z, tracks=("Elevation",), name="run2")
    with pytest.raises(InputError, match=r"run2 has \['Elevation'\].*--rename Elevation=left"):
        certify_profiler(ref, [good, other])


@pytest.mark.parametrize(("keep", "passed"), [(0.2, False), (0.85, False), (0.95, True)])
def test_a_run_must_cover_the_reference_to_certify(long_profile, keep, passed):
    """A 2 km run passed against a 10 km reference (accuracy 1.000 over the 2 km it covers; session 35, a probe)."""
    from longprofile.road import certify_profiler
    from longprofile.road.smoothness import MIN_REFERENCE_COVERAGE

    x = long_profile.distance
    cut = x <= x[0] + keep * (x[-1] - x[0])
    run = Profile(x[cut], long_profile.elevation[cut], tracks=long_profile.tracks)
    noise = 1e-4 * np.random.default_rng(0).standard_normal(long_profile.elevation[cut].shape)
    again = Profile(x[cut], long_profile.elevation[cut] + noise, tracks=long_profile.tracks)  # a second run
    res = certify_profiler(long_profile, [run, again])
    assert res.runs["coverage"].iloc[0] == pytest.approx(keep, abs=0.02)
    assert res.accuracy[long_profile.tracks[0]] > 0.99  # the part it covers agrees
    assert res.passed is passed and (keep >= MIN_REFERENCE_COVERAGE) is passed


def _runs(long_profile, gains, n=6000, noise=5e-5, shift=0):
    """Runs of the same road: the reference times each gain, plus instrument noise (separate draws)."""
    x, z = long_profile.distance, long_profile.elevation[:, 0]
    ref = Profile(distance=x[:n], elevation=z[100:100 + n], tracks=("left",), name="ref")
    rng = np.random.default_rng(11)
    return ref, [Profile(distance=x[:n], elevation=g * (z[100 + shift:100 + shift + n] + rng.normal(0, noise, n)),
                         tracks=("left",), name=f"run{i + 1}") for i, g in enumerate(gains)]


@settings(max_examples=15, deadline=None)
@given(gain=st.floats(0.001, 4.0))
def test_the_rating_penalises_an_amplitude_error_as_the_rms_ratio(long_profile, gain):
    """Oracle: the rating of ``gain x reference`` is ``rho x min(a, 1/a)`` with rho and the RMS ratio a of the
    filtered profiles summed directly (session 36: a run at half the reference's amplitude, or a thousandth of it,
    metres under a mm label, was certified with rho 0.9998)."""
    ref, (run,) = _runs(long_profile, [gain], noise=0.0)
    c = compare_profiles(ref, run, max_offset=0.0)
    p, q = filter_for_comparison(ref, "left"), filter_for_comparison(run, "left")
    rho = np.sum(p * q) / np.sqrt(np.sum(p * p) * np.sum(q * q))
    a = np.sqrt(np.sum(q * q) / np.sum(p * p))
    assert c.rating == pytest.approx(rho * min(a, 1 / a), rel=1e-9)
    assert c.rating == pytest.approx(min(gain, 1 / gain), rel=1e-6)
    assert c.correlation == pytest.approx(1.0, abs=1e-9)  # the shape alone agrees


@pytest.mark.parametrize(("gains", "passed"), [((1.0, 1.0, 1.0), True), ((1.03, 0.98, 1.0), True),
                                               ((0.5, 0.5, 0.5), False), ((1e-3, 1e-3, 1e-3), False)])
def test_certification_judges_amplitude(long_profile, gains, passed):
    ref, runs = _runs(long_profile, gains)
    res = certify_profiler(ref, runs)
    assert res.passed is passed
    assert np.allclose(res.runs["shape_correlation"], 1.0, atol=0.01)  # shape agrees in every case
    assert np.allclose(res.runs["accuracy_correlation"], [min(g, 1 / g) for g in gains], atol=0.01)


def test_an_alignment_beyond_the_search_is_named_with_the_fix(long_profile):
    ref, runs = _runs(long_profile, [1.0, 1.0], shift=140)  # 7 m further on than the stations say
    res = certify_profiler(ref, runs)
    assert not res.passed and any("+7.00 m, outside the +-5 m search" in w and "max_offset" in w
                                  for w in res.warnings)
    wide = certify_profiler(ref, runs, max_offset=10.0)
    assert wide.passed and not wide.warnings


def test_one_run_identical_runs_missing_tracks_and_percent_thresholds(long_profile):
    ref, runs = _runs(long_profile, [1.0, 1.0])
    one = certify_profiler(ref, runs[:1])
    assert not one.passed and any("one run" in w for w in one.warnings)
    with pytest.raises(InputError, match="identical"):
        certify_profiler(ref, [runs[0], runs[0]])
    two = Profile(ref.distance, np.column_stack([ref.elevation[:, 0], ref.elevation[:, 0]]), tracks=("left", "right"))
    res = certify_profiler(two, runs)
    assert list(res.accuracy) == ["left"] and any("'right' is not in every run" in w for w in res.warnings)
    with pytest.raises(InputError, match=r"a correlation in \(0, 1\].*0.90"):
        certify_profiler(ref, runs, thresholds={"accuracy": 90})


def test_a_flat_profile_is_named_and_the_summary_is_strict_json(tmp_path, long_profile):
    import json

    from longprofile.report import write_compare_report

    ref, runs = _runs(long_profile, [1.0, 1.0])
    dead = Profile(ref.distance, np.zeros_like(ref.elevation), tracks=("left",), name="dead")
    with pytest.raises(InputError, match="flat after the iri filter"):
        compare_profiles(dead, dead)
    res = certify_profiler(ref, runs[:1])
    write_compare_report(res, tmp_path / "c")
    summary = json.loads((tmp_path / "c" / "summary.json").read_text(),
                         parse_constant=lambda c: pytest.fail(f"non-standard JSON constant {c}"))
    assert summary["repeatability"]["left"] is None and summary["warnings"]


def test_track_names_that_differ_only_in_case_are_the_same_track(long_profile):
    """A CSV's ``left`` against a ProVAL ERD's ``Left`` / ``LEFT`` (session 36, a probe: the only fix was to edit the
    ERD's header)."""
    from dataclasses import replace

    ref, runs = _runs(long_profile, [1.0, 1.0])
    upper = [replace(runs[0], tracks=("Left",)), replace(runs[1], tracks=("LEFT",))]
    res = certify_profiler(ref, upper)
    assert res.passed and list(res.accuracy) == ["left"]


def test_road_compare_refuses_the_reference_again_as_a_run(long_profile, tmp_path, capsys):
    """The probe's `road compare prof1.csv prof1.csv` printed accuracy 1.000 and PASS: the reference given again as
    a run (the same path, a hard link, a copy in another format) or a run given twice is refused in one line."""
    import os

    from longprofile.cli.app import main
    from longprofile.io import write_profile

    x, z = long_profile.distance[:4000], long_profile.elevation[:4000]
    ref = write_profile(Profile(distance=x, elevation=z, tracks=("left",)), tmp_path / "ref.csv", units="mm")
    os.link(ref, tmp_path / "link.csv")
    copy = write_profile(Profile(distance=x, elevation=z, tracks=("left",)), tmp_path / "copy.parquet", units="mm")
    rng = np.random.default_rng(3)
    run = write_profile(Profile(distance=x, elevation=z + rng.normal(0, 1e-4, z.shape), tracks=("left",)),
                        tmp_path / "run.csv", units="mm")
    for runs, what in (([ref], "the reference again (the same file)"),
                       ([run, tmp_path / "link.csv"], "the reference again (the same file)"),
                       ([copy], "the reference again (the same stations and elevations)"),
                       ([run, run], f"run {run} again (the same file)")):
        out = tmp_path / "cmp"
        assert main(["road", "compare", str(ref), *map(str, runs), "-o", str(out)]) == 2
        err = capsys.readouterr().err.replace("\n", " ")
        assert err.count("error:") == 1 and what in err and "1.000" in err, err
        assert not out.exists()
    assert main(["road", "compare", str(ref), str(run), "-o", str(tmp_path / "ok")]) == 0
