"""What writing the road guide (docs/guide/road.md) found: a recording read as a profile, renaming tracks, a road
seed apart from the noise seed, unit-named acceptance tables, the reconstruct refusal's way out, the report's IRI
line (each test fails without its fix)."""

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main
from longprofile.errors import InputError
from longprofile.io import is_simulated_recording, read_profile, write_profile
from longprofile.road import iso8608_profile
from longprofile.road.apl import apl_model, simulate_apl_recording


def _err(capsys):
    return " ".join(capsys.readouterr().err.split())


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A `road simulate` recording (200 m of class C) and its `road reconstruct` output."""
    d = tmp_path_factory.mktemp("guide")
    assert main(["road", "simulate", "--length", "200", "--seed", "1", "-o", str(d / "rec.csv")]) == 0
    assert main(["road", "reconstruct", str(d / "rec.csv"), "-o", str(d / "profile.csv")]) == 0
    return d


# ---- 1. a recording read as a profile ------------------------------------------------------------------------------

def test_a_recording_is_read_as_its_true_profile_only(files):
    rec = files / "rec.csv"
    assert is_simulated_recording(rec) and not is_simulated_recording(files / "profile.csv")
    p = read_profile(rec)
    assert p.tracks == ("true",)
    np.testing.assert_array_equal(p.elevation[:, 0], pd.read_csv(rec)["true_m"].to_numpy())


def test_road_iri_of_a_recording_is_the_truth_s_with_a_note(files, tmp_path, capsys):
    out = tmp_path / "iri.csv"
    assert main(["road", "iri", str(files / "rec.csv"), "--segment", "50", "-o", str(out)]) == 0
    err = _err(capsys)
    assert "is a `road simulate` recording: analysing its true profile, track 'true'" in err
    assert "road reconstruct" in err and "MRI" not in err and "apl" not in err.split("section IRI")[1]
    cols = [c for c in pd.read_csv(out, comment="#").columns if c.startswith(("iri_", "mri", "hri"))]
    assert cols == ["iri_true_m_per_km"]


@pytest.mark.parametrize("command", [
    ["road", "report", "{f}", "-o", "{o}/report"],
    ["road", "convert", "{f}", "{o}/p.csv"],
    ["road", "compare", "{f}", "{f2}", "-o", "{o}/cmp", "--rename", "elevation=true"],
    ["road", "acceptance", "{f}", "-o", "{o}/acc"],
], ids=["report", "convert", "compare", "acceptance"])
def test_every_road_command_reading_profiles_says_it_reads_the_truth(files, tmp_path, capsys, command):
    args = [a.format(f=files / "rec.csv", f2=files / "profile.csv", o=tmp_path) for a in command]
    assert main(args) == 0
    assert "is a `road simulate` recording" in _err(capsys)


def test_the_acceptance_of_a_recording_has_no_apl_lot_column(files, tmp_path):
    assert main(["road", "acceptance", str(files / "rec.csv"), "-o", str(tmp_path / "acc")]) == 0
    lots = pd.read_csv(tmp_path / "acc" / "lots.csv")
    assert not [c for c in lots.columns if "apl" in c or c.startswith("mri")]


def test_the_trailer_signal_is_refused_as_a_track_with_the_way_out(files, tmp_path, capsys):
    assert main(["road", "iri", str(files / "rec.csv"), "--track", "true,apl"]) == 2
    err = _err(capsys)
    assert "raw signal, not a profile" in err and "--track true" in err and "road reconstruct" in err
    # a real recording (stations and signal only): refused by default, readable when --track names it
    real = tmp_path / "real.csv"
    pd.read_csv(files / "rec.csv")[["distance_m", "apl_m"]].to_csv(real, index=False)
    assert main(["road", "iri", str(real)]) == 2
    err = _err(capsys)
    assert "looks like an APL trailer's raw signal" in err and f"road reconstruct {real}" in err
    assert read_profile(real, tracks="apl").tracks == ("apl",)
    with pytest.raises(InputError, match="raw signal"):
        read_profile(files / "rec.csv", tracks=["apl"])


def test_batch_iri_of_a_recording_takes_its_truth(files):
    from longprofile.batch import IRITask

    out = IRITask(interval=50.0)(files / "rec.csv")
    assert [c for c in out.segments.columns if c.startswith("iri_")] == ["iri_true_m_per_km"]


# ---- 2. renaming tracks --------------------------------------------------------------------------------------------

def test_compare_names_rename_and_rename_matches_the_tracks(files, tmp_path, capsys):
    truth = tmp_path / "truth.csv"
    assert main(["road", "convert", str(files / "rec.csv"), str(truth), "--track", "true"]) == 0
    capsys.readouterr()
    assert main(["road", "compare", str(truth), str(files / "profile.csv"), "-o", str(tmp_path / "c1")]) == 2
    assert "--rename elevation=true" in _err(capsys)
    assert main(["road", "compare", str(truth), str(files / "profile.csv"), "-o", str(tmp_path / "c2"),
                 "--rename", "elevation=true"]) == 0
    runs = pd.read_csv(tmp_path / "c2" / "runs.csv", dtype={"track": str})  # "true" would be read as a bool
    assert list(runs.track) == ["true"] and runs.accuracy_correlation.iloc[0] > 0.9
    # road convert --rename writes the renamed file; the data are unchanged
    renamed = tmp_path / "renamed.csv"
    assert main(["road", "convert", str(files / "profile.csv"), str(renamed), "--rename", "elevation=true"]) == 0
    a, b = read_profile(renamed), read_profile(files / "profile.csv")
    assert a.tracks == ("true",) and np.array_equal(a.elevation, b.elevation)


@pytest.mark.parametrize("rename, message", [
    ("left=x", "has no track 'left'"),
    ("elevation", "OLD=NEW"),
    ("elevation=a,ELEVATION=b", "twice"),
])
def test_bad_renames_are_one_line_errors(files, tmp_path, capsys, rename, message):
    assert main(["road", "convert", str(files / "profile.csv"), str(tmp_path / "o.csv"), "--rename", rename]) == 2
    err = _err(capsys)
    assert message in err.split("error:", 1)[1]  # one line, after the note of a reconstruct output
    assert not (tmp_path / "o.csv").exists()


def test_profile_renamed_refuses_two_tracks_of_one_name():
    p = iso8608_profile(50.0, 0.25, "A", rng=0, tracks=("left", "right"))
    assert p.renamed({"left": "a"}).tracks == ("a", "right")
    assert p.renamed({"left": "right", "right": "left"}).tracks == ("right", "left")
    with pytest.raises(InputError, match="two tracks named 'right'"):
        p.renamed({"left": "right"})
    with pytest.raises(InputError, match="cannot rename track 'x'"):
        p.renamed({"x": "y"})


# ---- 3. the road seed ----------------------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["iso8608", "white-noise", "bump"])
def test_road_seed_keeps_the_road_and_draws_new_noise(kind):
    model = apl_model(20.0, 0.05)

    def sim(**kw):
        return simulate_apl_recording(kind, model, length=300.0, **kw)

    base = sim(rng=3)
    same = sim(rng=3, road_rng=3)  # the documented default: --road-seed is --seed
    np.testing.assert_array_equal(same.true_elevation, base.true_elevation)
    np.testing.assert_array_equal(same.signal, base.signal)
    other = sim(rng=4, road_rng=3)  # the road of seed 3 under other noise
    np.testing.assert_array_equal(other.true_elevation, base.true_elevation)
    n3, n4 = base.signal - _clean(base, model), other.signal - _clean(other, model)
    assert abs(np.corrcoef(n3, n4)[0, 1]) < 0.05  # independent noise (6 001 samples: |r| ~ 0.013)
    # and the noise of seed 4 whatever the road: the pattern of --seed 4 alone
    np.testing.assert_allclose(n4 / other.noise_std, (sim(rng=4).signal - _clean(sim(rng=4), model))
                               / sim(rng=4).noise_std, rtol=1e-9, atol=1e-9)


def _clean(rec, model):
    from longprofile.road.apl import apl_response

    return apl_response(rec.true_elevation, model)


def test_cli_road_seed(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert main(["road", "simulate", "--length", "100", "--seed", "2", "-o", str(a)]) == 0
    assert main(["road", "simulate", "--length", "100", "--seed", "5", "--road-seed", "2", "-o", str(b)]) == 0
    ra, rb = pd.read_csv(a), pd.read_csv(b)
    assert ra.true_m.equals(rb.true_m) and not ra.apl_m.equals(rb.apl_m)


# ---- 4. acceptance tables name their units -------------------------------------------------------------------------

_SPEC = {
    "si": ['units = "si"', "[localized]", "threshold = 3.2", "[grinding]", "max_depth = 5"],
    "us": ['units = "us"', "[localized]", f"threshold = {3.2 * 63.36!r}", "[grinding]", f"max_depth = {5 / 25.4!r}"],
}


@pytest.fixture(scope="module")
def acceptance(tmp_path_factory):
    d = tmp_path_factory.mktemp("acceptance")
    lanes = d / "lanes.csv"
    write_profile(iso8608_profile(1000.0, 0.025, "A", rng=1, tracks=("left", "right")), lanes, units="mm")
    for units, lines in _SPEC.items():
        (d / f"{units}.toml").write_text("\n".join(lines) + "\n")
        assert main(["road", "acceptance", str(lanes), "--spec", str(d / f"{units}.toml"), "-o", str(d / units)]) == 0
    return d


def test_acceptance_tables_name_their_units(acceptance):
    for units, (lu, iu, du) in {"si": ("m", "m_per_km", "mm"), "us": ("ft", "in_per_mi", "in")}.items():
        out = acceptance / units
        assert list(pd.read_csv(out / "lots.csv").columns) == [
            f"start_{lu}", f"end_{lu}", f"included_length_{lu}", f"iri_left_{iu}", f"iri_right_{iu}", f"mri_{iu}",
            f"index_{iu}", "pay_factor"]
        assert list(pd.read_csv(out / "defects.csv").columns) == [
            f"start_{lu}", f"end_{lu}", f"length_{lu}", f"peak_station_{lu}", f"peak_{iu}", "open_end"]
        assert list(pd.read_csv(out / "grinds.csv").columns) == [
            "area", "track", f"start_{lu}", f"end_{lu}", f"length_{lu}", f"max_depth_{du}", f"mean_depth_{du}",
            "achieved", f"peak_before_{iu}", f"peak_after_{iu}", "limit"]
        assert list(pd.read_csv(out / "histogram.csv").columns) == [f"low_{iu}", f"high_{iu}", "lots", f"length_{lu}"]
        assert list(pd.read_parquet(out / "localized.parquet").columns) == [
            f"station_{lu}", f"iri_left_{iu}", f"iri_right_{iu}", f"mri_{iu}", f"index_{iu}"]


def test_acceptance_values_agree_once_converted_by_their_column_units(acceptance):
    """The same physical spec in SI and US: the defects found agree once each is converted by its column's unit."""
    si, us = (pd.read_csv(acceptance / u / "defects.csv") for u in ("si", "us"))
    assert len(si) == len(us) > 0
    np.testing.assert_allclose(us.peak_station_ft * 0.3048, si.peak_station_m, atol=1e-6)
    np.testing.assert_allclose(us.peak_in_per_mi / 63.36, si.peak_m_per_km, rtol=1e-9)


# ---- 5. the reconstruct refusal names what the command line offers -------------------------------------------------

def test_reconstruct_outside_table_1_names_the_cli_way_out(files, tmp_path, capsys):
    assert main(["road", "reconstruct", str(files / "rec.csv"), "--speed", "25", "-o", str(tmp_path / "x.csv")]) == 2
    err = _err(capsys)
    assert "TrailerPoles" not in err and "poles=" not in err
    assert "road identify" in err and "--model model.json" in err and "--speed 25" in err
    assert "20 m/s at dx 0.05, 0.15, 0.2 m" in err and "6 m/s at dx 0.05 m" in err


# ---- 6. road report prints the section IRI as road iri does --------------------------------------------------------

def test_road_report_prints_the_iri_line_of_road_iri(acceptance, tmp_path, capsys):
    lanes = acceptance / "lanes.csv"
    assert main(["road", "iri", str(lanes), "-o", str(tmp_path / "iri.csv")]) == 0
    iri_line = next(ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("section IRI"))
    assert main(["road", "report", str(lanes), "-o", str(tmp_path / "report")]) == 0
    report_lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("section IRI")]
    assert report_lines == [iri_line] and "MRI" in iri_line and "HRI" in iri_line
