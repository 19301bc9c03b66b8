"""Bad input over every file-reading command (issue 13, part 2): one clear line, exit 2, nothing lost.

Each case takes a valid input of a command, breaks it the way users' files are broken (the classes of issue 13:
absurd values, a header only, unsorted / duplicate / descending keys, decimal commas in a comma-separated file, a
spreadsheet export with semicolons and decimal commas, a truncated last row, millimetres under a metre column, time in
ms, angles in radians or degrees where the other is expected, text in a number, an empty or binary file, a missing
column) and runs the command in process. The
outcome is classified:

* ``clear``     -- exit code 2, exactly one ``error:`` line, no traceback, no output written, inputs unchanged;
* ``traceback`` -- an exception escaped the CLI;
* ``read``      -- exit 0 on an input that only looks broken and has one reading (:data:`READ`);
* ``silent``    -- exit 0: a result was written from a broken input;
* ``data-loss`` -- an input file changed;
* ``unclear``   -- anything else (another exit code, several error lines, a partial output).

Every case must be ``clear``. The positions of the broken cell are drawn at random per case (seeded by the case's
name: reproducible), so the suite does not test one lucky row. ``python -m tests.cli.test_bad_input_fuzz`` prints
the table of outcomes (the counts quoted in the issue note).
"""

from __future__ import annotations

import hashlib
import io
import random
import shutil
import sys
import traceback
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd
import pytest

from longprofile.cli.app import main

# ---- valid inputs, made once ---------------------------------------------------------------------------------


def make_inputs(folder: Path) -> Path:
    """Small valid inputs of every command under ``folder`` (the library's own simulators)."""
    folder.mkdir(parents=True, exist_ok=True)
    run = [
        ["road", "simulate", "--road-class", "C", "--length", "200", "--seed", "1", "-o", str(folder / "rec.csv")],
        ["road", "reconstruct", str(folder / "rec.csv"), "-o", str(folder / "profile.csv")],
        ["vehicle", "simulate", "--scenario", "hill", "--duration", "3", "-o", str(folder / "log.csv")],
        # channel unit checks need a drive that turns and brakes (a 3 s hill climb excites none of them)
        ["vehicle", "simulate", "--scenario", "paper", "--duration", "10", "-o", str(folder / "plog.csv")],
        ["vehicle", "vertical", "simulate", "--config", "3", "--road-class", "C", "--speed", "20", "--duration", "2",
         "-o", str(folder / "vlog.csv")],
        ["vehicle", "vertical", "simulate", "--config", "2", "--road-class", "C", "--speed", "20", "--duration", "2",
         "-o", str(folder / "vlog2.csv")],
        ["rail", "simulate", "--preset", "mittersheim-like", "--days", "6", "-o", str(folder / "site")],
        ["road", "simulate", "--profile", "crenels", "--length", "120", "-o", str(folder / "bench.csv")],
        # the reference of `road compare`: another recording of the same road (new noise), reconstructed (the
        # profile itself again is refused since session 39)
        ["road", "simulate", "--road-class", "C", "--length", "200", "--road-seed", "1", "--seed", "2", "-o",
         str(folder / "rec2.csv")],
        ["road", "reconstruct", str(folder / "rec2.csv"), "-o", str(folder / "ref.csv")],
    ]
    for argv in run:
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
            assert main(argv) == 0, argv
    # the cases edit profile.csv as a spreadsheet would, its header on line 1: the `#` provenance lines `road
    # reconstruct` writes before it (session 39) are left out here
    profile = folder / "profile.csv"
    profile.write_text("".join(ln for ln in profile.read_text().splitlines(True) if not ln.startswith("#")))
    t = np.arange(2000) * 1e-3
    pd.DataFrame(dict(time=t, x=np.sin(2 * np.pi * 2 * t))).to_csv(folder / "sig.csv", index=False)
    from longprofile.vehicle import default_vehicle

    (folder / "car.toml").write_text(default_vehicle().to_toml())
    (folder / "localized.toml").write_text("[localized]\nthreshold = 20\n")  # the valid profile peaks at 13.6 m/km
    return folder


# ---- commands: argv on a folder holding the (possibly broken) inputs ----------------------------------------


@dataclass(frozen=True)
class Command:
    name: str
    target: str                      # the input file a case breaks (relative to the folder)
    argv: Callable[[Path], list]     # folder -> argv (outputs under folder / "out*")
    key: str                         # the column that must increase (station or time)
    value: str                       # a physical value column
    metre: str | None = None         # a column in metres (for the mm-under-m case)
    time: str | None = None          # a column in seconds (for the ms case)
    radian: str | None = None        # a column in radians (for the degrees case)
    accel: tuple = ()                # columns in m/s^2 (for the accelerations-in-g case)
    as_is: bool = False              # the command line itself is wrong for the (unchanged) input


def _settle(d: Path) -> list:
    return ["rail", "settle", "--sensors", str(d / "site/sensors.csv"), "--readings", str(d / "site/readings.csv"),
            "--survey", str(d / "site/survey.csv"), "-o", str(d / "out.csv")]


COMMANDS = [
    Command("road iri", "profile.csv", lambda d: ["road", "iri", str(d / "profile.csv"), "-o", str(d / "out.csv")],
            key="distance_m", value="elevation_m", metre="elevation_m"),
    # session 41: ProVAL's other analyses on the command line
    *[Command(f"road {name}", "profile.csv", lambda d, name=name: ["road", name, str(d / "profile.csv"), "-o",
                                                                   str(d / "out.csv")],
              key="distance_m", value="elevation_m", metre="elevation_m")
      for name in ("ride-number", "straightedge", "profile-index", "faulting")],
    Command("road reconstruct", "rec.csv",
            lambda d: ["road", "reconstruct", str(d / "rec.csv"), "-o", str(d / "out.csv")],
            key="distance_m", value="apl_m", metre="apl_m"),
    Command("road report", "profile.csv", lambda d: ["road", "report", str(d / "profile.csv"), "-o", str(d / "out")],
            key="distance_m", value="elevation_m", metre="elevation_m"),
    Command("road convert", "profile.csv",
            lambda d: ["road", "convert", str(d / "profile.csv"), str(d / "out.erd")],
            key="distance_m", value="elevation_m", metre="elevation_m"),
    Command("road acceptance", "profile.csv",
            lambda d: ["road", "acceptance", str(d / "profile.csv"), "-o", str(d / "out")],
            key="distance_m", value="elevation_m", metre="elevation_m"),
    Command("road compare (a run)", "profile.csv",
            lambda d: ["road", "compare", str(d / "ref.csv"), str(d / "profile.csv"), "-o", str(d / "out")],
            key="distance_m", value="elevation_m", metre="elevation_m"),
    Command("differentiate", "sig.csv",
            lambda d: ["differentiate", str(d / "sig.csv"), "--column", "x", "--dt", "0.001", "--window", "45",
                       "-o", str(d / "out.csv")],
            key="time", value="x", time="time"),
    Command("vehicle slope", "log.csv", lambda d: ["vehicle", "slope", str(d / "log.csv"), "-o", str(d / "out.csv")],
            key="time", value="wheel_speed_fl", time="time"),
    Command("vehicle vertical estimate", "vlog.csv",
            lambda d: ["vehicle", "vertical", "estimate", str(d / "vlog.csv"), "--config", "3", "-o", str(d / "out.csv")],
            key="time", value="dz21_FL", metre="dz21_FL", time="time"),
    # session 41 (issue 13 §2): body accelerometers in g, a deflection sensor of half gain (configuration 2)
    Command("vehicle vertical estimate (config 2)", "vlog2.csv",
            lambda d: ["vehicle", "vertical", "estimate", str(d / "vlog2.csv"), "--config", "2", "-o",
                       str(d / "out.csv")],
            key="time", value="dz21_FL", accel=tuple(f"body_accel_{c}" for c in ("FL", "FR", "RL", "RR"))),
    Command("road acceptance (localized roughness)", "profile.csv",
            lambda d: ["road", "acceptance", str(d / "profile.csv"), "--spec", str(d / "localized.toml"), "-o",
                       str(d / "out")],
            key="distance_m", value="elevation_m"),
    *[Command(f"differentiate {' '.join(extra)} (a window spanning the 2 Hz sine)", "sig.csv",
              lambda d, extra=extra: ["differentiate", str(d / "sig.csv"), "--column", "x", "--dt", "0.001", *extra,
                                      "-o", str(d / "out.csv")],
              key="time", value="x", as_is=True)
      for extra in (("-w", "1000", "-d", "2"), ("-w", "1000", "-d", "2", "--order", "2"))],
    Command("rail settle (readings)", "site/readings.csv",
            lambda d: ["rail", "settle", "--sensors", str(d / "site/sensors.csv"), "--readings",
                       str(d / "site/readings.csv"), "--survey", str(d / "site/survey.csv"), "-o", str(d / "out.csv")],
            key="timestamp", value="angle_deg"),
    Command("rail settle (survey)", "site/survey.csv", _settle, key="x_m", value="z_m", metre="x_m"),
    Command("rail settle (survey z)", "site/survey.csv", _settle, key="x_m", value="z_m", metre="z_m"),
    Command("rail settle --angle-unit rad on degrees", "site/readings.csv",
            lambda d: [*_settle(d), "--angle-unit", "rad"], key="timestamp", value="angle_deg", as_is=True),
    Command("vehicle slope (steering, accelerations)", "plog.csv",
            lambda d: ["vehicle", "slope", str(d / "plog.csv"), "-o", str(d / "out.csv")],
            key="time", value="steering_angle", radian="steering_angle", accel=("accel_x", "accel_y")),
    Command("vehicle slope --vehicle", "car.toml",
            lambda d: ["vehicle", "slope", str(d / "log.csv"), "--vehicle", str(d / "car.toml"), "-o", str(d / "out.csv")],
            key="", value="mass"),
    Command("road identify", "bench.csv",
            lambda d: ["road", "identify", "--input", str(d / "bench.csv"), "--input-column", "true_m", "--output",
                       str(d / "bench.csv"), "--output-column", "apl_m", "-o", str(d / "out.json")],
            key="distance_m", value="apl_m"),
    Command("road convert onto a hard link of its input", "profile.csv",
            lambda d: ["road", "convert", str(d / "profile.csv"), str(d / "link.csv"), "--overwrite"],
            key="distance_m", value="elevation_m", as_is=True),
    # session 39 (a track engineer's probe): the thresholds file, and options written the way users write them
    Command("rail settle --thresholds", "site/thresholds.csv",
            lambda d: [*_settle(d), "--thresholds", str(d / "site/thresholds.csv")], key="", value="value_mm"),
    Command("rail settle --quiet-day 08/12/2019 (day/month)", "site/readings.csv",
            lambda d: [*_settle(d), "--quiet-day", "08/12/2019"], key="timestamp", value="angle_deg", as_is=True),
    Command("rail settle --quiet-day outside the record", "site/readings.csv",
            lambda d: [*_settle(d), "--quiet-day", "2018-01-01"], key="timestamp", value="angle_deg", as_is=True),
    Command("rail settle --alarm-probability 50 (a percentage)", "site/readings.csv",
            lambda d: [*_settle(d), "--alarm-probability", "50"], key="timestamp", value="angle_deg", as_is=True),
    Command("rail settle --settlement-threshold-mm 0.01 (metres as mm)", "site/readings.csv",
            lambda d: [*_settle(d), "--settlement-threshold-mm", "0.01"], key="timestamp", value="angle_deg",
            as_is=True),
]


# ---- ways to break a file ------------------------------------------------------------------------------------


def _rows(text: str) -> tuple[str, list[str]]:
    lines = text.splitlines()
    return lines[0], [ln for ln in lines[1:] if ln.strip()]


def _frame(path: Path) -> pd.DataFrame:
    return pd.read_csv(path, dtype=str, keep_default_na=False)


def _save(frame: pd.DataFrame, path: Path) -> None:
    frame.to_csv(path, index=False)


def _pick(rng: random.Random, n: int) -> int:
    return rng.randrange(max(1, n // 10), max(2, n - n // 10))


def huge_value(path, cmd, rng):
    f = _frame(path)
    f.loc[_pick(rng, len(f)), cmd.value] = rng.choice(["1e300", "-1e300", "1e30"])
    _save(f, path)


def text_in_a_number(path, cmd, rng):
    f = _frame(path)
    f.loc[_pick(rng, len(f)), cmd.value] = rng.choice(["abc", "1.2.3", "#N/A!"])
    _save(f, path)


def header_only(path, cmd, rng):
    head, _ = _rows(path.read_text())
    path.write_text(head + "\n")


def empty_file(path, cmd, rng):
    path.write_bytes(b"")


def binary_garbage(path, cmd, rng):
    path.write_bytes(bytes(rng.randrange(256) for _ in range(4096)))


def missing_column(path, cmd, rng):
    f = _frame(path)
    _save(f.drop(columns=[cmd.value]), path)


def swapped_rows(path, cmd, rng):
    f = _frame(path)
    i = _pick(rng, len(f) - 1)
    j = i + rng.randrange(1, 4)
    f.iloc[[i, j]] = f.iloc[[j, i]].to_numpy()
    _save(f, path)


def duplicate_row(path, cmd, rng):
    f = _frame(path)
    i = _pick(rng, len(f))
    _save(pd.concat([f.iloc[: i + 1], f.iloc[i: i + 1], f.iloc[i + 1:]]), path)


def descending(path, cmd, rng):
    _save(_frame(path).iloc[::-1], path)


def decimal_commas(path, cmd, rng):
    head, rows = _rows(path.read_text())
    cols = head.split(",")
    k = cols.index(cmd.value)
    for i in sorted(rng.sample(range(len(rows)), min(5, len(rows)))):
        cells = rows[i].split(",")
        if "." in cells[k]:
            cells[k] = cells[k].replace(".", ",", 1)  # 0.0123 -> 0,0123: one more field in a comma-separated file
            rows[i] = ",".join(cells)
    path.write_text("\n".join([head, *rows]) + "\n")


def semicolon_export(path, cmd, rng):
    """The table as a spreadsheet in a decimal-comma locale saves it: ';' between fields, ',' in every number."""
    head, rows = _rows(path.read_text())
    lines = [head.replace(",", ";"), *(r.replace(",", ";").replace(".", ",") for r in rows)]
    path.write_text("\n".join(lines) + "\n")


def truncated_last_row(path, cmd, rng):
    text = path.read_text().rstrip("\n")
    last = text.rsplit("\n", 1)[1]
    cut = rng.randrange(1, max(2, last.rfind(",")))
    path.write_text(text[: len(text) - len(last) + cut])


def millimetres_under_metres(path, cmd, rng):
    f = _frame(path)
    f[cmd.metre] = (pd.to_numeric(f[cmd.metre]) * 1000.0).map(repr)
    _save(f, path)


def time_in_milliseconds(path, cmd, rng):
    f = _frame(path)
    f[cmd.time] = (pd.to_numeric(f[cmd.time]) * 1000.0).map(repr)
    _save(f, path)


def degrees_for_radians(path, cmd, rng):
    f = _frame(path)
    f[cmd.radian] = np.degrees(pd.to_numeric(f[cmd.radian])).map(repr)
    _save(f, path)


def accelerations_in_g(path, cmd, rng):
    f = _frame(path)
    for c in cmd.accel:
        f[c] = (pd.to_numeric(f[c]) / 9.80665).map(repr)
    _save(f, path)


def huge_toml_value(path, cmd, rng):
    import re

    text, n = re.subn(rf"(?m)^{cmd.value} = .*$", f"{cmd.value} = {rng.choice(['1e300', '-1500.0', 'nan'])}",
                      path.read_text(), count=1)
    assert n == 1, f"no {cmd.value} in {path}"
    path.write_text(text)


def as_is(path, cmd, rng):
    if cmd.name.endswith("hard link of its input"):
        import os

        os.link(path, path.parent / "link.csv")


def angles_times_1000(path, cmd, rng):
    f = _frame(path)
    f[cmd.value] = (pd.to_numeric(f[cmd.value]) * 1000.0).map(repr)
    _save(f, path)


def temperature_bus_down(path, cmd, rng):
    """A day when no sensor sent a temperature (the loggers' temperature bus down): nothing to fill from; that day is
    left out with a warning (session 34: a traceback)."""
    f = _frame(path)
    day = f["timestamp"].str[:10]
    f.loc[day == sorted(day.unique())[rng.randrange(1, day.nunique() - 1)], "temperature_c"] = ""
    _save(f, path)


def nan_markers(path, cmd, rng):
    """One sensor's temperature channel failed, written as a Campbell Scientific logger writes it ("NAN"): an empty
    temperature, filled from the neighbours with a warning (session 34: the whole file was refused)."""
    f = _frame(path)
    sid = sorted(f["sensor_id"].unique())[rng.randrange(1, f["sensor_id"].nunique() - 1)]
    f.loc[f["sensor_id"] == sid, "temperature_c"] = "NAN"
    _save(f, path)


def no_temperature(path, cmd, rng):
    """A logger that records angles only: the temperature column is there and empty in every row (session 34: this
    ended in "too few daily slope changes to estimate their noise; pass sigma", which named neither the cause nor
    the way out)."""
    f = _frame(path)
    f["temperature_c"] = ""
    _save(f, path)


def rows_missing(path, cmd, rng):
    """A stretch of rows cut out (a vendor's software removing a dropout; session 35: a profile's IRI over the gap was
    that of a straight line, 0.00 m/km, without a word)."""
    f = _frame(path)
    i = _pick(rng, len(f) - len(f) // 5)
    _save(pd.concat([f.iloc[:i], f.iloc[i + len(f) // 10:]]), path)


def not_utf8(path, cmd, rng):
    """A Windows spreadsheet's export: cp1252 text (an accent in the header)."""
    text = path.read_text(encoding="utf-8")
    head, _, body = text.partition("\n")
    path.write_bytes((head.replace(cmd.value, cmd.value + "_\u00e9", 1) + "\n" + body).encode("cp1252"))


def empty_id(path, cmd, rng):
    f = _frame(path)
    f.loc[_pick(rng, len(f)), "sensor_id"] = ""
    _save(f, path)


def offsets_on_some_times(path, cmd, rng):
    """A logger's firmware update: its times carry "Z" from some row on, the earlier ones none."""
    f = _frame(path)
    f = f.sort_values("timestamp", kind="stable")
    k = _pick(rng, len(f))
    f.iloc[k:, f.columns.get_loc("timestamp")] = f["timestamp"].iloc[k:].str.replace(" ", "T") + "Z"
    _save(f, path)


def a_stray_reading_years_before(path, cmd, rng):
    """One reading of a logger whose clock reset to 2000-01-01 (session 35: a traceback)."""
    f = _frame(path)
    f.loc[_pick(rng, len(f)), "timestamp"] = "2000-01-01 00:00:00"
    _save(f, path)


def a_dropout_coded_9999(path, cmd, rng):
    """A profiler's dropout written as the logger's missing-value code over 20 samples (session 36, a probe: the
    IRI read it as pavement, 140.7 m/km)."""
    f = _frame(path)
    k = _pick(rng, len(f) - 20)
    f.loc[k:k + 19, cmd.value] = "-9999"
    _save(f, path)


def a_blank_line(path, cmd, rng):
    """An empty line among the data (a logger's empty record; session 39, a probe: "distance must be finite; 1
    non-finite value(s), first at index (5000,)", no file, no line)."""
    head, rows = _rows(path.read_text())
    i = _pick(rng, len(rows))
    path.write_text("\n".join([head, *rows[:i], "", *rows[i:]]) + "\n")


def a_stop(path, cmd, rng):
    """The trailer stopped: one station logged on 20 rows (session 39, a probe: "distance[20001] = 1000.0 <=
    distance[20000] = 1000.0", no line, no cause)."""
    f = _frame(path)
    i = _pick(rng, len(f))
    _save(pd.concat([f.iloc[: i + 1], *[f.iloc[i: i + 1]] * 20, f.iloc[i + 1:]]), path)


def km_rounded(path, cmd, rng):
    """Stations exported in km to 4 decimals (0.1 m, coarser than the 0.05 m samples; session 39, a probe)."""
    f = _frame(path)
    f[cmd.key] = (12.3 + pd.to_numeric(f[cmd.key]) / 1000).round(4).map(repr)
    _save(f.rename(columns={cmd.key: "chainage_km"}), path)


def metres_under_a_mm_label(path, cmd, rng):
    """An APL signal in metres under an mm label (session 39, a probe: a profile 1000 times too small, q 2.4e-12)."""
    _save(_frame(path).rename(columns={cmd.metre: cmd.metre[:-2] + "_mm"}), path)


def micrometres(path, cmd, rng):
    """The value column in micrometres, a unit the package does not convert (session 39, a probe: read as metres)."""
    f = _frame(path)
    f[cmd.value] = (pd.to_numeric(f[cmd.value]) * 1e6).map(repr)
    _save(f.rename(columns={cmd.value: cmd.value.rsplit("_", 1)[0] + "_um"}), path)


def a_vendor_station_name(path, cmd, rng):
    """The station column named as a vendor's software does (session 39, a probe: "missing column(s)
    ['distance_m']", no names it takes)."""
    name = rng.choice(["PR_m", "DIST (m)", "abscisse_m", "PK [km]"])
    _save(_frame(path).rename(columns={cmd.key: name}), path)


def a_dead_sensor(path, cmd, rng):
    """Every elevation 0 (a dead height sensor; session 36, a probe: paid the acceptance bonus on every lot)."""
    f = _frame(path)
    f[cmd.value] = "0"
    _save(f, path)


def gravity_in_the_accelerometers(path, cmd, rng):
    """The vertical accelerometers logged with gravity (+1 g: many IMUs do; session 38, a probe: body velocity 1-3 m/s
    off without a message)."""
    f = _frame(path)
    for c in [c for c in f.columns if c.lower().startswith(("wheel_accel", "body_accel"))]:
        f[c] = (pd.to_numeric(f[c]) + 9.80665).map(repr)
    _save(f, path)


def a_dead_wheel_speed_sensor(path, cmd, rng):
    """One wheel speed channel at 0 (session 38, a probe: blamed on staggered tyres)."""
    f = _frame(path)
    f[rng.choice([c for c in f.columns if c.startswith("wheel_speed_")])] = "0"
    _save(f, path)


def a_time_reset(path, cmd, rng):
    """The logger's clock restarts from 0 mid-file (session 38, a probe: "must be strictly increasing", no row)."""
    f = _frame(path)
    t = pd.to_numeric(f[cmd.time]).to_numpy()
    k = 2 + _pick(rng, len(t) - 4)
    f[cmd.time] = np.r_[t[:k], t[k:] - t[k]]
    f[cmd.time] = f[cmd.time].map(repr)
    _save(f, path)


def a_car_value_in_another_unit(path, cmd, rng):
    """A car-file value in another unit: mass in tonnes, cg height in mm, cornering stiffness per degree (session 38,
    a probe: accepted silently, V_y band coverage 13-17 %)."""
    import re

    key, scale = rng.choice([("mass", 1e-3), ("cg_height", 1e3), ("cornering_stiffness", np.pi / 180)])
    text, n = re.subn(rf"(?m)^{key} = ([0-9.eE+-]+)", lambda m: f"{key} = {float(m.group(1)) * scale!r}",
                      path.read_text(), count=1)
    assert n == 1, f"no {key} in {path}"
    path.write_text(text)


def thresholds_in_metres(path, cmd, rng):
    """Settlement thresholds written in metres under value_mm (0.010 for 10 mm; session 39, a probe: 4540 alarms, no
    word; a rate or a twist of a few mm in metres fell below the old floor of 0.01 mm and was refused already)."""
    f = _frame(path)
    f = f[f["quantity"] == "settlement"]
    f[cmd.value] = (pd.to_numeric(f[cmd.value]) / 1000.0).map(repr)
    _save(f, path)


def an_unknown_angle_unit(path, cmd, rng):
    """An angle column declaring a unit the reader does not convert (gon; session 39: arcsec, mm/m, µrad and % were
    refused as a missing angle_deg column, now read; an unknown one is named)."""
    _save(_frame(path).rename(columns={"angle_deg": "angle (gon)"}), path)


def spring_local_times(path, cmd, rng):
    """Loggers in local time (Europe/Paris) across the spring clock change, no --timezone (session 39, a probe:
    accepted silently while the autumn change was refused)."""
    f = _frame(path)
    t = pd.to_datetime(f["timestamp"])
    t = t + (pd.Timestamp("2020-03-27") - t.min().normalize())
    local = t.dt.tz_localize("UTC").dt.tz_convert("Europe/Paris").dt.tz_localize(None)
    f["timestamp"] = local.dt.strftime("%Y-%m-%d %H:%M:%S")
    _save(f, path)


def a_conflicting_duplicate(path, cmd, rng):
    """A reading repeated at the same sensor and time with another angle (exact repeats are dropped with a warning)."""
    f = _frame(path)
    i = _pick(rng, len(f))
    row = f.iloc[i: i + 1].copy()
    row[cmd.value] = (pd.to_numeric(row[cmd.value]) + 0.01).map(repr)
    _save(pd.concat([f.iloc[: i + 1], row, f.iloc[i + 1:]]), path)


def a_deflection_sensor_of_half_gain(path, cmd, rng):
    """One suspension deflection channel reading half the travel (a wrong gain in its calibration; session 40's probe:
    not detected)."""
    f = _frame(path)
    f["dz21_FL"] = (0.5 * pd.to_numeric(f["dz21_FL"])).map(repr)
    _save(f, path)


def a_bump_at_the_end(path, cmd, rng):
    """A 40 mm bump 2.5 m before the profile's end, in the stretch no localized window is centred on (session 40's
    probe: reported as a short defect ending at the last window, nothing said)."""
    f = _frame(path)
    x = pd.to_numeric(f[cmd.key]).to_numpy()
    z = pd.to_numeric(f[cmd.value]).to_numpy() + 0.04 * np.exp(-0.5 * ((x - (x[-1] - 2.5)) / 0.3) ** 2)
    f[cmd.value] = pd.Series(z).map(repr)
    _save(f, path)


def no_temperature_column(path, cmd, rng):
    """An angles-only logger's export without --thermal none (the refusal names --thermal none; with it, it runs)."""
    _save(_frame(path).drop(columns=["temperature_c"]), path)


#: mutation -> applies to a command when the predicate holds
def _table(c: Command) -> bool:
    return not c.as_is and not c.target.endswith(".toml")


def _general(c: Command) -> bool:
    return _table(c) and not c.name.startswith(("rail settle (survey z)", "vehicle slope (steering",
                                                 "rail settle --thresholds", "vehicle vertical estimate (config 2)",
                                                 "road acceptance (localized roughness)"))


MUTATIONS: dict[str, tuple[Callable, Callable[[Command], bool]]] = {
    "huge value": (huge_value, _general),
    "text in a number": (text_in_a_number, _general),
    "header only": (header_only, _general),
    "empty file": (empty_file, lambda c: _general(c) or c.target.endswith(".toml")),
    "binary garbage": (binary_garbage, lambda c: _general(c) or c.target.endswith(".toml")),
    "missing column": (missing_column, _general),
    "swapped rows": (swapped_rows, lambda c: _general(c) and not c.name.startswith("rail settle (readings)")),
    "duplicate row": (duplicate_row, _general),
    "descending keys": (descending, lambda c: _general(c) and not c.name.startswith("rail settle (readings)")),
    "decimal commas": (decimal_commas, _general),
    "semicolon export": (semicolon_export, _general),
    "truncated last row": (truncated_last_row, _general),
    "mm under a metre column": (millimetres_under_metres, lambda c: _table(c) and c.metre is not None),
    "time in ms": (time_in_milliseconds, lambda c: _table(c) and c.time is not None),
    "angles x1000": (angles_times_1000, lambda c: c.name == "rail settle (readings)"),
    "temperature column empty": (no_temperature, lambda c: c.name == "rail settle (readings)"),
    "a day without any temperature": (temperature_bus_down, lambda c: c.name == "rail settle (readings)"),
    "a channel written NAN": (nan_markers, lambda c: c.name == "rail settle (readings)"),
    "degrees for radians": (degrees_for_radians, lambda c: c.radian is not None),
    "accelerations in g": (accelerations_in_g, lambda c: bool(c.accel)),
    "absurd value in the file": (huge_toml_value, lambda c: c.target.endswith(".toml")),
    "(the input as is)": (as_is, lambda c: c.as_is),
    "rows missing (a gap)": (rows_missing, lambda c: _general(c) and c.key in ("distance_m", "time")
                             and c.name != "road convert"),
    "not UTF-8 (cp1252)": (not_utf8, _general),
    "an empty sensor id": (empty_id, lambda c: c.name == "rail settle (readings)"),
    "times with and without a UTC offset": (offsets_on_some_times, lambda c: c.name == "rail settle (readings)"),
    "a stray reading years before": (a_stray_reading_years_before, lambda c: c.name == "rail settle (readings)"),
    "a dropout coded -9999": (a_dropout_coded_9999, lambda c: _general(c) and c.key == "distance_m"),
    "a blank line among the data": (a_blank_line, lambda c: _general(c) and c.key == "distance_m"),
    "a stop (one station on 20 rows)": (a_stop, lambda c: _general(c) and c.key == "distance_m"),
    "stations in km to 4 decimals": (km_rounded, lambda c: _general(c) and c.key == "distance_m"),
    "metres under a mm label": (metres_under_a_mm_label, lambda c: c.name == "road reconstruct"),
    "micrometres": (micrometres, lambda c: _general(c) and c.key == "distance_m"),
    "a vendor's station name": (a_vendor_station_name,
                                lambda c: _general(c) and c.key == "distance_m" and c.name != "road identify"),
    "a dead height sensor": (a_dead_sensor, lambda c: c.name in ("road acceptance", "road compare (a run)")),
    "gravity in the accelerometers": (gravity_in_the_accelerometers, lambda c: c.name == "vehicle vertical estimate"),
    "a dead wheel speed sensor": (a_dead_wheel_speed_sensor, lambda c: _table(c) and c.name.startswith("vehicle slope")),
    "a time reset": (a_time_reset, lambda c: _table(c) and c.time is not None),
    "a car value in another unit": (a_car_value_in_another_unit, lambda c: c.target.endswith(".toml")),
    "thresholds in metres under value_mm": (thresholds_in_metres, lambda c: c.name == "rail settle --thresholds"),
    "an angle unit not known": (an_unknown_angle_unit, lambda c: c.name == "rail settle (readings)"),
    "local times across the spring change": (spring_local_times, lambda c: c.name == "rail settle (readings)"),
    "a reading repeated with another value": (a_conflicting_duplicate, lambda c: c.name == "rail settle (readings)"),
    "no temperature column": (no_temperature_column, lambda c: c.name == "rail settle (readings)"),
    "a deflection sensor of half gain": (a_deflection_sensor_of_half_gain,
                                         lambda c: c.name.startswith("vehicle vertical estimate")),
    "a bump at the profile's end": (a_bump_at_the_end, lambda c: c.name == "road acceptance (localized roughness)"),
}

CASES = [(c, m) for c in COMMANDS for m, (_, applies) in MUTATIONS.items() if applies(c)]

#: The commands of ProVAL's other analyses (session 41): they read profiles as `road iri` does.
_PROVAL = ("road ride-number", "road straightedge", "road profile-index", "road faulting")

#: Cases whose input has one right reading, which the command takes with a warning instead of refusing it: a rail
#: survey is a set of (x, z) points, so its rows in another order (whole rows moved) give the same profile; the
#: warning asks to check for a mistyped station. A day without any temperature is left out, with a warning; a
#: channel written "NAN" (a logger's marker) is an empty temperature, filled with a warning. The outcome must then be "warned": exit 0 and this phrase in a
#: ``warning:`` line.
WARNED = {("rail settle (survey)", "swapped rows"): "not in order of x_m",
          ("rail settle (survey)", "descending keys"): "not in order of x_m",
          ("rail settle (readings)", "a day without any temperature"): "without a usable daily angle on any sensor",
          ("rail settle (readings)", "a channel written NAN"): "had an angle but no usable temperature",
          ("rail settle (readings)", "a stray reading years before"): "is the reference day",
          # a row repeated exactly is an overlapping download: dropped, counted in a warning (session 39)
          ("rail settle (readings)", "duplicate row"): "repeated exactly",
          # session 41: measured gains and a defect that may go on where nothing is assessed are warnings
          **{(name, "a deflection sensor of half gain"): "dz21_FL reads 0.5"
             for name in ("vehicle vertical estimate", "vehicle vertical estimate (config 2)")},
          ("road acceptance (localized roughness)", "a bump at the profile's end"): "runs up to the unassessed end",
          **{(f"differentiate {extra} (a window spanning the 2 Hz sine)", "(the input as is)"): "window too long"
             for extra in ("-w 1000 -d 2", "-w 1000 -d 2 --order 2")},
          # rows cut from an APL recording's grid are its missing samples, bridged (as empty cells are; session 39)
          ("road reconstruct", "rows missing (a gap)"): "absent from the",
          # a profile whose stations count down is a run driven against the stationing (a southbound lane): read
          # in the order of its rows, with a warning that names the other reading (session 40)
          **{(name, "descending keys"): "decrease (200 .. 0): a run driven against the stationing"
             for name in ("road iri", "road report", "road convert", "road acceptance", "road compare (a run)",
                          *_PROVAL)}}

#: Cases whose input only looks broken: a profile file separated by ';' with decimal commas and no point has one
#: reading, which the profile readers take (session 40; tests/io/test_profile_file_variants.py checks it reads
#: back bit-identical to the comma file). The outcome must be "read": exit 0.
READ = {(name, "semicolon export") for name in ("road iri", "road reconstruct", "road report", "road convert",
                                                 "road acceptance", "road compare (a run)", *_PROVAL)}


#: Mutations whose refusal must also name the broken file (session 39: an APL recording's stations were refused as
#: "distance must be finite; ... first at index (5000,)", with neither the file nor its line).
NAMES_THE_FILE = {"a blank line among the data", "a stop (one station on 20 rows)", "stations in km to 4 decimals",
                  "metres under a mm label", "micrometres", "a vendor's station name"}


# ---- running and classifying ---------------------------------------------------------------------------------


def _digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def run_case(valid: Path, work: Path, cmd: Command, mutation: str) -> tuple[str, str]:
    """Break ``cmd.target`` in a copy of ``valid`` and run the command: (outcome, what it printed)."""
    shutil.copytree(valid, work)
    rng = random.Random(f"{cmd.name}/{mutation}")
    MUTATIONS[mutation][0](work / cmd.target, cmd, rng)
    before = _digests(work)
    out, err = io.StringIO(), io.StringIO()
    try:
        with redirect_stdout(out), redirect_stderr(err):
            code = main(cmd.argv(work))
    except BaseException:  # noqa: BLE001 - anything escaping the CLI is the finding
        return "traceback", traceback.format_exc(limit=3)
    text = out.getvalue() + err.getvalue()
    after = _digests(work)
    changed = [k for k, v in before.items() if after.get(k) != v]
    written = sorted(set(after) - set(before))
    if changed:
        return "data-loss", f"changed inputs {changed}; {text}"
    if code == 0 and (cmd.name, mutation) in READ:
        return "read", text
    if code == 0:
        phrase = WARNED.get((cmd.name, mutation))
        warned = phrase is not None and any(ln.startswith("warning:") and phrase in ln for ln in text.splitlines())
        return ("warned" if warned else "silent"), text
    errors = [ln for ln in text.splitlines() if ln.startswith("error:")]
    named = mutation not in NAMES_THE_FILE or any(Path(cmd.target).name in ln for ln in text.splitlines()
                                                  if ln.startswith("error:"))
    if code == 2 and len(errors) == 1 and "Traceback" not in text and not written and named:
        return "clear", errors[0]
    return "unclear", f"exit {code}; written {written}; {text}"


@pytest.fixture(scope="module")
def valid_inputs(tmp_path_factory):
    return make_inputs(tmp_path_factory.mktemp("valid"))


@pytest.mark.parametrize(("cmd", "mutation"), CASES, ids=[f"{c.name}: {m}" for c, m in CASES])
def test_bad_input_is_one_clear_line_and_nothing_is_lost(cmd, mutation, valid_inputs, tmp_path):
    outcome, text = run_case(valid_inputs, tmp_path / "case", cmd, mutation)
    expected = "warned" if (cmd.name, mutation) in WARNED else "read" if (cmd.name, mutation) in READ else "clear"
    assert outcome == expected, f"{cmd.name} with {mutation}: {outcome}\n{text}"


@pytest.mark.parametrize("cmd", [c for c in COMMANDS if not c.as_is], ids=lambda c: c.name)
def test_every_command_runs_on_its_valid_input(cmd, valid_inputs, tmp_path):
    """Each case must fail for its broken input, not for its command line: on the unbroken input the command succeeds
    (the rail cases once wrote to an output without a file extension, so every one of them was "clear" for that)."""
    MUTATIONS["(none)"] = (lambda path, cmd, rng: None, lambda c: False)
    try:
        outcome, text = run_case(valid_inputs, tmp_path / "ok", cmd, "(none)")
    finally:
        del MUTATIONS["(none)"]
    assert outcome == "silent", f"{cmd.name} on its valid input: {outcome}\n{text}"  # exit 0


def test_the_classifier_sees_each_failure_kind(valid_inputs, tmp_path):
    """The harness itself can fail: a valid input is 'silent', a raising command a 'traceback'."""
    ok = Command("road iri", "profile.csv", COMMANDS[0].argv, key="distance_m", value="elevation_m")
    MUTATIONS["(none)"] = (lambda path, cmd, rng: None, lambda c: False)
    try:
        assert run_case(valid_inputs, tmp_path / "a", ok, "(none)")[0] == "silent"
        # a group without its command prints its help and fails, with no "error:" line (a mistyped option is one
        # clear line since session 37: tests/cli/test_app.py)
        boom = Command("boom", "profile.csv", lambda d: ["road"], key="distance_m", value="elevation_m")
        assert run_case(valid_inputs, tmp_path / "b", boom, "(none)")[0] == "unclear"
        loss = Command("loss", "profile.csv",  # a user's other file replaced on purpose (--overwrite)
                       lambda d: ["road", "convert", str(d / "profile.csv"), str(d / "sig.csv"), "--overwrite"],
                       key="distance_m", value="elevation_m")
        assert run_case(valid_inputs, tmp_path / "c", loss, "(none)")[0] == "data-loss"
    finally:
        del MUTATIONS["(none)"]


if __name__ == "__main__":  # the outcome table quoted in the issue note
    import tempfile
    from collections import Counter

    root = Path(tempfile.mkdtemp(prefix="fuzz-"))
    valid = make_inputs(root / "valid")
    counts: Counter = Counter()
    for i, (c, m) in enumerate(CASES):
        outcome, text = run_case(valid, root / f"case{i}", c, m)
        counts[outcome] += 1
        if outcome != ("warned" if (c.name, m) in WARNED else "read" if (c.name, m) in READ else "clear"):
            print(f"{outcome:10s} {c.name}: {m}: {' '.join(text.split())[:300]}")
    print(f"{len(CASES)} cases: " + ", ".join(f"{k} {counts[k]}" for k in ("clear", "warned", "read", "traceback",
                                                                          "silent", "data-loss", "unclear")))
    shutil.rmtree(root, ignore_errors=True)
    sys.exit(0 if counts["clear"] + counts["warned"] + counts["read"] == len(CASES)
             and counts["warned"] == len(WARNED) and counts["read"] == len(READ) else 1)
