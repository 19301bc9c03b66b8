"""Rail settlement report: a self-contained HTML page, its PNG figures and CSV tables.

Rendering only: every number comes from :func:`longprofile.rail.estimate_settlement`.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import pandas as pd

from ._html import REPORT_FILES, figure_pngs, render, report_folder, write_csv, write_pngs, write_text
from ._layout import fixed_figure, fixed_grid
from ._render import current_renderer

__all__ = ["plot_settlement", "plot_true_settlement", "write_rail_report"]

_Z90 = 1.6448536269514722


def _figure(width=10.0, height=4.0, **margins):
    return fixed_figure(width, height, dpi=110, **margins)


def _day_label(d) -> str:
    return pd.Timestamp(d).strftime("%Y-%m-%d")


def _chosen_days(result, n=6):
    D = result.days.size
    idx = np.unique(np.linspace(0, D - 1, min(n, D)).round().astype(int))
    return idx


def _profiles_axes(ax, result, days_idx, *, controls=True):
    import matplotlib as mpl

    cmap = mpl.colormaps["viridis"]
    x = result.x
    for k, d in enumerate(days_idx):
        c = cmap(k / max(len(days_idx) - 1, 1))
        m = 1e3 * result.dz[d]
        s = 1e3 * _Z90 * result.dz_std[d]
        ax.fill_between(x, m - s, m + s, color=c, alpha=0.25, lw=0)
        ax.plot(x, m, color=c, lw=1.6, label=_day_label(result.days[d]))
        if controls and result.controls is not None:
            cd = result.controls[result.controls["date"] == _day_label(result.days[d])]
            if len(cd):
                ax.plot(cd["x_m"], 1e3 * cd["dz_control_m"], "o", color=c, ms=4, mec="k", mew=0.5)
    bad = result.health.excluded
    if bad.any():
        ax.plot(x[bad], np.zeros(bad.sum()), "x", color="#c62828", ms=8, mew=2, label="excluded sensor")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel("station x (m)")
    ax.set_ylabel("altitude change (mm)")
    ax.legend(fontsize=7, ncol=2, loc="lower left")


def plot_settlement(result, path, *, n_days: int = 6) -> Path:
    """Settlement profiles on ``n_days`` evenly spaced days with their 90 % bands; control surveys as dots."""
    fig = _figure(10, 4.2)
    ax = fig.add_subplot()
    _profiles_axes(ax, result, _chosen_days(result, n_days))
    ax.set_title("altitude change since the first day, 90 % bands (dots: control surveys, x: excluded sensors)",
                 fontsize=9)
    from ..io import save_figure

    return save_figure(fig, Path(path), dpi=110)  # temporary file + os.replace; OSError -> OutputError there


def plot_true_settlement(truth, path, *, n_days: int = 6) -> Path:
    """True altitude change of a synthetic site (``rail simulate --plot``) on ``n_days`` evenly spaced days.

    Parameters
    ----------
    truth : SiteTruth
        ``longprofile.rail.simulate_site(...).truth`` (stations ``x``, ``days``, ``settlement`` (D, N) in m).
    path : path-like
        PNG to write.
    n_days : int, default 6

    Returns
    -------
    Path
    """
    D = truth.settlement.shape[0]
    fig = _figure(10, 4)
    ax = fig.add_subplot()
    for d in np.unique(np.linspace(0, D - 1, n_days).round().astype(int)):
        ax.plot(truth.x, 1e3 * truth.settlement[d], label=pd.Timestamp(truth.days[d]).strftime("%Y-%m-%d"))
    ax.set_xlabel("station x (m)"); ax.set_ylabel("true altitude change (mm)"); ax.legend(fontsize=7)
    from ..io import save_figure

    return save_figure(fig, Path(path), dpi=110)  # temporary file + os.replace; OSError -> OutputError there


def _weekly_figure(result):
    """Small multiples: one panel per week, the profile of each day with its band."""
    D = result.days.size
    weeks = [list(range(s, min(s + 7, D))) for s in range(0, D, 7)]
    ncol = 2
    nrow = int(np.ceil(len(weeks) / ncol))
    fig = _figure(11, 2.6 * nrow)
    axes = fixed_grid(fig, nrow, ncol).ravel()
    for ax in axes[len(weeks):]:
        ax.set_visible(False)
    lo = 1e3 * np.nanmin(result.dz - _Z90 * result.dz_std)
    hi = 1e3 * np.nanmax(result.dz + _Z90 * result.dz_std)
    for i, w in enumerate(weeks):
        ax = axes[i]
        _profiles_axes(ax, result, w)
        ax.set_ylim(lo - 1, hi + 1)
        ax.set_title(f"week from {_day_label(result.days[w[0]])}", fontsize=9)
    return fig


def _time_figure(result):
    fig = _figure(11, 8.0, bottom=0.9)
    ax1, ax2, ax3 = fixed_grid(fig, 3, 1, hspace=0.45, sharex=True)[:, 0]
    days = pd.DatetimeIndex(result.days)
    sm = result.smoothed
    mean = sm.mean if sm is not None else result.dz
    std = sm.std if sm is not None else result.dz_std
    j = int(np.nanargmin(mean[-1]))
    other = 0 if j != 0 else result.x.size - 1  # an end station for comparison
    for jj, c in ((j, "#c62828"), (other, "0.4")):
        ax1.fill_between(days, 1e3 * (mean[:, jj] - _Z90 * std[:, jj]), 1e3 * (mean[:, jj] + _Z90 * std[:, jj]),
                         color=c, alpha=0.2, lw=0)
        ax1.plot(days, 1e3 * mean[:, jj], color=c, label=f"{result.sensor_ids[jj]} (x = {result.x[jj]:.1f} m)")
        ax1.plot(days, 1e3 * result.dz[:, jj], ".", color=c, ms=4)
    ax1.set_ylabel("altitude change (mm)")
    ax1.legend(fontsize=8)
    ax1.set_title("settlement through time (line: smoothed across days, dots: daily posterior), 90 % bands",
                  fontsize=9)
    if sm is not None:
        r, rs = 1e3 * sm.rate[:, j], 1e3 * _Z90 * sm.rate_std[:, j]
        ax2.bar(days, r, color="#c62828", alpha=0.6, width=0.8)
        ax2.errorbar(days, r, yerr=rs, fmt="none", ecolor="k", lw=0.8)
        ax2.set_ylabel(f"rate at {result.sensor_ids[j]} (mm/day)")
        ax2.set_title("daily rate (smoothed model), 90 % error bars", fontsize=9)
    ax3.plot(days, 1e3 * result.max_settlement_mean, "k-", lw=1, label="Monte Carlo mean")
    if result.max_settlement_lower is not None:
        ax3.fill_between(days, 1e3 * result.max_settlement_lower, 1e3 * result.max_settlement_upper, color="k",
                         alpha=0.1, lw=0, label="90 % interval (simultaneous band)"
                         if result.settings.get("max_settlement_interval") == "band" else "90 % interval")
    ax3.set_ylabel("max settlement (mm)")
    ax3.set_title("maximum settlement over the track (§4.3, paper's posterior: includes the prior's uncertainty "
                  "between sensors)", fontsize=9)
    ax3.legend(fontsize=8)
    fig.autofmt_xdate(bottom=0.9 / 8.0)
    return fig


def _map_figure(result):
    fig = _figure(11, 3.6, left=1.0)
    ax = fig.add_subplot()
    sm = result.smoothed
    mean = sm.mean if sm is not None else result.dz
    lim = max(1e-3, float(np.nanmax(np.abs(mean)))) * 1e3
    im = ax.pcolormesh(result.x, np.arange(result.days.size), 1e3 * mean, cmap="RdBu", vmin=-lim, vmax=lim,
                       shading="nearest")
    ax.set_yticks(np.arange(0, result.days.size, 7), [_day_label(d) for d in result.days[::7]], fontsize=7)
    ax.set_xlabel("station x (m)")
    ax.set_title("altitude change (mm) by day and station", fontsize=9)
    fig.colorbar(im, ax=ax, label="mm")
    return fig


def _initial_figure(result):
    fig = _figure(11, 4.0)
    ax1, ax2 = fixed_grid(fig, 1, 2)[0]
    ini = result.initial
    x = result.x
    trend = np.polyval(np.polyfit(x, ini.z_mean, 1), x)
    ax1.fill_between(x, 1e3 * (ini.z_mean - trend - _Z90 * ini.z_std), 1e3 * (ini.z_mean - trend + _Z90 * ini.z_std),
                     color="C0", alpha=0.3, lw=0)
    ax1.plot(x, 1e3 * (ini.z_mean - trend), "C0")
    ax1.set_title("initial profile minus its linear trend (§4.4), 90 % band", fontsize=9)
    ax1.set_xlabel("station x (m)"); ax1.set_ylabel("mm")
    ang = np.rad2deg(np.arctan(ini.slope_mean))
    band = np.rad2deg(_Z90 * ini.slope_std)
    ax2.fill_between(x, ang - band, ang + band, color="C1", alpha=0.3, lw=0)
    ax2.plot(x, ang, "C1")
    ax2.set_title("initial angles (deg), 90 % band", fontsize=9)
    ax2.set_xlabel("station x (m)")
    return fig


def _controls_figure(result):
    c = result.controls
    fig = _figure(11, 3.4)
    ax = fig.add_subplot()
    for k, (date, g) in enumerate(c.groupby("date")):
        col = f"C{k}"
        ax.errorbar(g["x_m"], 1e3 * g["dz_estimate_m"], yerr=1e3 * _Z90 * g["std_m"], fmt="-", color=col, lw=1,
                    label=f"estimate {date}")
        ax.plot(g["x_m"], 1e3 * g["dz_control_m"], "o", color=col, mec="k", mew=0.5, label=f"control {date}")
    ax.set_xlabel("station x (m)"); ax.set_ylabel("altitude change (mm)")
    ax.legend(fontsize=7, ncol=3)
    ax.set_title("estimate vs control surveys (control noise ~2 mm x sqrt 2)", fontsize=9)
    return fig


def _table_html(df: pd.DataFrame, fmt="{:.4g}") -> str:
    if df is None or len(df) == 0:
        return "<p><em>none</em></p>"
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    rows = []
    for _, r in df.iterrows():
        cells = "".join(f"<td>{fmt.format(v) if isinstance(v, (float, np.floating)) else html.escape(str(v))}</td>"
                        for v in r)
        rows.append(f"<tr>{cells}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _with_units(alarms: pd.DataFrame) -> pd.DataFrame:
    """The alarms table with the unit of its ``value`` and ``threshold`` (SI: m, m/day for a rate; a user reading
    ``-0.0036`` next to thresholds given in mm asked which unit it was; session 36)."""
    if alarms is None or "kind" not in alarms:
        return alarms
    return alarms.assign(unit=np.where(alarms["kind"].astype(str) == "rate", "m/day", "m"))


def _report_figures(result) -> dict:
    """The report's figures by PNG file name: the function drawing each (``function(result)`` -> Figure)."""
    figs = {"profiles_by_week.png": _weekly_figure, "through_time.png": _time_figure,
            "settlement_map.png": _map_figure, "initial_profile.png": _initial_figure}
    if result.controls is not None:
        figs["controls.png"] = _controls_figure
    return figs


def _through_time_phrase(st: dict) -> str:
    """How the days are tied together, for the report's method paragraph."""
    if st.get("joint_days"):
        return ("all days in one posterior (sensor drift correlated over the days, settlement prior fitted per day: "
                "docs/rail.md step 10)")
    return f"day-to-day settlement std {1e3 * (st.get('process_std') or float('nan')):.3g} mm/day"


def _sensor_table(result) -> pd.DataFrame:
    """``sensors.csv``: one row per sensor (health, noise factor, thermal fit, initial profile and angle)."""
    return pd.DataFrame({"sensor_id": result.sensor_ids, "x_m": result.x, "status": result.health.status,
                         "detail": result.health.detail, "loo_score": result.health.loo_score,
                         **{k: v for k, v in (("reversal_z", result.health.reversal_z),
                                              ("reversal_llr", result.health.reversal_llr),
                                              ("step_z", result.health.step_z)) if v is not None},
                         **({} if result.sensor_noise_factor is None
                            else {"noise_factor": result.sensor_noise_factor}),
                         "thermal_coef_deg_per_c": result.daily.thermal_coef,
                         "thermal_lag_h": result.daily.thermal_lag_hours, "outliers": result.daily.n_outliers,
                         "initial_z_m": result.initial.z_mean, "initial_z_std_m": result.initial.z_std,
                         "initial_angle_deg": np.rad2deg(np.arctan(result.initial.slope_mean)),
                         "initial_angle_std_deg": np.rad2deg(result.initial.slope_std)})


def _max_settlement_table(result) -> pd.DataFrame:
    """The maximum settlement per day (Monte Carlo mean, std and 90 % interval), mm."""
    maxs = pd.DataFrame({"date": [_day_label(d) for d in result.days],
                         "max settlement mean (mm)": 1e3 * result.max_settlement_mean,
                         "std (mm)": 1e3 * result.max_settlement_std})
    if result.max_settlement_lower is not None:  # the 90 % interval (max_settlement_interval; not mean -/+ 1.645 std)
        maxs["90 % low (mm)"] = 1e3 * result.max_settlement_lower
        maxs["90 % high (mm)"] = 1e3 * result.max_settlement_upper
    return maxs


def _control_summary(controls) -> pd.DataFrame:
    """Per control survey: points, RMS difference estimate - control (mm), share inside the 90 % band."""
    return controls.groupby("date").apply(lambda d: pd.Series({
        "points": len(d), "RMS diff (mm)": 1e3 * np.sqrt(np.mean((d.dz_control_m - d.dz_estimate_m) ** 2)),
        "inside 90 % (%)": 100 * d.inside_90.mean()}), include_groups=False).reset_index()


def _alarm_summary(alarms: pd.DataFrame) -> pd.DataFrame:
    """One row per station, kind (and level) (first and last day, worst value and threshold in mm or mm/day)."""
    alarms = alarms.copy()
    if len(alarms):
        alarms["value"] = alarms["value"] * 1e3
        alarms["threshold"] = alarms["threshold"] * 1e3
        keys = ["sensor_id", "x_m", "kind"] + (["level"] if "level" in alarms.columns else [])
        alarms = (alarms.groupby(keys, sort=False)
                  .agg(first_date=("date", "min"), last_date=("date", "max"), days=("date", "size"),
                       threshold=("threshold", "first"), worst_value=("value", lambda v: v.iloc[np.argmax(np.abs(v))]),
                       max_probability=("probability", "max"))
                  .reset_index().sort_values(["first_date", "x_m"]))
        alarms = alarms.rename(columns={"worst_value": "worst value (mm or mm/day)",
                                        "threshold": "threshold (mm or mm/day)"})
    return alarms


def _thresholds_html(settings: dict) -> str:
    """The thresholds the alarms were tested against, or the statement that none was set."""
    graded = dict(settings.get("thresholds") or {})
    if settings.get("settlement_threshold_m") is not None:
        graded.setdefault("settlement", {})["alert"] = settings["settlement_threshold_m"]
    if settings.get("rate_threshold_m_per_day") is not None:
        graded.setdefault("rate", {})["alert"] = settings["rate_threshold_m_per_day"]
    if not graded:
        return ('<p class="nothr"><b>No alarm thresholds were set: no station was tested against a limit.</b> An empty '
                "list below is not a statement that the track is within tolerance; give thresholds with "
                "<code>rail settle --thresholds FILE</code> (quantity, level, value_mm).</p>")
    unit = {"rate": "mm/day"}
    rows = [(q, lv, f"{1e3 * v:g} {unit.get(q, 'mm')}") for q, levels in graded.items() for lv, v in levels.items()]
    return "<p>Thresholds tested: " + "; ".join(f"{q} {lv} {html.escape(v)}" for q, lv, v in rows) + ".</p>"


def _thermal_phrase(st: dict) -> str:
    """The thermal model used, and why when the data chose it (``thermal="auto"``)."""
    from ..rail import LAG_AUTO_RATIO

    ratio = st.get("lag_variance_ratio")
    if st.get("thermal_requested") != "auto" or ratio is None:
        return str(st.get("thermal"))
    if not np.isfinite(ratio):
        return f"{st.get('thermal')} (no day had the readings and temperature spread to test a thermal lag)"
    return (f"{st.get('thermal')} (chosen from the readings: a thermal lag leaves {ratio:.2f} of the no-lag residual "
            f"variance, median over sensors; lagged below {LAG_AUTO_RATIO:g})")


def _method_context(result) -> dict:
    """The page's first paragraph: the site, the days and the settings of the fit (strings)."""
    st = result.settings
    order = st.get("penalty_order", 2)
    return dict(n_sensors=f"{len(result.sensor_ids)}", length=f"{result.x[-1] - result.x[0]:.1f}",
                n_days=f"{result.days.size}", first_day=_day_label(result.days[0]),
                last_day=_day_label(result.days[-1]), thermal=html.escape(_thermal_phrase(st)),
                sigma=f"{st.get('sigma_deg', float('nan')):.2e}",
                sigma_source="estimated" if st.get("sigma_estimated") else "given", penalty_order=f"{order}",
                rigidity=f"{st.get('rigidity', float('nan')):.2e}", rigidity_power=f"{2 * order - 2}",
                rigidity_source="maximum likelihood" if st.get("rigidity_estimated") else "given",
                through_time=_through_time_phrase(st),
                alarm_probability=f"{st.get('alarm_probability')}")


def _control_check_phrase(check) -> str:
    """One sentence on whether the control surveys agree with the estimate (escaped; empty without controls)."""
    if check is None:
        return ""
    verdict = ("<b>they disagree</b>: the estimate's assumptions do not hold here (see the warnings)" if check.disagree
               else "they agree with the estimate and its bands")
    return (f"Chi-squared test of the standardised differences (estimate band and survey noise): "
            f"{check.chi2:.3g} on {check.n_points} points, p = {check.p_value:.2g}; {check.n_outside} of "
            f"{check.n_points} points outside the 90 % band; {verdict} (docs/rail.md, \"Control surveys\").")


def _page_context(result, title: str, health: pd.DataFrame, images: dict) -> dict:
    """Everything ``templates/rail_report.html`` shows: escaped text, HTML tables, base64 PNGs by figure name."""
    flagged = health[health["status"] != "ok"][["sensor_id", "x_m", "status", "detail"]]
    return dict(title=html.escape(title), **_method_context(result),
                warnings=[html.escape(w) for w in result.warnings],
                flagged_table=_table_html(flagged), alarms_table=_table_html(_alarm_summary(result.alarms)),
                thresholds=_thresholds_html(result.settings),
                controls_table=("" if result.controls is None else _table_html(_control_summary(result.controls))),
                controls_check=_control_check_phrase(result.control_check),
                max_table=_table_html(_max_settlement_table(result)),
                imgs={name.removesuffix(".png"): b64 for name, b64 in images.items()})


def write_rail_report(result, outdir, *, title: str = "Track settlement report", inputs=(),
                      overwrite: bool = True) -> list[Path]:
    """Write ``outdir/index.html`` (figures embedded), the PNGs and CSV tables of a settlement result.

    Parameters
    ----------
    result : SettlementResult
    outdir : path-like
        Created if needed.
    title : str
    inputs : sequence of path-like or None
        The site's tables (or folder), never overwritten (:class:`~longprofile.errors.OutputError` when the
        report would write over one of them).
    overwrite : bool, default True
        False refuses an existing, non-empty ``outdir`` (:class:`~longprofile.errors.OutputError`).

    Returns
    -------
    list of Path
        Files written.

    Notes
    -----
    The page is ``report/templates/rail_report.html`` (Jinja2).
    """
    out = report_folder(outdir, inputs, writes=REPORT_FILES["rail"], overwrite=overwrite, what="report",
                        hint=f"the report needs a folder, e.g. {Path(outdir).with_suffix('')}_report/.")
    # drawn by the command's figure helper while the tables are written, when one runs (report/_render.py)
    figures = current_renderer().submit(figure_pngs, _report_figures(result), result, savefig={"dpi": 110})
    health = _sensor_table(result)
    written = [write_csv(result.to_table(), out / "settlement.csv"), write_csv(_with_units(result.alarms),
                                                                              out / "alarms.csv"),
               write_csv(health, out / "sensors.csv")]
    paths, images = write_pngs(figures.result(), out)
    page = render("rail_report.html", **_page_context(result, title, health, images))
    return [write_text(out / "index.html", page)] + paths + written  # the figures before the tables, as always
