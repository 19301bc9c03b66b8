"""``rail serve`` / ``rail site ...`` commands (registered on a Typer app as cli/rail.py does)."""

from __future__ import annotations

import json

import pytest
import typer
from typer.testing import CliRunner

from longprofile.cli._rail_serve import register
from longprofile.errors import LongprofileError

from .conftest import synthetic


@pytest.fixture
def cli():
    app = typer.Typer()
    register(app)
    runner = CliRunner()

    def run(*args, input=None):
        res = runner.invoke(app, list(args), input=input, catch_exceptions=True)
        return res

    return run


def test_site_commands_manage_a_site_end_to_end(cli, tmp_path):
    syn, r = synthetic()
    url = f"sqlite:///{tmp_path}/cli.db"
    syn.sensors.to_csv(tmp_path / "sensors.csv", index=False)
    syn.survey.to_csv(tmp_path / "survey.csv", index=False)
    r.to_csv(tmp_path / "readings.csv", index=False)
    assert cli("site", "create", "mitt", "--db", url, "--clock", "data", "--actor", "alice").exit_code == 0
    assert json.loads(cli("site", "sensors", "mitt", "--file", str(tmp_path / "sensors.csv"), "--db", url).stdout) \
        == {"added": 58, "changed": 0}
    assert cli("site", "survey", "mitt", "--file", str(tmp_path / "survey.csv"), "--db", url).exit_code == 0
    assert cli("site", "threshold", "mitt", "settlement", "alert", "3", "--db", url, "--actor", "bob").exit_code == 0
    key = cli("site", "logger", "mitt", "lg1", "--db", url).stdout.strip()
    assert key.startswith("lpk_")
    out = cli("site", "ingest", "mitt", "--file", str(tmp_path / "readings.csv"), "--db", url)
    assert out.exit_code == 0 and json.loads(out.stdout)["accepted"] == len(r)
    out = cli("site", "recompute", "mitt", "--db", url)
    assert out.exit_code == 0 and json.loads(out.stdout)["status"] == "ok"
    show = json.loads(cli("site", "show", "mitt", "--db", url).stdout)
    assert show["thresholds"] == {"settlement.alert": 0.003} and len(show["sensors"]) == 58
    audit = json.loads(cli("site", "audit", "mitt", "--db", url).stdout)
    assert [a["actor"] for a in audit if a["entity"] == "threshold"] == ["bob"] and audit[-1]["actor"] == "alice"
    assert cli("site", "user", "carol", "--role", "engineer", "--db", url, input="carol-password\n").exit_code == 0
    assert cli("site", "list", "--db", url).stdout.split() == ["mitt"]


def test_errors_are_library_errors(cli, tmp_path):
    url = f"sqlite:///{tmp_path}/cli.db"
    res = cli("site", "create", "../etc", "--db", url)
    assert isinstance(res.exception, LongprofileError)
    res = cli("site", "threshold", "nosuch", "settlement", "alert", "3", "--db", url)
    assert isinstance(res.exception, LongprofileError) and "unknown site" in str(res.exception)
    res = cli("serve")
    assert isinstance(res.exception, LongprofileError) and "--db" in str(res.exception)
    assert cli("site", "create", "mitt", "--db", url).exit_code == 0
    res = cli("site", "update", "mitt", "--db", url, "--set", "settings={model: per-day}")  # not JSON
    assert isinstance(res.exception, LongprofileError) and "not a JSON object" in str(res.exception)
    res = cli("site", "update", "mitt", "--db", url, "--set", 'settings={"model": "joint"}')
    assert isinstance(res.exception, LongprofileError) and "model must be one of" in str(res.exception)
    res = cli("site", "update", "mitt", "--db", url, "--set", 'settings={"model": "per-day"}')
    assert res.exit_code == 0 and json.loads(res.stdout)["settings"] == {"model": "per-day"}
    # a profile given as readings: one line naming the columns, nothing stored (it printed one rejection per row)
    prof = tmp_path / "profile.csv"
    prof.write_text("distance_m,elevation_m\n" + "".join(f"{0.25 * i},0.001\n" for i in range(500)))
    res = cli("site", "ingest", "mitt", "--file", str(prof), "--db", url)
    assert isinstance(res.exception, LongprofileError) and "missing column(s)" in str(res.exception)
    # thresholds: mm, plausibility checked (a unit mistake is refused)
    for value in ("1e300", "0.000001"):
        res = cli("site", "threshold", "mitt", "settlement", "alert", value, "--db", url)
        assert isinstance(res.exception, LongprofileError) and "not plausible" in str(res.exception)
    assert cli("site", "threshold", "mitt", "settlement", "alert", "12", "--db", url).exit_code == 0
    res = cli("site", "survey", "mitt", "--file", str(prof), "--db", url)
    assert isinstance(res.exception, LongprofileError) and "missing column(s) ['x_m', 'z_m']" in str(res.exception)


def test_thresholds_file_replaces_all_levels_in_one_transaction(cli, tmp_path):
    url = f"sqlite:///{tmp_path}/cli.db"
    assert cli("site", "create", "mitt", "--db", url).exit_code == 0
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    first.write_text("quantity,level,value_mm\nsettlement,alert,10\nsettlement,action,15\nsettlement,alarm,20\n"
                     "rate,alert,3\n")
    # raising alert above the old action and dropping action: one level at a time would break alert <= action
    second.write_text("quantity,level,value_mm\nsettlement,alert,25\nsettlement,alarm,40\n")
    assert cli("site", "thresholds", "mitt", "--file", str(first), "--db", url).exit_code == 0
    res = cli("site", "threshold", "mitt", "settlement", "alert", "25", "--db", url)
    assert isinstance(res.exception, LongprofileError) and "must grow" in str(res.exception)
    assert cli("site", "thresholds", "mitt", "--file", str(second), "--db", url, "--actor", "eve").exit_code == 0
    show = json.loads(cli("site", "show", "mitt", "--db", url).stdout)
    assert show["thresholds"] == {"settlement.alert": 0.025, "settlement.alarm": 0.04}
    audit = json.loads(cli("site", "audit", "mitt", "--db", url).stdout)
    assert sum(a["actor"] == "eve" and a["entity"] == "threshold" for a in audit) == 4  # 2 changed, 2 removed
    second.write_text("quantity,level,value_mm\nsettlement,alert,30\nsettlement,alarm,20\n")
    res = cli("site", "thresholds", "mitt", "--file", str(second), "--db", url)
    assert isinstance(res.exception, LongprofileError) and "must grow" in str(res.exception)
    assert json.loads(cli("site", "show", "mitt", "--db", url).stdout)["thresholds"]["settlement.alert"] == 0.025


def test_site_tables_are_read_as_rail_settle_reads_them(cli, tmp_path):
    # declared units and letter case, as `rail settle` (io.read_rail_table): before 2026-12-06 `rail site` refused
    # them ("needs sensor_id and x_m", "a readings table has exactly ...") while `rail settle` read them
    import numpy as np

    syn, r = synthetic()
    canon, other = f"sqlite:///{tmp_path}/a.db", f"sqlite:///{tmp_path}/b.db"
    syn.sensors.to_csv(tmp_path / "s.csv", index=False)
    syn.survey.to_csv(tmp_path / "v.csv", index=False)
    r.to_csv(tmp_path / "r.csv", index=False)
    syn.sensors.assign(x_mm=1e3 * syn.sensors["x_m"]).drop(columns=["x_m"]).rename(columns=str.upper).to_csv(
        tmp_path / "s2.csv", index=False)
    syn.survey.rename(columns={"x_m": "x [ft]", "z_m": "Z_M"}).assign(**{"x [ft]": syn.survey["x_m"] / 0.3048}).to_csv(
        tmp_path / "v2.csv", index=False)
    r.assign(angle_rad=np.deg2rad(r["angle_deg"])).drop(columns=["angle_deg"]).to_csv(tmp_path / "r2.csv", index=False)
    shows = []
    for url, (s, v, rr) in ((canon, ("s", "v", "r")), (other, ("s2", "v2", "r2"))):
        assert cli("site", "create", "mitt", "--db", url, "--clock", "data").exit_code == 0
        for cmd, name in (("sensors", s), ("survey", v), ("ingest", rr)):
            out = cli("site", cmd, "mitt", "--file", str(tmp_path / f"{name}.csv"), "--db", url)
            assert out.exit_code == 0, (cmd, out.output, out.exception)
            if cmd == "ingest":
                assert json.loads(out.stdout)["accepted"] == len(r)
        assert json.loads(cli("site", "recompute", "mitt", "--db", url).stdout)["status"] == "ok"
        shows.append(json.loads(cli("site", "show", "mitt", "--db", url).stdout))
    a, b = ([(s["sensor_id"], s["x_m"]) for s in show["sensors"]] for show in shows)
    assert [i for i, _ in a] == [i for i, _ in b]
    np.testing.assert_allclose([x for _, x in a], [x for _, x in b], rtol=1e-12)
