"""A track that is not in a file is refused listing the file's tracks only (probe 37: a ``road reconstruct`` output
was said to have ``['elevation', 'raw']``, though ``raw_m`` is a diagnostic, not a track)."""

import pytest

from longprofile.errors import InputError
from longprofile.io import read_profile

ROWS = "0,0.001,0.0001,0.002,0.0002\n0.05,0.0012,0.0001,0.0021,0.0002\n0.1,0.0013,0.0001,0.0022,0.0002\n"


def test_reconstruct_output_lists_its_one_track(tmp_path):
    f = tmp_path / "rec.csv"
    f.write_text("distance_m,elevation_m,std_m,raw_m,raw_std_m\n" + ROWS)
    with pytest.raises(InputError) as info:
        read_profile(f, tracks=["left"])
    msg = str(info.value)
    assert "no track 'left'; the file (a `road reconstruct` output) has the track ['elevation']" in msg
    assert "'raw'" not in msg


def test_simulated_recording_lists_its_true_profile(tmp_path):
    f = tmp_path / "sim.csv"
    f.write_text("distance_m,true_m,apl_m\n0,0.001,0.01\n0.05,0.0012,0.02\n0.1,0.0013,0.03\n")
    with pytest.raises(InputError, match=r"has the track \['true'\] \(apl_m is the trailer's raw signal\)"):
        read_profile(f, tracks=["left"])


def test_other_tables_list_every_track(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("distance_m,left_mm,right_mm\n0,1,2\n0.05,1,2\n0.1,1,2\n")
    with pytest.raises(InputError, match=r"no track 'centre'; the file has \['left', 'right'\]"):
        read_profile(f, tracks=["centre"])
