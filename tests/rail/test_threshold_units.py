"""Rate thresholds in a column with a per-day unit (value_mm_per_day, 'value (mm/day)', value_mm/day): taken for the
rate rows, refused for settlement and twist rows (lengths); the refusal of a value column names those accepted
(a track engineer's probe, session 39)."""

from __future__ import annotations

import pytest

from longprofile.errors import InputFormatError
from longprofile.io import read_rail_thresholds

#: The same limits as value_mm (mm/day for the rate): the reference every spelling must give.
REFERENCE = "quantity,level,value_mm\nsettlement,alert,10\nsettlement,alarm,20\nrate,alert,2\nrate,alarm,4\n"


@pytest.mark.parametrize(("header", "factor"), [
    ("value_mm_per_day", 1.0), ("value (mm/day)", 1.0), ("value_mm/day", 1.0), ("Value [mm/d]", 1.0),
    ("value (mm / day)", 1.0), ("value_cm_per_day", 0.1), ("value_m/day", 1e-3)])
def test_rate_rows_in_a_per_day_column_are_read_in_its_unit(tmp_path, header, factor):
    ref = tmp_path / "ref.csv"
    ref.write_text(REFERENCE)
    want = read_rail_thresholds(ref)
    f = tmp_path / "thr.csv"
    # alone: rate rows only
    f.write_text(f"quantity,level,{header}\nrate,alert,{2 * factor:g}\nrate,alarm,{4 * factor:g}\n")
    got = read_rail_thresholds(f)
    assert set(got) == {"rate"} and got["rate"] == pytest.approx(want["rate"])
    # next to value_mm: the lengths in value_mm, the rates in the per-day column
    f.write_text(f'quantity,level,value_mm,"{header}"\nsettlement,alert,10,\nsettlement,alarm,20,\n'
                 f"rate,alert,,{2 * factor:g}\nrate,alarm,,{4 * factor:g}\n")
    got = read_rail_thresholds(f)
    assert got["settlement"] == want["settlement"] and got["rate"] == pytest.approx(want["rate"])


def test_a_length_in_a_per_day_column_and_a_value_given_twice_are_refused(tmp_path):
    f = tmp_path / "thr.csv"
    f.write_text("quantity,level,value_mm_per_day\nrate,alert,2\nsettlement,alert,10\n")
    with pytest.raises(InputFormatError, match=r"row 2: a settlement threshold is a length, not a rate: give it in "
                                               r"'value_mm', not in 'value_mm_per_day'"):
        read_rail_thresholds(f)
    f.write_text("quantity,level,value_mm,value (mm/day)\ntwist,alert,,4\n")
    with pytest.raises(InputFormatError, match="a twist threshold is a length"):
        read_rail_thresholds(f)
    f.write_text("quantity,level,value_mm,value_mm_per_day\nrate,alert,2,2\n")
    with pytest.raises(InputFormatError, match="row 1: a value in both 'value_mm' and 'value_mm_per_day'"):
        read_rail_thresholds(f)
    f.write_text("quantity,level,value_mm_per_day,value (mm/d)\nrate,alert,2,\n")
    with pytest.raises(InputFormatError, match="more than one value column"):
        read_rail_thresholds(f)


@pytest.mark.parametrize("header", ["value", "value_mm/h", "value (mm/week)", "limit_mm"])
def test_a_value_column_not_understood_names_the_columns_accepted(tmp_path, header):
    f = tmp_path / "thr.csv"
    f.write_text(f"quantity,level,{header}\nrate,alert,2\n")
    with pytest.raises(InputFormatError, match=r"no value column; accepted: value_mm \(mm; mm/day on rate rows\), "
                                               r"or value with its length unit: value_m.*value_mm_per_day, "
                                               r"'value \(mm/day\)'"):
        read_rail_thresholds(f)


def test_a_per_day_rate_below_the_floor_names_its_column(tmp_path):
    f = tmp_path / "thr.csv"
    f.write_text("quantity,level,value_m/day\nrate,alert,0.00002\n")
    with pytest.raises(InputFormatError, match=r"rate alert 2e-05 m/day is below 0.05 mm/day.*'value_m/day'"):
        read_rail_thresholds(f)
