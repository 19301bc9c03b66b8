"""``longprofile rail simulate | settle``: track settlement from sleeper inclinometers (paper 004)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ._common import (
    OVERWRITE,
    TABLE_SUFFIXES,
    check_output_folder,
    check_output_path,
    check_plot_path,
    console,
    progress,
)
from ._rail_events import EVENTS_OPTION, read_site_with_events

rail_app = typer.Typer(help="Rail track settlement from sleeper inclinometers, with confidence bands (paper 004).",
                       no_args_is_help=True)


def _example_thresholds():
    import pandas as pd

    return pd.DataFrame({"quantity": ["settlement", "settlement", "settlement", "rate", "twist"],
                         "level": ["alert", "action", "alarm", "alert", "alert"],
                         "value_mm": [10.0, 15.0, 20.0, 3.0, 5.0]})


@rail_app.command("simulate")
def simulate_command(
    output: Path = typer.Option(..., "--output", "-o", help="Folder for sensors.csv, readings.csv, survey.csv, "
                                                             "controls.csv (if any), truth.csv and thresholds.csv "
                                                             "(example graded alarm limits for rail settle "
                                                             "--thresholds)."),
    preset: str = typer.Option("mittersheim-like", "--preset", help="mittersheim-like or farebersviller-like."),
    seed: int = typer.Option(0, "--seed", min=0, help="Random seed."),
    sampling_minutes: float = typer.Option(10.0, "--sampling-minutes", help="Interval between readings, min."),
    days: int = typer.Option(None, "--days", help="Number of days (default: the preset's)."),
    fmt: str = typer.Option("csv", "--format", help="csv or parquet."),
    plot: Path = typer.Option(None, "--plot", help="Also draw the true settlement to this PNG."),
    overwrite: bool = OVERWRITE,
):
    """Simulate an inclinometer site with known settlement (ground truth in truth.csv)."""
    from ..errors import InputError
    from ..io import write_table
    from ..rail import simulate_site

    if fmt not in ("csv", "parquet"):
        raise InputError(f"--format must be csv or parquet; got {fmt!r}.")
    check_output_folder(output, overwrite=overwrite, what="--output",
                        hint="rail simulate writes a folder of tables and never replaces an existing file; choose "
                             f"a folder path, e.g. {Path(output).with_suffix('')}_site/.")
    png = check_plot_path(plot, overwrite=overwrite)
    site = simulate_site(preset, seed=seed, sampling_minutes=sampling_minutes, n_days=days)
    out = Path(output)
    written = [write_table(site.sensors, out / f"sensors.{fmt}"), write_table(site.readings, out / f"readings.{fmt}"),
               write_table(site.survey, out / f"survey.{fmt}")]
    if site.controls is not None:
        written.append(write_table(site.controls, out / f"controls.{fmt}"))
    written.append(write_table(site.truth_table(), out / f"truth.{fmt}"))
    # an example of graded limits (typical of track monitoring near works; not a standard): rail settle --thresholds
    written.append(write_table(_example_thresholds(), out / f"thresholds.{fmt}"))
    if plot is not None:
        from ..report import draw, plot_true_settlement

        draw(plot_true_settlement, site.truth, png)
    D, N = site.truth.settlement.shape
    console.print(f"simulated {preset}: {N} sensors, {D} days, {len(site.readings)} readings -> "
                  f"{', '.join(str(p) for p in written)}")


#: ``rail settle --timezone``.
TIMEZONE_HELP = ("IANA zone of the loggers' clocks (e.g. Europe/Paris) when the readings' times carry no UTC offset: "
                 "read as local times (the hour shown twice in autumn in each sensor's order). Default: such times "
                 "are UTC.")


#: ``rail settle --sigma-deg``'s help (a datasheet's ±0.05° was typed there: a user's probe, session 39).
_SIGMA_HELP = ("Std of the day-to-day change of a daily-median angle, deg (default: estimated from the data; about 8e-4 "
               "on the simulated presets). Not a datasheet accuracy (±0.05°) nor the paper's single-reading 5e-3: "
               "values outside 1e-5..1e-2, or 10 times from the data's own noise, are refused.")
#: ``rail settle --thresholds``'s help ("twist" named for what it is: a user's probe, session 39).
_THRESHOLDS_HELP = ("Graded thresholds table: quantity (settlement, rate, twist), level (alert, action, alarm), value_mm "
                    "(mm; mm/day for the rate; or value_mm_per_day for the rate rows), as the monitoring service "
                    "takes them. Without any threshold nothing is tested. 'twist' is the difference of neighbouring "
                    "sensors' changes over their own spacing, not EN 13848 twist (cross-level over a fixed base): no "
                    "standard twist limit applies to it.")


@rail_app.command("settle")
def settle_command(
    sensors: Path = typer.Option(..., "--sensors", help="Sensors table: sensor_id, x_m [, z_m] (CSV/Parquet)."),
    readings: Path = typer.Option(..., "--readings",
                                  help="Readings table: timestamp, sensor_id, angle_deg, temperature_c; or a "
                                       "logger's wide export, one column per sensor id (S01_angle_deg, "
                                       "S01_temperature_c, ...)."),
    survey: Path = typer.Option(None, "--survey", help="Initial survey: x_m, z_m (any grid covering the sensors)."),
    controls: Path = typer.Option(None, "--controls", help="Control surveys: date, x_m, z_m."),
    output: Path = typer.Option(..., "--output", "-o", help="Settlement table (.csv/.parquet), one row per day and "
                                                             "sensor, with 90 % bands and rates."),
    plot: Path = typer.Option(None, "--plot", help="Also draw settlement profiles with bands to this PNG."),
    report: Path = typer.Option(None, "--report", help="Also write an HTML report (profiles, bands, controls, "
                                                        "alarms, flagged sensors) into this folder."),
    thermal: str = typer.Option("auto", "--thermal",
                                help="auto (the lagged model where the readings show a thermal lag, else linear), "
                                     "linear (paper §3), lagged (first-order lag) or none."),
    sigma_deg: float = typer.Option(None, "--sigma-deg", help=_SIGMA_HELP),
    rigidity: Optional[float] = typer.Option(
        None, "--rigidity",
        help="Rigidity r of the settlement prior, m^-2 (the paper uses 1e-8). Default: prior and r fitted by "
             "maximum likelihood, which gives calibrated 90 % bands (docs/rail.md)."),
    sigma_z: float = typer.Option(1e-5, "--sigma-z", help="Std of the fixed-end anchors, m."),
    sigma_a: float = typer.Option(2e-3, "--sigma-a", help="Survey noise, m."),
    angle_unit: str = typer.Option("deg", "--angle-unit", help="Unit of a plain angle_deg column as given: deg or rad (a header that "
                                                              "declares its unit, angle_rad or 'angle (mrad)', is "
                                                              "converted; leave this out then)."),
    check_units: bool = typer.Option(True, "--check-units/--no-check-units",
                                     help="Refuse angles that look like radians, or like degrees declared as "
                                          "radians (a median beyond 10 deg from level), and a survey steeper than "
                                          "25 % (millimetres under z_m)."),
    temperature_fill: bool = typer.Option(True, "--temperature-fill/--no-temperature-fill",
                                          help="A reading with an angle but no temperature (a failed temperature "
                                               "channel), or one stuck at a value all day, takes the median "
                                               "temperature of its 4 nearest sensors in the same minute plus "
                                               "its own offset from them in the 7 days before; "
                                               "--no-temperature-fill leaves it out (docs/rail.md)."),
    timezone: str = typer.Option(None, "--timezone", help=TIMEZONE_HELP),
    exclude: list[str] = typer.Option([], "--exclude", help="Sensor id to exclude (repeatable)."),
    events: Path = EVENTS_OPTION,
    quiet_day: list[str] = typer.Option([], "--quiet-day", help="A day without works (YYYY-MM-DD, repeatable): "
                                                                   "the thermal fit then uses only these days."),
    no_health: bool = typer.Option(False, "--no-health-check", help="Only exclude dead sensors."),
    affine: bool = typer.Option(False, "--affine-correction", help="Apply the §5.2 affine correction (not robust)."),
    per_day: bool = typer.Option(False, "--per-day-model",
                                 help="Estimate each day on its own (docs/rail.md step 9; the live service's model "
                                      "above 40 000 sensor-days) instead of all days in one posterior (the default, "
                                      "step 10: sensor drift correlated over the days)."),
    thresholds: Path = typer.Option(None, "--thresholds", help=_THRESHOLDS_HELP),
    threshold_mm: float = typer.Option(None, "--settlement-threshold-mm", help="Alarm on |altitude change|, mm."),
    rate_mm: float = typer.Option(None, "--rate-threshold-mm-per-day", help="Alarm on |daily rate|, mm/day."),
    alarm_probability: float = typer.Option(0.5, "--alarm-probability", help="Report exceedance probabilities >= this."),
    n_monte_carlo: int = typer.Option(1000, "--monte-carlo", min=0, help="Posterior draws per day for the max settlement."),
    max_band: bool = typer.Option(False, "--max-settlement-band",
                                  help="Max settlement's 90 % interval from the simultaneous band (conservative; the "
                                       "default until 2026-12-06) instead of the one holding 98 % of the draws' "
                                       "maxima (docs/rail.md step 13)."),
    end_ambiguity: str = typer.Option("off", "--end-ambiguity",
                                      help="off or mixture. Where the evidence that the span's ends moved rests on "
                                           "sensors the health tests excluded (a step at a joint or a transition seen "
                                           "by one or two sensors): off keeps the bands of the fixed ends; mixture "
                                           "widens them to carry both readings (also on bowls with a detached sensor, "
                                           "hence opt-in; docs/rail.md)."),
    witness_rule: str = typer.Option("off", "--witness-rule",
                                     help="off, steps or steps-ends. steps keeps a sensor whose departure from its "
                                          "neighbours grew in separate same-sign steps (the only witness of a settling "
                                          "transition at a joint, abutment or culvert) instead of excluding it as "
                                          "detached; steps-ends also lets it loosen the span's end anchors "
                                          "(docs/rail.md, \"Sensor health on a transition\")."),
    seed: int = typer.Option(0, "--seed", min=0, help="Random seed of the Monte Carlo."),
    overwrite: bool = OVERWRITE,
):
    """Altitude change of the track, day by day, with 90 % bands, sensor health and alarms."""
    import numpy as np

    from ..io import read_rail_thresholds, write_table
    from ..rail import SettlementSettings, estimate_settlement

    inputs = (sensors, readings, survey, controls, thresholds, events)
    out, png = _check_settle_outputs(output, plot, report, inputs, overwrite)
    quiet = _check_settle_options({
        "--thermal": thermal, "--sigma-deg": sigma_deg, "--rigidity": rigidity, "--sigma-z": sigma_z,
        "--sigma-a": sigma_a, "--angle-unit": angle_unit, "--settlement-threshold-mm": threshold_mm,
        "--rate-threshold-mm-per-day": rate_mm, "--alarm-probability": alarm_probability, "--thresholds": thresholds,
        "--end-ambiguity": end_ambiguity, "--witness-rule": witness_rule, "--quiet-day": quiet_day})
    graded = None if thresholds is None else read_rail_thresholds(thresholds)
    site, declared = read_site_with_events(events, sensors, readings, survey, controls, angle_unit=angle_unit,
                                           check_units=check_units, temperature_fill=temperature_fill,
                                           timezone=timezone, require_temperature=thermal != "none")
    _check_quiet_days_in_record(quiet, site)
    settings = SettlementSettings(
        thermal=thermal, sigma=None if sigma_deg is None else float(np.deg2rad(sigma_deg)),
        rigidity=rigidity, sigma_z=sigma_z, sigma_a=sigma_a,
        quiet_days=quiet or None, check_health=not no_health, exclude_sensors=tuple(exclude),
        use_affine_correction=affine, joint_days=not per_day,
        settlement_threshold_m=None if threshold_mm is None else threshold_mm * 1e-3,
        rate_threshold_m_per_day=None if rate_mm is None else rate_mm * 1e-3, thresholds=graded,
        alarm_probability=alarm_probability, n_monte_carlo=n_monte_carlo, rng=seed,
        max_settlement_interval="band" if max_band else "draws", end_ambiguity=end_ambiguity,
        witness_rule=witness_rule, events=declared)
    with progress() as bar:
        task = bar.add_task("settlement", total=1)
        res = estimate_settlement(site, settings=settings)
        bar.advance(task)
    plotted = None
    if plot is not None:  # queued first: the figure helper, when one runs, draws it while the tables are written
        from ..report import current_renderer, plot_settlement

        plotted = current_renderer().submit(plot_settlement, res, png)
    write_table(res.to_table(), out)
    if report is not None:
        from ..report import write_rail_report

        write_rail_report(res, report, inputs=inputs, overwrite=overwrite)
    if plotted is not None:
        plotted.result()
    _print_settle_summary(res, output)


#: ``rail settle`` options with a fixed set of values.
_SETTLE_CHOICES = {"--thermal": ("auto", "linear", "lagged", "none"), "--angle-unit": ("deg", "rad"),
                   "--end-ambiguity": ("off", "mixture"), "--witness-rule": ("off", "steps", "steps-ends")}


def _check_settle_outputs(output, plot, report, inputs, overwrite: bool):
    """(the -o path, the --plot path) of ``rail settle``, every output checked before the computation, so a bad path
    fails at once and writes nothing."""
    out = check_output_path(output, *inputs, suffixes=TABLE_SUFFIXES, overwrite=overwrite)
    png = check_plot_path(plot, *inputs, overwrite=overwrite)
    if report is not None:
        from ..report import REPORT_FILES

        check_output_folder(report, *inputs, overwrite=overwrite, what="--report", writes=REPORT_FILES["rail"],
                            others={"-o": output, "--plot": plot})
    return out, png


def _check_settle_options(options: dict) -> list:
    """Refuse a ``rail settle`` option value in the command line's own terms (the option's name, the value as typed,
    mm and deg), before any file is read; return the ``--quiet-day`` dates."""
    from ..errors import InputError
    from ..rail import THRESHOLD_FLOORS_M, THRESHOLD_RANGE_M

    if options["--thresholds"] is not None and (options["--settlement-threshold-mm"] is not None
                                                or options["--rate-threshold-mm-per-day"] is not None):
        raise InputError("give either --thresholds FILE or --settlement-threshold-mm / --rate-threshold-mm-per-day, "
                         "not both.")
    for name, choices in _SETTLE_CHOICES.items():
        if options[name] not in choices:
            raise InputError(f"{name} {options[name]}: not known; use one of {', '.join(choices)}.")
    for name in ("--sigma-deg", "--rigidity", "--sigma-z", "--sigma-a"):
        v = options[name]
        if v is not None and not (v > 0 and v < float("inf")):
            raise InputError(f"{name} {v:g}: must be a number > 0 (leave it out for the default).")
    p = options["--alarm-probability"]
    if not 0 < p <= 1:
        hint = f" (a percentage? {p:g} % is {p / 100:g})" if 1 < p <= 100 else ""
        raise InputError(f"--alarm-probability {p:g}: must be a probability in (0, 1], e.g. 0.5{hint}.")
    for name, kind in (("--settlement-threshold-mm", "settlement"), ("--rate-threshold-mm-per-day", "rate")):
        v, per = options[name], "/day" if kind == "rate" else ""
        if v is None:
            continue
        lo, hi = 1e3 * THRESHOLD_FLOORS_M[kind], 1e3 * THRESHOLD_RANGE_M[1]
        if not (v > 0 and v < float("inf")):
            raise InputError(f"{name} {v:g}: must be a number > 0 (mm{per}).")
        if v < lo:
            raise InputError(f"{name} {v:g}: below {lo:g} mm{per}, the smallest plausible {kind} limit (track limits "
                             "are mm to tens of mm, rates 0.5-5 mm/day; the estimate's own error is ~0.1 mm): metres "
                             f"given as mm? Give the limit in mm{per} ({'2 for 2 mm/day' if per else '10 for 10 mm'}).")
        if v > hi:
            raise InputError(f"{name} {v:g}: above {hi:g} mm{per}, beyond any track limit: micrometres or another "
                             f"unit? Give the limit in mm{per}.")
    return _quiet_days(options["--quiet-day"])


def _quiet_days(days: list[str]) -> list:
    """The ``--quiet-day`` values as dates; each must be written YYYY-MM-DD (08/12/2019 is day/month or month/day)."""
    import datetime as dt
    import re

    from ..errors import InputError

    out = []
    for text in days:
        try:
            if not re.fullmatch(r"\d{4}-\d{2}-\d{2}", text.strip()):
                raise ValueError
            out.append(dt.date.fromisoformat(text.strip()))
        except ValueError:
            hint = " (day/month or month/day?)" if "/" in text or "." in text else ""
            raise InputError(f"--quiet-day {text}: not a date written YYYY-MM-DD{hint}; write e.g. "
                             "--quiet-day 2019-12-08.") from None
    return out


def _check_quiet_days_in_record(days: list, site) -> None:
    """Refuse a ``--quiet-day`` outside the readings' days (the thermal fit would have no day to use)."""
    if not days or not len(site.readings):
        return
    from ..errors import InputError

    t = site.readings["timestamp"]
    first, last = t.min().date(), t.max().date()
    out = [d for d in days if not first <= d <= last]
    if out:
        raise InputError(f"--quiet-day {out[0].isoformat()}: outside the record ({first.isoformat()} to "
                         f"{last.isoformat()}, UTC days); give days of the record (the thermal fit uses only those "
                         "days), or leave --quiet-day out.")


def _print_settle_summary(res, output: Path) -> None:
    """``rail settle``'s warnings, the thermal model's note and its one-line summary."""
    for w in res.warnings:
        console.print(f"[yellow]warning:[/yellow] {w}", highlight=False, soft_wrap=True)
    if res.settings.get("thermal_requested") == "auto" and res.settings.get("thermal") == "lagged":
        console.print(f"note: thermal model lagged, chosen from the readings (a thermal lag leaves "
                      f"{res.settings['lag_variance_ratio']:.2f} of the no-lag residual variance, median over sensors; "
                      "--thermal linear gives the paper's model)", highlight=False, soft_wrap=True)
    import numpy as np

    last = 1e3 * res.dz[-1]
    down, up = max(-float(np.nanmin(last)), 0.0), max(float(np.nanmax(last)), 0.0)
    moved = f"max settlement on the last day {down:.1f} mm" + (f", max heave {up:.1f} mm" if up >= 1.0 else "")
    share = res.daily.reading_shares()[-1]
    if share < res.daily.PARTIAL_DAY_SHARE:
        moved += f" (the last day, {np.datetime64(res.days[-1], 'D')}, holds {100 * share:.0f} % of a usual day's readings)"
    alarms = (f"{len(res.alarms)} alarm(s)" if res.settings.get("thresholds_set") else
              "no alarm thresholds set (--thresholds FILE): nothing was tested against a limit")
    console.print(f"{len(res.sensor_ids)} sensors, {res.days.size} days; {int(res.health.excluded.sum())} sensor(s) "
                  f"excluded; {moved}; {alarms} -> {output}")


def _register_service() -> None:
    """``rail serve`` and ``rail site ...``: the monitoring service (issue 15; needs the ``serve`` extra to run)."""
    from . import _rail_serve

    _rail_serve.register(rail_app)


_register_service()
