"""``longprofile road iri`` / ``road report`` in process (CliRunner) and the error contract (exit code 2)."""

import re

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from longprofile.cli.app import app, main
from longprofile.io import write_profile
from longprofile.road import iri, iso8608_profile
from tests._reference_data import reference_file


@pytest.fixture(scope="module")
def two_track_file(tmp_path_factory):
    p = iso8608_profile(250.0, 0.1, "B", rng=9, tracks=("left", "right"))
    return write_profile(p, tmp_path_factory.mktemp("cli") / "section.csv", units="mm"), p


def test_iri_command_writes_table_and_plot(tmp_path, two_track_file):
    f, p = two_track_file
    out, png = tmp_path / "iri.csv", tmp_path / "iri.png"
    res = CliRunner().invoke(app, ["road", "iri", str(f), "--segment", "100", "--track", "left,right",
                                   "-o", str(out), "--plot", str(png)])
    assert res.exit_code == 0, res.output
    df = pd.read_csv(out, comment="#")  # the metadata are '#' lines before the header
    want = iri(p, segment_length=100.0)
    np.testing.assert_allclose(df["iri_left_m_per_km"], want.iri[:, 0], rtol=1e-9)
    np.testing.assert_allclose(df["mri_m_per_km"], want.mri, rtol=1e-9)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_iri_command_sorel_file_to_stdout(tmp_path):
    # the reference profile is 'distance elevation' in m without a header: give it one, as a user would
    data = np.loadtxt(reference_file("sorel-iri-profile", "profile_1.txt"))
    f = tmp_path / "profile_1.csv"
    pd.DataFrame({"distance_m": data[:, 0], "elevation_m": data[:, 1]}).to_csv(f, index=False)
    res = CliRunner().invoke(app, ["road", "iri", str(f), "--segment", "20", "--lead-in", str(0.5 * 80 / 3.6)])
    assert res.exit_code == 0, res.output
    lines = [ln for ln in res.stdout.splitlines() if ln and ln[0].isdigit()]
    ref = pd.read_csv(reference_file("sorel-iri-profile", "iri_reference_michalsorel.csv"), comment="#")
    got = np.array([float(ln.split(",")[2]) for ln in lines])
    np.testing.assert_allclose(got, ref["iri_sayers"], rtol=1e-6)


def test_report_command(tmp_path, two_track_file):
    f, _ = two_track_file
    res = CliRunner().invoke(app, ["road", "report", str(f), "-o", str(tmp_path / "rep"), "--plot",
                                   str(tmp_path / "i.png")])
    assert res.exit_code == 0, res.output
    page = (tmp_path / "rep" / "index.html").read_text()
    for needle in ("IRI per segment", "Localised roughness", "ISO 8608", "data:image/png;base64,"):
        assert needle in page
    assert "http" not in page.replace("http-equiv", "")  # no external assets
    assert (tmp_path / "rep" / "iri_segments.csv").exists() and (tmp_path / "i.png").exists()


def test_bad_input_exit_2(tmp_path, capsys):
    f = tmp_path / "nounits.csv"
    f.write_text("distance_m,left\n0,1\n0.1,2\n")
    assert main(["road", "iri", str(f), "-o", str(tmp_path / "x.csv")]) == 2
    captured = capsys.readouterr()
    assert re.search(r"pass --(elevation-unit|units)", captured.out + captured.err)
    assert main(["road", "iri", str(tmp_path / "missing.csv")]) == 2
    assert main(["road", "iri", str(f), "--units", "mm", "--segment", "-5"]) == 2
    assert main(["road", "report", str(f), "--units", "mm", "-o", str(tmp_path / "r")]) == 2  # shorter than lead-in
