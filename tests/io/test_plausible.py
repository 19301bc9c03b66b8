"""The input layer refuses values no real file holds (a unit under the wrong label) and files cut short."""


import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.core import Profile
from longprofile.errors import InputFormatError, UnitsError
from longprofile.io import read_profile, read_table
from longprofile.io._plausible import MAX_ABS_ELEVATION_M, check_profile_plausible
from longprofile.road import iso8608_profile
from tests._reference_data import reference_file

CLASSES = {"A": 16e-6, "C": 256e-6, "E": 4096e-6, "H": 262144e-6}  # ISO 8608 Gd(n0), m^3


@settings(max_examples=20)
@given(st.sampled_from(sorted(CLASSES)), st.sampled_from([0.025, 0.05, 0.25]), st.integers(0, 10_000),
       st.floats(-500.0, 3000.0))
def test_every_iso_road_in_metres_passes_and_the_same_in_mm_is_refused(cls, dx, seed, offset):
    p = iso8608_profile(300.0, dx, CLASSES[cls], rng=seed)
    z = p.elevation.reshape(p.distance.size, -1) + offset  # an absolute elevation of a real place
    check_profile_plausible(Profile(p.distance, z, tracks=p.tracks), "road")
    with pytest.raises(UnitsError, match="millimetres under a metre label|beyond any terrain"):
        check_profile_plausible(Profile(p.distance, z * 1000.0, tracks=p.tracks), "road")


def test_a_huge_value_is_refused_with_its_station():
    x = np.arange(0, 50, 0.25)
    z = 1e-3 * np.sin(x)
    z[37] = 1e300
    with pytest.raises(UnitsError, match=r"1e\+300 m at station 9\.25 m, beyond any terrain"):
        check_profile_plausible(Profile(x, z), "p.csv")
    z[37] = MAX_ABS_ELEVATION_M * 0.99  # a (very high) elevation: one spike does not move the median grade
    check_profile_plausible(Profile(x, z), "p.csv")


def test_a_measured_profile_passes_in_metres_and_is_refused_in_mm():
    path = reference_file("sorel-iri-profile", "profile_1.txt")
    data = np.loadtxt(path)  # station (m), absolute elevation (m), 0.25 m step
    check_profile_plausible(Profile(data[:, 0], data[:, 1]), path)
    with pytest.raises(UnitsError, match="beyond any terrain"):
        check_profile_plausible(Profile(data[:, 0], data[:, 1] * 1000.0), path)
    with pytest.raises(UnitsError, match="millimetres under a metre label"):  # relative to its start, in mm
        check_profile_plausible(Profile(data[:, 0], (data[:, 1] - data[0, 1]) * 1000.0), path)


def test_a_cut_last_row_is_refused_with_its_line_and_empty_cells_are_not(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("distance_m,left_m,right_m\n0,0.001,0.002\n0.25,0.001,0.002\n0.5,0.0")
    with pytest.raises(InputFormatError, match=r"line 4 \(the last\) has 2 of the header's 3 fields"):
        read_table(path)
    path.write_text("distance_m,left_m,right_m\n0,0.001,0.002\n0.25,0.001,0.002\n0.5,,\n# end\n\n")
    assert read_table(path).shape == (3, 3)  # a row of empty cells is a missing sample, not a cut


def test_a_header_without_rows_and_an_orphan_std_column_are_refused(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("distance_m,left_m\n")
    with pytest.raises(InputFormatError, match="no data rows"):
        read_profile(path)
    pd.DataFrame(dict(distance_m=[0, 0.25, 0.5], std_m=[1e-3] * 3, raw_m=[0.0, 1e-3, 0.0])).to_csv(path, index=False)
    with pytest.raises(InputFormatError, match="'std_m' is a standard deviation"):
        read_profile(path)


def test_a_bench_record_must_be_sampled_at_the_models_spacing(tmp_path):
    from longprofile.io import read_sampled_column

    path = tmp_path / "bench.csv"
    x = np.arange(200) * 0.05
    pd.DataFrame(dict(distance_m=x, apl_mm=np.sin(x))).to_csv(path, index=False)
    np.testing.assert_allclose(read_sampled_column(path, "apl_mm", dx=0.05), np.sin(x) / 1000.0)
    with pytest.raises(InputFormatError, match=r"line 3: station 0\.05 m is 0\.05 m after .* dx = 0\.025 m"):
        read_sampled_column(path, "apl_mm", dx=0.025)
    pd.DataFrame(dict(apl_m=np.sin(x))).to_csv(path, index=False)  # no station column: rows are dx apart
    assert read_sampled_column(path, "apl_m", dx=0.025).shape == (200,)
