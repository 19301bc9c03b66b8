"""write_table / read_table: strict suffixes for writing, exact float64 round trip of the fast CSV writer.

Oracles: pandas (``DataFrame.to_csv`` text for non-numeric tables, ``pandas.read_csv``) and the Python
``csv`` module for the header.
"""

import csv

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from longprofile.errors import InputError, InputFormatError, OutputError
from longprofile.io import read_table, write_table


@pytest.mark.parametrize("name", ["t.txt", "t.xlsx", "t.json", "t", "t.csv.gz", "t.TXT"])
def test_unknown_suffix_is_refused_for_writing_and_nothing_is_written(tmp_path, name):
    with pytest.raises(OutputError, match="unknown table format .* for writing; use .csv or .parquet"):
        write_table(pd.DataFrame({"a": [1.0]}), tmp_path / "sub" / name)
    assert not (tmp_path / "sub").exists()


def test_txt_is_still_read_as_csv(tmp_path):
    f = tmp_path / "export.txt"
    f.write_text("distance_m,left_mm\n0,1.5\n0.25,1.75\n")
    df = read_table(f, numeric=["left_mm"])
    assert list(df.columns) == ["distance_m", "left_mm"] and df["left_mm"].tolist() == [1.5, 1.75]
    (tmp_path / "x.dat").write_text("a\n1\n")
    with pytest.raises(InputError, match="unknown table format '.dat'"):
        read_table(tmp_path / "x.dat")


_floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
_names = st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), min_size=1, max_size=12)


@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data(), n=st.integers(0, 40), ncols=st.integers(1, 5), suffix=st.sampled_from([".csv", ".parquet"]))
def test_numeric_round_trip_is_exact(tmp_path, data, n, ncols, suffix):
    # names as read_table reads them: no '#' (comments), no blanks around them (skipinitialspace), no ';'
    # or tab (read_table refuses a one-column header holding them: a file separated by ';')
    names = data.draw(st.lists(_names.filter(lambda s: s.strip() == s and not set(s) & set("#;\t")),
                               min_size=ncols, max_size=ncols, unique=True))
    columns = {}
    for name in names:
        kind = data.draw(st.sampled_from(["float", "whole", "int", "bool"]))
        if kind == "float":
            columns[name] = np.array(data.draw(st.lists(_floats, min_size=n, max_size=n)), dtype=np.float64)
        elif kind == "whole":  # floats that are whole numbers: must stay floats
            columns[name] = np.array(data.draw(st.lists(st.integers(-2**53 + 1, 2**53 - 1), min_size=n,
                                                        max_size=n)), dtype=np.float64)
        elif kind == "bool":  # e.g. the slope_plausible flag of vehicle slope
            columns[name] = np.array(data.draw(st.lists(st.booleans(), min_size=n, max_size=n)), dtype=bool)
        else:
            columns[name] = np.array(data.draw(st.lists(st.integers(-2**63, 2**63 - 1), min_size=n, max_size=n)),
                                     dtype=np.int64)
    df = pd.DataFrame(columns)
    path = write_table(df, tmp_path / f"t{suffix}")
    if suffix == ".csv":
        with open(path, newline="", encoding="utf-8") as fh:
            assert next(csv.reader(fh)) == names  # header names unchanged
    back = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
    assert list(back.columns) == names
    for name in names:
        want, got = df[name].to_numpy(), back[name].to_numpy()
        if n and want.dtype.kind == "f" and not np.isnan(want).all():
            assert got.dtype == np.float64, name
        if n and want.dtype.kind in "ib":
            assert got.dtype == want.dtype, name
        assert len(got) == n and np.array_equal(got.astype(np.float64) if want.dtype.kind == "f" else got, want,
                                                equal_nan=want.dtype.kind == "f"), name
        if want.dtype.kind == "f":  # the sign of zero too
            zero = want == 0
            assert np.array_equal(np.signbit(got.astype(np.float64)[zero]), np.signbit(want[zero])), name
    # and through our own reader, which the CLI uses
    ours = read_table(path)
    for name in names:
        assert np.array_equal(ours[name].to_numpy(), back[name].to_numpy(), equal_nan=back[name].dtype.kind == "f")


def test_csv_text_of_a_profile(tmp_path):
    df = pd.DataFrame({"distance_m": [0.0, 0.25, 0.5], "left_mm": [1.5, np.nan, -0.001], "n": [1, 2, 3],
                       "flat_m": [-0.0, 1.0, 2.0]})
    text = write_table(df, tmp_path / "p.csv").read_text()
    assert text == "distance_m,left_mm,n,flat_m\n0,1.5,1,-0.0\n0.25,,2,1.0\n0.5,-0.001,3,2.0\n"
    back = read_table(tmp_path / "p.csv")
    assert back["flat_m"].dtype == np.float64 and back["distance_m"].dtype == np.float64


def test_boolean_columns_take_the_fast_writer_and_read_as_pandas_writes_them(tmp_path, monkeypatch):
    df = pd.DataFrame({"t": [0.0, 0.001, 0.002], "ok": [True, False, True], "n": [1, 2, 3]})
    calls = []
    monkeypatch.setattr(pd.DataFrame, "to_csv", lambda self, *a, **k: calls.append(1))  # must not be used
    text = write_table(df, tmp_path / "b.csv").read_text()
    monkeypatch.undo()
    assert calls == [] and text == "t,ok,n\n0,True,1\n0.001,False,2\n0.002,True,3\n"  # the booleans as pandas writes
    back = read_table(tmp_path / "b.csv")
    assert back["ok"].dtype == bool and back["ok"].tolist() == [True, False, True]


def test_non_numeric_tables_are_written_as_pandas_writes_them(tmp_path):
    df = pd.DataFrame({"date": pd.to_datetime(["2020-01-01", "2020-01-02"]), "sensor_id": ["S1", "S,2"],
                       "ok": [True, False], "dz_m": [0.1, np.nan]})
    assert write_table(df, tmp_path / "t.csv").read_text() == df.to_csv(index=False)


def test_one_column_with_missing_values_keeps_its_rows(tmp_path):
    df = pd.DataFrame({"x": [np.nan, 1.0, np.nan]})
    path = write_table(df, tmp_path / "x.csv")
    assert path.read_text() == df.to_csv(index=False)  # "" for the empty cells, not blank lines
    np.testing.assert_array_equal(pd.read_csv(path)["x"].to_numpy(), df["x"].to_numpy())


def test_a_last_row_of_missing_values_is_kept_but_trailing_blank_lines_are_not(tmp_path):
    df = pd.DataFrame({"a": [1.0, np.nan], "b": [2.0, np.nan]})
    back = read_table(write_table(df, tmp_path / "t.csv"))
    assert len(back) == 2 and back.iloc[1].isna().all()
    f = tmp_path / "u.csv"
    f.write_text("a,b\n1,2\n,\n\n  \n# end\n\n")
    assert len(read_table(f)) == 2


def test_parquet_still_written(tmp_path):
    df = pd.DataFrame({"a": [0.1, 0.2], "b": ["x", "y"]})
    pd.testing.assert_frame_equal(read_table(write_table(df, tmp_path / "t.parquet")), df)


def test_a_reconstruct_output_is_read_as_its_one_profile_track(tmp_path):
    """`road reconstruct` writes distance_m, elevation_m, std_m, raw_m, raw_std_m: one track with its std."""
    import numpy as np
    import pandas as pd

    from longprofile.io import read_profile

    x = np.arange(0.0, 10.0, 0.05)
    path = tmp_path / "profile.csv"
    pd.DataFrame(dict(distance_m=x, elevation_m=np.sin(x), std_m=np.full(x.size, 1e-3), raw_m=x * 1e-3,
                      raw_std_m=np.nan)).to_csv(path, index=False)
    prof = read_profile(path)
    assert prof.tracks == ("elevation",)
    np.testing.assert_array_equal(prof.std[:, 0], 1e-3)
    assert read_profile(path, tracks="raw").tracks == ("raw",)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cases=st.lists(st.sampled_from([str.upper, str.title, str.swapcase, str]), min_size=3, max_size=3))
def test_required_columns_are_found_in_any_letter_case(tmp_path, cases):
    names = ["sensor_id", "x_m", "angle_deg"]
    f = tmp_path / "t.csv"
    f.write_text(",".join(case(n) for case, n in zip(cases, names)) + "\nS1,0.5,0.01\n")
    df = read_table(f, required=names, numeric=["x_m"])
    assert list(df.columns) == names and df["x_m"].tolist() == [0.5]


def test_two_case_variants_of_a_required_column_are_not_guessed(tmp_path):
    f = tmp_path / "t.csv"
    f.write_text("X_M,X_m\n1,2\n")
    with pytest.raises(InputError, match=r"missing column\(s\) \['x_m'\]"):
        read_table(f, required=["x_m"])


def test_a_loggers_missing_value_markers_are_missing_values(tmp_path):
    """"NAN" (Campbell Scientific loggers), "NONE", "Null", "#N/A"... read as missing, as an empty cell and pandas'
    own "NaN" are (core.MISSING_TEXT in the letter cases loggers write): a recording with a NAN gap reconstructs as
    with an empty one; before, "NAN" refused the file as non-numeric."""
    from longprofile.core import MISSING_TEXT

    path = tmp_path / "t.csv"
    path.write_text("x,y\n1,NAN\n2,Null\n3,NONE\n4,#N/A\n5,-nan\n6,n/a\n7,2.5\n8,\n")
    t = read_table(path, numeric=["y"])
    assert t["y"].isna().sum() == 7 and t["y"].iloc[6] == 2.5
    assert {"nan", "null", "none", "#n/a"} <= MISSING_TEXT
    path.write_text("x,y\n1,n.a.\n")  # text that is not a marker is still refused
    with pytest.raises(InputFormatError, match="non-numeric"):
        read_table(path, numeric=["y"])


def test_a_file_that_is_not_utf8_is_refused_with_its_line(tmp_path):
    """A Windows spreadsheet's export in cp1252 (an accent in a name): pandas' "can't decode byte 0xe9 in position 0"
    named neither the line nor what to do (session 35, a user's probe)."""
    path = tmp_path / "t.csv"
    path.write_bytes("x_m,name\n1,a\n2,capteur_\u00e9\n".encode("cp1252"))
    with pytest.raises(InputFormatError, match=r"line 3 is not UTF-8 text \('2,capteur_\u00e9'.*save the file as UTF-8"):
        read_table(path)


def test_a_hash_inside_a_field_is_text_unless_the_data_have_comment_lines(tmp_path):
    """"#" starts a comment line; inside a field it is text (a sensor "PK#1": its row was cut at the "#" and its
    numbers read as missing; session 35). A file whose data also hold comment lines keeps the old rule."""
    path = tmp_path / "t.csv"
    path.write_text("# exported by a logger\nx_m,name,y_m\n1,PK#1,2\n2,PK#2,3\n")
    t = read_table(path)
    assert t["name"].tolist() == ["PK#1", "PK#2"] and t["y_m"].tolist() == [2, 3]
    path.write_text("x_m,name,y_m\n1,a,2\n# a note among the data\n2,b,3\n")
    t = read_table(path)
    assert t["name"].tolist() == ["a", "b"] and t["y_m"].tolist() == [2, 3]


def test_report_table_metadata_is_strict_json(tmp_path):
    """A NaN in the metadata (a dead track's section IRI) is written as JSON null, not Python's NaN, in the CSV
    header and in the Parquet metadata (other JSON readers refuse NaN)."""
    import json

    from longprofile.io import read_report_table, write_report_table

    meta = {"section_iri_left": 1.5, "section_iri_right": float("nan"), "nested": {"x": [float("inf"), 2.0]}}
    frame = pd.DataFrame({"start_m": [0.0], "iri_m_per_km": [1.0]})
    for name in ("t.csv", "t.parquet"):
        write_report_table(frame, tmp_path / name, meta)
        _, back = read_report_table(tmp_path / name)
        assert back == {"section_iri_left": 1.5, "section_iri_right": None, "nested": {"x": [None, 2.0]}}
    for line in (tmp_path / "t.csv").read_text().splitlines():
        if line.startswith("# "):
            json.loads(line.split(": ", 1)[1], parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))


@pytest.mark.parametrize("name", ["t.csv", "t.parquet"])
def test_write_table_metadata_reads_back_and_is_skipped_by_read_table(tmp_path, name):
    """``write_table(..., metadata=)``: `#` lines / Parquet metadata (as write_report_table), with a text column
    (the pandas writer) and without (the pyarrow writer); read_table returns the same frame as without them."""
    from longprofile.io import read_report_table, read_table, write_table

    meta = {"source": "a#1.csv", "q_m2": 2e-6, "none": None, "list": [1, "x"]}
    for df in (pd.DataFrame({"x_m": [0.0, 0.5], "z_m": [1.5, float("nan")]}),
               pd.DataFrame({"x_m": [0.0, 0.5], "name": ["NA", "PK#12"]})):
        write_table(df, tmp_path / name, metadata=meta)
        frame, got = read_report_table(tmp_path / name)
        assert got == meta
        write_table(df, tmp_path / f"plain_{name}")
        pd.testing.assert_frame_equal(read_table(tmp_path / name), read_table(tmp_path / f"plain_{name}"))
