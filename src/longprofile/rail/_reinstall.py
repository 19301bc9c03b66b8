"""Sensors re-installed with a new mounting offset: detection and a new reference (beyond paper 004).

A sensor taken off its sleeper (tamping, maintenance) and refitted under the same id reads again with a new
mounting offset: its angle change since the reference day jumps by an unknown constant at the changeover. Left in,
the jump is read as settlement (false heave and alarms; docs/rail.md, "Re-installed sensors"). Here such a sensor's
series is *re-baselined*: from the changeover on it carries a new reference, i.e. its angle change across the
changeover is treated as unknown, and the settlement of that interval is carried by the neighbours and the prior.

Two stages. :func:`rebaseline_daily` removes a first estimate of the offset from the daily angles (the sensor's change
across the changeover minus the change its nearest neighbours show over the same days, linearly interpolated to its
station), so that the sensor-health tests and the noise and prior fits see a continuous series. The all-days
posterior then treats each new reference's offset as an unknown with a flat prior (:func:`condition_on_unknowns`),
exactly: the mean and the bands do not depend on that first estimate, and the bands carry the offset's uncertainty.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

#: ``SettlementSettings.reinstallations``: detect re-installed sensors and re-baseline them, or take every series as
#: continuous.
REINSTALL_MODES = ("detect", "off")
#: ``event`` values of the events table (:func:`check_events`).
EVENT_KINDS = ("reinstalled", "replaced_by")

#: A sensor resuming after a gap is taken as re-installed when its change across the gap departs from its neighbours'
#: by more than this many robust std of the same departure over ordinary day pairs of the same length (all sensors).
#: On mittersheim-like seed 0 the largest ordinary departure of a healthy sensor is 22 std (next to a reversed one).
REINSTALL_STEP_Z = 25.0
#: The same for a sensor that shares its gap (the same last and first days) with a sensor above
#: :data:`REINSTALL_STEP_Z`: several sensors refitted after one maintenance (a sensor left in place needlessly
#: re-baselined only loses that interval's information; its band widens to match).
REINSTALL_GROUP_Z = 10.0


@dataclass(frozen=True)
class Rebaselines:
    """New references of sensors' series (re-installed or replaced sensors).

    Attributes
    ----------
    sensor : (K,) int ndarray
        Index of the sensor (station order).
    day : (K,) int ndarray
        Index of the day of the new reference (the first day with a reading after the changeover).
    before : (K,) int ndarray
        Index of the last day with a reading before it.
    step : (K,) ndarray
        First estimate of the offset removed from the daily angle changes, rad (change across the changeover minus
        the neighbours' over the same days).
    z : (K,) ndarray
        ``step`` over the robust std of the same departure over ordinary day pairs (NaN when not computed).
    declared : (K,) bool ndarray
        Declared by the user (events table) rather than detected.
    """

    sensor: np.ndarray
    day: np.ndarray
    before: np.ndarray
    step: np.ndarray
    z: np.ndarray
    declared: np.ndarray

    def __len__(self) -> int:
        return int(self.sensor.size)

    def segments(self, shape) -> np.ndarray:
        """(D, N) int: 0 where a sensor's change refers to its first day, k + 1 from the k-th new reference on."""
        seg = np.zeros(shape, int)
        for k in np.argsort(self.day, kind="stable"):
            seg[self.day[k]:, self.sensor[k]] = k + 1
        return seg


def _empty() -> Rebaselines:
    e = np.zeros(0, int)
    return Rebaselines(e, e, e, np.zeros(0), np.zeros(0), np.zeros(0, bool))


def _neighbour_change(x, change, a: int, b: int, j: int, reference) -> float:
    """Change from day a to day b interpolated at station j from the nearest reference sensors on each side."""
    left = np.flatnonzero(reference[:j])
    right = j + 1 + np.flatnonzero(reference[j + 1:])
    delta = change[b] - change[a]
    if left.size and right.size:
        lo, hi = left[-1], right[0]
        w = (x[j] - x[lo]) / (x[hi] - x[lo])
        return float((1.0 - w) * delta[lo] + w * delta[hi])
    if left.size or right.size:
        return float(delta[left[-1]] if left.size else delta[right[0]])
    return float("nan")


def _departures(x, change, lag: int) -> np.ndarray:
    """(D - lag, N) each sensor's change over ``lag`` days minus the linear interpolation of its nearest neighbours
    with a change over the same days (one side at the ends of those), NaN where it has none."""
    c = np.asarray(change, float)
    out = np.full((max(c.shape[0] - lag, 0), c.shape[1]), np.nan)
    for d in range(out.shape[0]):
        delta = c[d + lag] - c[d]
        idx = np.flatnonzero(np.isfinite(delta))
        if idx.size < 2:
            continue
        lo = np.r_[idx[1], idx[:-1]]
        hi = np.r_[idx[1:], idx[-2]]
        w = np.where(hi != lo, (x[idx] - x[lo]) / np.where(hi != lo, x[hi] - x[lo], 1.0), 0.0)
        out[d, idx] = delta[idx] - ((1.0 - w) * delta[lo] + w * delta[hi])
    return out


def departure_scale(x, change, lag: int) -> float:
    """Robust std (1.4826 MAD) of every sensor's change over ``lag`` days minus its neighbours' linear
    interpolation (:func:`_departures`), over all day pairs (d, d + lag), rad (NaN if none)."""
    r = _departures(np.asarray(x, float), change, lag)
    r = np.abs(r[np.isfinite(r)])
    return 1.4826 * float(np.median(r)) if r.size else float("nan")


def _gaps(column):
    """(a, b) pairs: the last day with a value before each run of missing days inside the series, the first after."""
    ok = np.flatnonzero(np.isfinite(column))
    return [(int(a), int(b)) for a, b in zip(ok[:-1], ok[1:]) if b > a + 1]


def find_reinstallations(x, change, *, z: float = REINSTALL_STEP_Z, group_z: float = REINSTALL_GROUP_Z) -> Rebaselines:
    """Sensors whose daily angle change jumps across a gap in their readings beyond what their neighbours show.

    Parameters
    ----------
    x : (N,) array_like
        Stations, m.
    change : (D, N) array_like
        Daily slope (or angle) changes since each sensor's first day, NaN where a sensor has no daily value.
    z : float
        Threshold on the departure in robust std of ordinary departures over the same number of days
        (:func:`departure_scale`).
    group_z : float
        The threshold for a sensor with the same gap (last and first days) as one above ``z``.

    Returns
    -------
    Rebaselines
        One new reference per detected gap (``declared`` False).
    """
    x = np.asarray(x, float)
    c = np.asarray(change, float)
    own = np.abs(_departures(x, c, 1))
    own = np.where(np.isfinite(own).any(axis=0), np.nanmax(np.where(np.isfinite(own), own, -1.0), axis=0), 0.0)
    gaps = [(j, a, b) for j in range(c.shape[1]) for a, b in _gaps(c[:, j])]
    scales = {lag: departure_scale(x, c, lag) for lag in {b - a for _, a, b in gaps}}
    rows, taken = [], np.zeros(c.shape[1], bool)
    while gaps:  # the largest jump first; a sensor taken is no neighbour of the others (its jump is no settlement)
        best, ratio = None, 1.0
        for j, a, b in gaps:
            reference = np.isfinite(c[a]) & np.isfinite(c[b]) & ~taken  # the nearest, in the same gap or not
            reference[j] = False
            step = c[b, j] - c[a, j] - _neighbour_change(x, c, a, b, j, reference)
            s = scales[b - a]
            shared = any((r[1], r[2]) == (b, a) for r in rows)
            # a sensor that departs from its neighbours on ordinary days (reversed, in a bowl's flank) may depart by
            # as much on each day of the gap: alone, only a jump beyond (b - a) times its largest ordinary departure
            # counts; in a gap shared with a sensor taken, the threshold group_z
            if not (np.isfinite(step) and s > 0 and (shared or abs(step) > (b - a) * own[j])):
                continue
            limit = group_z if shared else z
            if abs(step) / (limit * s) > ratio:
                best, ratio = (j, b, a, step, step / s), abs(step) / (limit * s)
        if best is None:
            break
        rows.append(best)
        taken[best[0]] = True
        gaps.remove((best[0], best[2], best[1]))
    if not rows:
        return _empty()
    rows.sort()
    j, b, a, step, zz = (np.array(v) for v in zip(*rows))
    return Rebaselines(j.astype(int), b.astype(int), a.astype(int), step.astype(float), zz.astype(float),
                       np.zeros(j.size, bool))


def reinstall_warning(ids, days, rb: Rebaselines) -> str:
    """One line naming the re-baselined sensors, their changeover dates and step sizes, and the way out."""
    dates = pd.DatetimeIndex(days)
    parts = [f"{ids[j]} {dates[b]:%Y-%m-%d} ({np.rad2deg(s):+.3f} deg)"
             for j, b, s in zip(rb.sensor, rb.day, rb.step)]
    found = ~rb.declared
    head = (f"{int(found.sum())} sensor series resume after a gap with a jump in their angle that their neighbours do "
            "not show over the same days (a new mounting offset: re-installed after maintenance?)" if found.any()
            else f"{len(rb)} declared re-installation(s) or replacement(s)")
    return (f"{head}: {', '.join(parts)}. Each is re-baselined: its angle change across the changeover is treated as "
            "unknown (the neighbours and the prior carry that interval's settlement, with wider bands there); declare "
            "re-installations and replacements with an events table (--events FILE; docs/rail.md, \"Re-installed "
            "sensors\"), or --exclude the sensor.")


def rebaseline_daily(x, daily, rb: Rebaselines):
    """``daily`` (:class:`~longprofile.rail.DailyAngles`) with each new reference's first offset estimate removed
    from its sensor's angles from the changeover on, the days between ``before`` and ``day`` left out, and
    ``rebaselined`` set to the segments (:meth:`Rebaselines.segments`)."""
    if not len(rb):
        return daily
    angle = np.array(daily.angle_deg, float)
    change = np.array(daily.change_deg, float)
    for j, b, a, s in zip(rb.sensor, rb.day, rb.before, rb.step):
        angle[b:, j] -= np.rad2deg(s)
        change[b:, j] -= np.rad2deg(s)
        angle[a + 1:b, j] = change[a + 1:b, j] = np.nan  # a declared changeover's own day: both mountings
    return replace(daily, angle_deg=angle, change_deg=change, rebaselined=rb.segments(change.shape))


def offset_columns(segments, missing):
    """Index arrays (rows, cols) of each new reference's observed entries in the (D - 1, N) data of days 1..D-1,
    for :func:`condition_on_unknowns` (``segments`` (D, N) from :meth:`Rebaselines.segments`)."""
    seg = np.asarray(segments)[1:]
    out = []
    for k in np.unique(seg[seg > 0]):
        rows, cols = np.nonzero((seg == k) & ~missing)
        if rows.size:
            out.append((rows, cols))
    return out


def condition_on_unknowns(posterior, precision_times, m0, columns, base, rng=None, n_records: int = 0,
                          to_modes=None):
    r"""The all-days posterior with unknowns of flat prior added to the data: m = theta + e + sum_k c_k u_k.

    Each unknown c_k multiplies a 0/1 column u_k of the (D - 1, N) data: a single entry for a missing sensor-day (its
    value is then unknown, i.e. missing), every observed day of a new reference for a re-installed sensor's offset.
    With H the complete-data posterior mean (theta_hat = H m) and Lambda = Sigma_e^{-1} (I - H) the precision of the
    data, the generalised least-squares estimate c_hat = (U^T Lambda U)^{-1} U^T Lambda m0 is the posterior mean of c
    under a flat prior, Cov c = (U^T Lambda U)^{-1}, and

        E[theta | m] = H (m0 - U c_hat),   Cov[theta | m] = Cov[theta | m, c] + H U Cov(c) U^T H^T

    (for unit columns these are the missing-data formulas of :func:`~longprofile.rail._settle._impute_missing`).

    Parameters
    ----------
    posterior : callable
        data (D - 1, N) -> the joint posterior (``z_mean``, ``slope_mean`` (D, N)) of that data.
    precision_times : callable
        (data, fitted slopes of days 1..D-1) -> Sigma_e^{-1} (data - fitted), (D - 1, N).
    m0 : (D - 1, N) ndarray
        The data, 0 at missing entries of kept sensors, NaN for excluded sensors.
    columns : list of (rows, cols)
        The entries of each u_k.
    base : (D - 1, N) ndarray
        0 for kept sensors, NaN for excluded ones (the zero data).
    rng, n_records, to_modes
        With ``n_records``: that many records m0 - U (c_hat + draw of Cov c), mapped by ``to_modes``.

    Returns
    -------
    mean : the posterior of m0 - U c_hat
    add : dict of the added variances ``z``, ``slope`` (D, N) and ``rate`` (D - 1, N)
    records : (n_records, ...) ndarray or None
    """
    if not columns:
        mean = posterior(m0)
        zero = np.zeros_like(mean.z_mean)
        records = np.stack([to_modes @ m0] * n_records) if n_records else None
        return mean, {"z": zero, "slope": zero, "rate": zero[1:]}, records

    def column(k, value=1.0):
        v = base.copy()
        v[columns[k]] = value
        return v

    def project(p):
        return np.array([p[r, c].sum() for r, c in columns])

    lam_o = project(precision_times(m0, posterior(m0).slope_mean[1:]))
    lam = np.empty((len(columns), len(columns)))
    for k in range(len(columns)):  # U^T Lambda U, a column per unknown (its unit response)
        lam[:, k] = project(precision_times(column(k), posterior(column(k)).slope_mean[1:]))
    cov = np.linalg.inv(0.5 * (lam + lam.T))
    cov = 0.5 * (cov + cov.T)
    c_hat = cov @ lam_o
    w, V = np.linalg.eigh(cov)
    root = V * np.sqrt(np.clip(w, 0.0, None))  # cov = root root^T

    def shifted(c):
        v = m0.copy()
        for k, (r, cc) in enumerate(columns):
            v[r, cc] -= c[k]
        return v

    mean = posterior(shifted(c_hat))
    add = {"z": np.zeros_like(mean.z_mean), "slope": np.zeros_like(mean.z_mean),
           "rate": np.zeros((m0.shape[0], m0.shape[1]))}
    for k in np.flatnonzero(np.any(root != 0.0, axis=0)):  # diag(H U cov U^T H^T) = sum_k (H U root_k)^2
        r = posterior(shifted(-root[:, k]) - m0 + base)
        add["z"] += r.z_mean**2
        add["slope"] += r.slope_mean**2
        add["rate"] += np.diff(r.z_mean, axis=0) ** 2
    records = None
    if n_records:
        records = np.stack([to_modes @ shifted(c_hat - root @ rng.standard_normal(root.shape[1]))
                            for _ in range(n_records)])
    return mean, add, records


def declared_rebaselines(ids, days, change, events) -> Rebaselines:
    """New references declared by the events table (:func:`check_events`): each row's sensor from its first daily
    angle after the row's date; the event's day itself mixes both mountings and is left out (:func:`rebaseline_daily`).
    A row after the sensor's last day, or before its second, changes nothing."""
    c = np.asarray(change, float)
    pos = {s: j for j, s in enumerate(ids)}
    dates = pd.DatetimeIndex(days)
    rows = []
    for sid, date in zip(events["sensor_id"], events["date"]):
        j = pos[sid]
        ok = np.flatnonzero(np.isfinite(c[:, j]))
        after = ok[dates[ok] > pd.Timestamp(date).normalize()]
        before = ok[dates[ok] < pd.Timestamp(date).normalize()]
        if after.size and before.size:
            rows.append((j, int(after[0]), int(before[-1])))
    if not rows:
        return _empty()
    j, b, a = (np.array(v, int) for v in zip(*rows))
    return Rebaselines(j, b, a, np.zeros(j.size), np.full(j.size, np.nan), np.ones(j.size, bool))


def _first_steps(x, change, rb: Rebaselines) -> Rebaselines:
    """``rb`` with ``step`` the sensor's change across the changeover minus its neighbours' (sensors with a daily
    angle on every day from ``before`` to ``day`` and no new reference of their own), the first estimate of the offset
    (0 when no neighbour has one)."""
    c = np.asarray(change, float)
    steps = []
    moved = np.isin(np.arange(c.shape[1]), rb.sensor)  # a sensor with a new reference is nobody's neighbour
    for j, b, a in zip(rb.sensor, rb.day, rb.before):
        reference = np.isfinite(c[a:b + 1]).all(axis=0) & ~moved
        step = c[b, j] - c[a, j] - _neighbour_change(x, c, a, b, j, reference)
        steps.append(step if np.isfinite(step) else 0.0)
    return replace(rb, step=np.asarray(steps, float))


def _merge(first: Rebaselines, second: Rebaselines) -> Rebaselines:
    """Both sets of new references, a detected one dropped where a declared one starts on the same sensor-day."""
    declared = set(zip(first.sensor.tolist(), first.day.tolist()))
    keep = np.array([(j, b) not in declared for j, b in zip(second.sensor.tolist(), second.day.tolist())], bool)
    return Rebaselines(*(np.concatenate([getattr(first, f), getattr(second, f)[keep]])
                         for f in ("sensor", "day", "before", "step", "z", "declared")))


def reinstall_stage(x, ids, daily, mode: str, events, warnings: list):
    """The daily angles with declared (``events``) and, with ``mode="detect"``, detected re-installations
    re-baselined (:func:`rebaseline_daily`), and one warning naming them (:func:`reinstall_warning`)."""
    x = np.asarray(x, float)
    change = np.deg2rad(np.asarray(daily.change_deg, float))
    rb = _empty()
    if events is not None and len(events):
        rb = declared_rebaselines(ids, daily.days, change, check_events(events, ids))
    if mode == "detect":
        rb = _merge(rb, find_reinstallations(x, change))
    if not len(rb):
        return daily
    rb = _first_steps(x, change, rb)
    warnings.append(reinstall_warning(ids, daily.days, rb))
    return rebaseline_daily(x, daily, rb)


def check_events(events, sensor_ids=None) -> pd.DataFrame:
    """The events table checked: columns ``sensor_id``, ``date`` (YYYY-MM-DD), ``event`` (``reinstalled`` or
    ``replaced_by``) and, for a replacement, ``new_id`` (the replacing sensor's id in the readings).

    Parameters
    ----------
    events : DataFrame
    sensor_ids : sequence of str, optional
        The site's sensors: every ``sensor_id`` must be one of them.

    Returns
    -------
    DataFrame
        sensor_id, date (Timestamp, midnight), event, new_id (str, "" for a re-installation), sorted by date.

    Raises
    ------
    InputError
        One line naming the row and what is wrong.
    """
    from ..errors import InputError

    missing = [c for c in ("sensor_id", "date", "event") if c not in events.columns]
    if missing:
        raise InputError(f"events table: missing column(s) {missing}; expected sensor_id, date, event, new_id "
                         "(docs/file-formats.md).")
    ev = pd.DataFrame({"sensor_id": events["sensor_id"].astype(str).str.strip(),
                       "date": pd.to_datetime(events["date"].astype(str), errors="coerce", format="mixed"),
                       "event": events["event"].astype(str).str.strip().str.lower(),
                       "new_id": (events["new_id"].fillna("").astype(str).str.strip() if "new_id" in events.columns
                                  else "")})
    known = None if sensor_ids is None else set(map(str, sensor_ids))
    for k, row in enumerate(ev.itertuples(index=False)):
        where = f"events table, row {k + 2}"
        if pd.isna(row.date):
            raise InputError(f"{where}: date {events['date'].iloc[k]!r} is not a date (YYYY-MM-DD).")
        if row.event not in EVENT_KINDS:
            raise InputError(f"{where}: event {events['event'].iloc[k]!r} is not one of {EVENT_KINDS}.")
        if row.event == "replaced_by" and not row.new_id:
            raise InputError(f"{where}: a replacement needs new_id, the replacing sensor's id in the readings.")
        if known is not None and row.sensor_id not in known:
            raise InputError(f"{where}: sensor {row.sensor_id!r} is not in the sensors table.")
    ev["date"] = ev["date"].dt.tz_localize(None).dt.normalize() if ev["date"].dt.tz is not None \
        else ev["date"].dt.normalize()
    return ev.sort_values("date", kind="stable").reset_index(drop=True)


def apply_replacements(sensors: pd.DataFrame, readings: pd.DataFrame, events) -> tuple:
    """Sensors and readings tables with each replacement (``event`` ``replaced_by``) merged into the replaced sensor:
    the new sensor's readings from the event's date on are given the old id (the old sensor's own readings from that
    date on are dropped: it was taken away), and the new sensor's row, at the same station or not, leaves the sensors
    table. The series then goes on under the old id with a new reference on that date (``events`` in
    :class:`~longprofile.rail.SettlementSettings`).

    Returns
    -------
    sensors, readings : DataFrame
    notes : list of str
        One line per replacement (readings moved, and the distance between the two stations when both are given).
    """
    from ..errors import InputError

    ev = check_events(events)
    s, r = sensors.copy(), readings.copy()
    sid = r["sensor_id"].astype(str)
    t = pd.to_datetime(r["timestamp"], errors="coerce", utc=False, format="mixed")
    if getattr(t.dt, "tz", None) is not None:
        t = t.dt.tz_convert(None)
    notes, drop = [], np.zeros(len(r), bool)
    for row in ev[ev["event"] == "replaced_by"].itertuples(index=False):
        if row.new_id == row.sensor_id:
            raise InputError(f"events table: sensor {row.sensor_id} 'replaced_by' itself; use event 'reinstalled'.")
        new, old = (sid == row.new_id).to_numpy(), (sid == row.sensor_id).to_numpy()
        after = (t >= row.date).to_numpy()
        drop |= (old & after) | (new & ~after)
        r.loc[new & after, "sensor_id"] = row.sensor_id
        where = s["sensor_id"].astype(str) == row.new_id
        moved = ""
        if where.any() and "x_m" in s.columns:
            dx = abs(float(s.loc[where, "x_m"].iloc[0]) - float(s.loc[s["sensor_id"].astype(str) == row.sensor_id,
                                                                      "x_m"].iloc[0]))
            moved = f", stations {dx * 1e3:.0f} mm apart (the old one's is kept)"
        s = s[~where]
        notes.append(f"sensor {row.sensor_id} replaced by {row.new_id} on {row.date:%Y-%m-%d}: "
                     f"{int((new & after).sum())} reading(s) of {row.new_id} continue {row.sensor_id}'s series with a "
                     f"new reference{moved}")
    return s.reset_index(drop=True), r[~drop].reset_index(drop=True), notes


def site_with_events(sensors, readings, survey=None, controls=None, events=None, **options):
    """The site of ``rail settle --events`` and of the monitoring service: the tables validated
    (:func:`~longprofile.rail.validate_site`) after each declared replacement is merged (:func:`apply_replacements`),
    with one warning per merge, and the events checked (:func:`check_events`).

    Parameters
    ----------
    sensors, readings, survey, controls : DataFrame or None
        The site's tables, as :func:`~longprofile.rail.validate_site` takes them.
    events : DataFrame or None
        The events table (sensor_id, date, event, new_id); None: no event.
    **options
        Those of :func:`~longprofile.rail.validate_site`.

    Returns
    -------
    site : SiteData
    events : DataFrame or None
        The checked events (``events`` of :class:`~longprofile.rail.SettlementSettings`), None without.
    """
    from ._data import validate_site

    if events is None:
        return validate_site(sensors, readings, survey, controls, **options), None
    ev = check_events(events)
    notes: list = []
    if (ev["event"] == "replaced_by").any():
        sensors, readings, notes = apply_replacements(sensors, readings, ev)
    site = validate_site(sensors, readings, survey, controls, **options)
    return (replace(site, warnings=tuple(site.warnings) + tuple(notes)) if notes else site), ev
