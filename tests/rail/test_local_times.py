"""Readings in the loggers' local time (``validate_site(timezone=...)``, ``rail settle --timezone``).

The oracle is the zone database: each reading gets a true UTC time, the file holds it as the local wall-clock time
of the zone (what a logger on local time writes, with the hour shown twice in autumn), and the site read with the
zone must hold the true UTC times.
"""

from __future__ import annotations

import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from longprofile.cli.app import main
from longprofile.errors import InputError, InputFormatError
from longprofile.rail import simulate_site, validate_site

_SYN = {}

#: Zones with a daylight-saving change, north and south, and the UTC instant their clocks go back in 2019.
FALLS = {"Europe/Paris": "2019-10-27T01:00:00Z", "America/New_York": "2019-11-03T06:00:00Z",
         "Australia/Sydney": "2019-04-06T16:00:00Z", "Europe/London": "2019-10-27T01:00:00Z"}


def _site(minutes=20.0):
    if minutes not in _SYN:
        _SYN[minutes] = simulate_site("mittersheim-like", seed=1, sampling_minutes=minutes, n_days=3)
    return _SYN[minutes]


def _redated(syn, start: pd.Timestamp) -> pd.DataFrame:
    """The readings moved to start at ``start`` (UTC), times as UTC instants."""
    r = syn.readings.copy()
    t = pd.to_datetime(r["timestamp"])
    r["utc"] = (t - t.min() + start).dt.tz_localize("UTC") if start.tzinfo is None else t - t.min() + start
    return r


def _local_text(utc: pd.Series, zone: str) -> pd.Series:
    return utc.dt.tz_convert(zone).dt.strftime("%Y-%m-%dT%H:%M:%S")


@settings(max_examples=12, deadline=None)
@given(zone=st.sampled_from(sorted(FALLS)), minutes=st.sampled_from([10.0, 20.0, 30.0]),
       hours_before=st.integers(2, 40), by_time=st.booleans())
def test_local_times_across_the_autumn_change_read_as_the_true_instants(zone, minutes, hours_before, by_time):
    syn = _site(minutes)
    r = _redated(syn, pd.Timestamp(FALLS[zone]) - pd.Timedelta(hours=hours_before))
    if by_time:  # a logger's export: every sensor at each time, in the order written
        r = r.sort_values("utc", kind="stable")
    local = r.assign(timestamp=_local_text(r["utc"], zone)).drop(columns="utc")
    assert local.duplicated(["sensor_id", "timestamp"]).any()  # the clock did show an hour twice
    with pytest.raises(InputError, match="daylight-saving change"):
        validate_site(syn.sensors, local, syn.survey)  # read as UTC: the duplicates are refused, as before
    got = validate_site(syn.sensors, local, syn.survey, timezone=zone).readings
    want = validate_site(syn.sensors, r.assign(timestamp=r["utc"].dt.strftime("%Y-%m-%dT%H:%M:%SZ"))
                         .drop(columns="utc"), syn.survey).readings
    pd.testing.assert_frame_equal(got, want)


def test_a_time_the_clock_skips_an_unknown_zone_and_times_with_offsets():
    syn = _site()
    r = _redated(syn, pd.Timestamp("2019-03-30T12:00:00Z"))
    naive = r["utc"].dt.strftime("%Y-%m-%dT%H:%M:%S")  # UTC wall clock: passes 02:00-03:00 of 03-31, absent in Paris
    with pytest.raises(InputFormatError, match=r"does not exist in Europe/Paris \(the clock skips"):
        validate_site(syn.sensors, r.assign(timestamp=naive).drop(columns="utc"), syn.survey, timezone="Europe/Paris")
    with pytest.raises(InputError, match="unknown time zone 'Europe/Pariss'"):
        validate_site(syn.sensors, r.assign(timestamp=naive).drop(columns="utc"), syn.survey, timezone="Europe/Pariss")
    iso = r["utc"].dt.tz_convert("Europe/Paris").map(pd.Timestamp.isoformat)  # with their offsets
    a = validate_site(syn.sensors, r.assign(timestamp=iso).drop(columns="utc"), syn.survey, timezone="Asia/Tokyo")
    b = validate_site(syn.sensors, r.assign(timestamp=iso).drop(columns="utc"), syn.survey)
    pd.testing.assert_frame_equal(a.readings, b.readings)  # an offset names the instant, whatever the zone


def test_rail_settle_timezone_gives_the_utc_files_result(tmp_path, capsys):
    syn = _site(30.0)
    r = _redated(syn, pd.Timestamp(FALLS["Europe/Paris"]) - pd.Timedelta(hours=30))
    syn.sensors.to_csv(tmp_path / "sensors.csv", index=False)
    syn.survey.to_csv(tmp_path / "survey.csv", index=False)
    r.assign(timestamp=r["utc"].dt.strftime("%Y-%m-%dT%H:%M:%SZ")).drop(columns="utc").to_csv(tmp_path / "utc.csv",
                                                                                                 index=False)
    r.assign(timestamp=_local_text(r["utc"], "Europe/Paris")).drop(columns="utc").to_csv(tmp_path / "local.csv",
                                                                                           index=False)
    common = ["rail", "settle", "--sensors", str(tmp_path / "sensors.csv"), "--survey", str(tmp_path / "survey.csv")]
    assert main(common + ["--readings", str(tmp_path / "utc.csv"), "-o", str(tmp_path / "a.csv")]) == 0
    assert main(common + ["--readings", str(tmp_path / "local.csv"), "-o", str(tmp_path / "b.csv")]) == 2
    assert "--timezone" in capsys.readouterr().err  # the refusal names the way out
    assert main(common + ["--readings", str(tmp_path / "local.csv"), "--timezone", "Europe/Paris",
                          "-o", str(tmp_path / "b.csv")]) == 0
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()
