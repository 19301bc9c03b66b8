"""Synthetic inclinometer sites with ground truth, modelled on the two sites of paper 004.

Presets
-------
"mittersheim-like"
    58 sensors over 167.5 m, 4 weeks from Monday 2019-11-18, works from week 2: a ~2 cm
    settlement bowl appearing in steps during night works (01:00-03:00) on some weekdays;
    air temperature -5..15 °C; per-sensor linear thermal coefficients of either sign; 5e-3 deg
    noise; 0.2 % outliers; one dead sensor (stuck) and one reversed sensor (inside the bowl).
"farebersviller-like"
    75 sensors over 222 m, 3 months from 2021-03-03, -10..40 °C, thermal response through a
    per-sensor continuous first-order lag (2-6 h: hysteresis loops, §5.1; the same site whatever the
    sampling interval), a bowl deepening to ~3 cm,
    initial survey and monthly control surveys every 10 m (2 mm noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..errors import InputError

__all__ = ["SyntheticSite", "SiteTruth", "simulate_site", "PRESETS"]


@dataclass(frozen=True)
class _Preset:
    n_sensors: int
    length_m: float
    start: str
    n_days: int
    works_from_day: int
    bowl_center_m: float
    bowl_width_m: float
    bowl_depth_m: float
    n_steps: int
    temp_range_c: tuple
    thermal_coef_deg_per_c: tuple
    thermal_lag_hours: tuple | None
    noise_deg: float
    outlier_fraction: float
    dead_sensor: int | None
    reversed_sensor_offset_m: float | None
    survey_step_m: float | None
    control_days: tuple


PRESETS = {
    "mittersheim-like": _Preset(
        n_sensors=58, length_m=167.5, start="2019-11-18", n_days=28, works_from_day=7, bowl_center_m=105.0,
        bowl_width_m=12.0, bowl_depth_m=0.02, n_steps=4, temp_range_c=(-5.0, 15.0),
        thermal_coef_deg_per_c=(1e-3, 3e-3), thermal_lag_hours=None, noise_deg=5e-3, outlier_fraction=0.002,
        dead_sensor=12, reversed_sensor_offset_m=-9.0, survey_step_m=None, control_days=()),
    "farebersviller-like": _Preset(
        n_sensors=75, length_m=222.0, start="2021-03-03", n_days=95, works_from_day=10, bowl_center_m=120.0,
        bowl_width_m=18.0, bowl_depth_m=0.03, n_steps=14, temp_range_c=(-10.0, 40.0),
        thermal_coef_deg_per_c=(1e-3, 3e-3), thermal_lag_hours=(2.0, 6.0), noise_deg=5e-3, outlier_fraction=0.002,
        dead_sensor=None, reversed_sensor_offset_m=None, survey_step_m=10.0, control_days=(34, 68, 92)),
}


@dataclass(frozen=True, eq=False)
class SiteTruth:
    """Ground truth of a synthetic site.

    Attributes
    ----------
    days : (D,) datetime64[ns] ndarray
        Calendar days.
    x : (N,) ndarray
        Sensor stations, m.
    settlement : (D, N) ndarray
        True altitude change z(x, noon of day d) - z(x, start), m (negative = down).
    slope_change : (D, N) ndarray
        True slope change at the sensors at noon, rad.
    initial_z : (N,) ndarray
        True initial altitude at the sensors, m.
    thermal_coef : (N,) ndarray
        Angle bias per °C of each sensor, deg/°C.
    thermal_lag_hours : (N,) ndarray
        Time constant of each sensor's thermal response, h (0 = instantaneous).
    work_days : (D,) bool ndarray
        Days with works (settlement steps happen during their night).
    bad_sensors : dict
        sensor_id -> "dead" or "reversed".
    """

    days: np.ndarray
    x: np.ndarray
    settlement: np.ndarray
    slope_change: np.ndarray
    initial_z: np.ndarray
    thermal_coef: np.ndarray
    thermal_lag_hours: np.ndarray
    work_days: np.ndarray
    bad_sensors: dict


@dataclass(frozen=True, eq=False)
class SyntheticSite:
    """Tables of a synthetic site (same columns as the files users give) and its truth."""

    sensors: pd.DataFrame
    readings: pd.DataFrame
    survey: pd.DataFrame
    controls: pd.DataFrame | None
    truth: SiteTruth
    preset: str

    def truth_table(self) -> pd.DataFrame:
        """The truth as a long table, one row per day and sensor: date, sensor_id, x_m, dz_true_m (m),
        status_true ("ok" or the defect of a bad sensor), as ``rail simulate`` writes it (truth.csv)."""
        tr = self.truth
        D, N = tr.settlement.shape
        ids = self.sensors["sensor_id"]
        return pd.DataFrame({"date": np.repeat(pd.DatetimeIndex(tr.days).strftime("%Y-%m-%d"), N),
                             "sensor_id": np.tile(ids.to_numpy(), D), "x_m": np.tile(tr.x, D),
                             "dz_true_m": tr.settlement.ravel(),
                             "status_true": np.tile([tr.bad_sensors.get(s, "ok") for s in ids], D)})


def _bowl(x, center, width):
    """Unit bowl shape b(x) (0 far away, -1 at the center) and its derivative."""
    u = (x - center) / width
    b = -np.exp(-0.5 * u**2)
    return b, -u / width * b


#: Most readings :func:`simulate_site` makes (about 120 bytes each while simulating): ``rail simulate --days 100000``
#: was killed by the kernel at 22 GB after minutes (session 35). A year of 58 sensors read every minute is 3e7.
MAX_SIMULATED_READINGS = 50_000_000


def simulate_site(preset: str = "mittersheim-like", *, seed=0, sampling_minutes: float = 10.0,
                  n_days: int | None = None) -> SyntheticSite:
    """Simulate an inclinometer site with known settlement (ground truth).

    Parameters
    ----------
    preset : {"mittersheim-like", "farebersviller-like"}
        Site model (module docstring).
    seed : int or numpy.random.Generator, default 0
        Everything random comes from this generator: same seed, same site.
    sampling_minutes : float, default 10
        Interval between readings, min (the paper's sensors: a few minutes).
    n_days : int, optional
        Shorten (or lengthen) the record; default from the preset.

    Returns
    -------
    SyntheticSite
        ``sensors`` (sensor_id, x_m), ``readings`` (timestamp, sensor_id, angle_deg,
        temperature_c), ``survey`` (x_m, z_m), ``controls`` (date, x_m, z_m) or None, ``truth``.
    """
    if preset not in PRESETS:
        raise InputError(f"unknown preset {preset!r}; choose one of {sorted(PRESETS)}.")
    p = PRESETS[preset]
    rng = np.random.default_rng(seed)
    if not (np.isfinite(sampling_minutes) and 0 < sampling_minutes <= 240):
        raise InputError(f"sampling_minutes must be in (0, 240]; got {sampling_minutes!r}.")
    D = p.n_days if n_days is None else int(n_days)
    if D < 2:
        raise InputError(f"n_days must be >= 2; got {n_days!r}.")
    N = p.n_sensors
    x = np.round(np.linspace(0.0, p.length_m, N) + np.r_[0.0, rng.uniform(-0.1, 0.1, N - 2), 0.0], 3)
    ids = [f"S{i + 1:02d}" for i in range(N)]
    start = pd.Timestamp(p.start)
    days = pd.date_range(start, periods=D, freq="D")
    dt_h = sampling_minutes / 60.0
    t_h = np.arange(0.0, D * 24.0, dt_h)  # hours since start
    T = t_h.size
    if T * N > MAX_SIMULATED_READINGS:
        raise InputError(f"{D} days read every {sampling_minutes:g} min on {N} sensors are {T * N:.3g} readings, more "
                         f"than {MAX_SIMULATED_READINGS:.0e} (about {T * N * 1.2e-7:.0f} GB to simulate): reduce the days "
                         "(--days) or read less often (--sampling-minutes).")
    step_days, amounts, work_days = _settlement_steps(p, rng, days)
    shape, dshape = _bowl(x, p.bowl_center_m, p.bowl_width_m)
    depth_t = _depth_at(t_h, step_days, amounts)  # (T,)
    noon = 24.0 * np.arange(D) + 12.0
    depth_noon = _depth_at(noon, step_days, amounts)
    settlement = depth_noon[:, None] * shape[None, :]
    slope_change = depth_noon[:, None] * dshape[None, :]
    slope_t = depth_t[:, None] * dshape[None, :]  # (T, N) rad
    temp = _temperatures(p, rng, t_h, D, N)
    angle, coef, lag, bad = _angles(p, rng, x, ids, temp, slope_t, dt_h)
    # whole milliseconds: float hours gave 00:19:59.999999998, which users copy as a template (session 35)
    stamps = start + pd.to_timedelta(np.round(t_h * 3.6e6).astype(np.int64), unit="ms")
    readings = pd.DataFrame({
        "timestamp": np.repeat(stamps.to_numpy(), N),
        "sensor_id": np.tile(ids, T),
        "angle_deg": angle.ravel(),
        "temperature_c": np.round(temp.ravel(), 2),
    })
    z0 = _initial_profile(rng)
    survey, controls = _survey_and_controls(p, rng, x, days, z0, step_days, amounts)
    sensors = pd.DataFrame({"sensor_id": ids, "x_m": np.round(x, 3)})
    truth = SiteTruth(days=days.to_numpy(), x=np.round(x, 3), settlement=settlement, slope_change=slope_change,
                      initial_z=z0(x), thermal_coef=coef, thermal_lag_hours=lag, work_days=work_days,
                      bad_sensors=bad)
    return SyntheticSite(sensors=sensors, readings=readings, survey=survey, controls=controls, truth=truth,
                         preset=preset)


def _settlement_steps(p, rng, days):
    """Settlement steps on some weekdays after works start: (step days, amounts in m, work-day mask)."""
    D = len(days)
    weekday = np.array([d.weekday() < 5 for d in days])
    candidates = np.nonzero(weekday & (np.arange(D) >= p.works_from_day))[0]
    if candidates.size:
        k = min(p.n_steps, candidates.size)
        step_days = np.sort(rng.choice(candidates, size=k, replace=False))
        amounts = rng.dirichlet(np.full(k, 2.0)) * p.bowl_depth_m
    else:
        step_days, amounts = np.array([], int), np.array([])
    work_days = np.zeros(D, bool)
    work_days[step_days] = True
    return step_days, amounts, work_days


def _depth_at(th, step_days, amounts):
    """Bowl depth at the hours ``th``: a linear ramp 01:00 -> 03:00 on each step day."""
    out = np.zeros_like(th, dtype=float)
    for dd, a in zip(step_days, amounts):
        out += a * np.clip((th - (24.0 * dd + 1.0)) / 2.0, 0.0, 1.0)
    return out


def _temperatures(p, rng, t_h, D, N):
    """(T, N) sensor temperatures: daily cycle + slow weather, scaled to the preset range; per-sensor offsets."""
    T = t_h.size
    daily = np.sin(2 * np.pi * (t_h - 9.0) / 24.0)
    n_knots = max(D // 3, 2)
    weather = np.interp(t_h, np.linspace(0, t_h[-1], n_knots), rng.normal(0, 1, n_knots))
    season = np.linspace(0, 1, T) if p.temp_range_c[1] - p.temp_range_c[0] > 30 else 0.0
    air = 1.0 * daily + 0.8 * weather + 2.0 * season
    lo, hi = p.temp_range_c
    air = lo + (hi - lo) * (air - air.min()) / (air.max() - air.min())
    return air[:, None] + rng.normal(0, 0.3, N)[None, :] + rng.normal(0, 0.05, (T, N))


def lagged_temperature(temperature, dt_h: float, tau_h: float) -> np.ndarray:
    """The temperature a sensor feels through a continuous first-order lag, tau dT_s/dt = T - T_s, of a regularly
    sampled temperature taken linear between samples; in equilibrium at the start.

    Exactly, T_s[k] = a T_s[k-1] + (1 - b) T[k] + (b - a) T[k-1], a = exp(-h/tau), b = (1 - a) tau / h (h = dt_h).
    The response does not depend on the logger's interval h. Until session 37 it was a step-held one (T held over
    each interval), whose lag was ~h/2 shorter: an hourly site was another site than the same one read every
    10 min, and its lag was not the first-order one the estimator fits (docs/rail.md, "The thermal model chosen
    by the data").

    Parameters
    ----------
    temperature : (T,) ndarray
        Samples every ``dt_h`` hours, °C.
    dt_h, tau_h : float
        Sampling interval and time constant, h (both > 0).

    Returns
    -------
    (T,) ndarray
    """
    from scipy.signal import lfilter  # imported on use: scipy.signal costs 0.6-1 s at start-up

    a = np.exp(-dt_h / tau_h)
    b = (1.0 - a) * tau_h / dt_h
    return lfilter([1.0 - b, b - a], [1.0, -a], temperature, zi=[b * temperature[0]])[0]


def _angles(p, rng, x, ids, temp, slope_t, dt_h):
    """Readings in degrees with thermal bias (linear, optionally lagged), noise, outliers and bad sensors:
    (angle (T, N), thermal coefficients, lags in h, bad sensors {id: defect})."""
    T, N = temp.shape
    kmin, kmax = p.thermal_coef_deg_per_c
    coef = rng.uniform(kmin, kmax, N) * rng.choice([-1.0, 1.0], N)
    if p.thermal_lag_hours is None:
        lag = np.zeros(N)
        felt = temp
    else:
        lag = rng.uniform(*p.thermal_lag_hours, N)
        felt = np.column_stack([lagged_temperature(temp[:, i], dt_h, lag[i]) for i in range(N)])
    offset = rng.normal(0, 0.5, N)
    sign = np.ones(N)
    bad = {}
    if p.reversed_sensor_offset_m is not None:
        rv = int(np.argmin(np.abs(x - (p.bowl_center_m + p.reversed_sensor_offset_m))))
        sign[rv] = -1.0
        bad[ids[rv]] = "reversed"
    angle = offset[None, :] + sign[None, :] * np.rad2deg(slope_t) + coef[None, :] * felt
    angle += rng.normal(0, p.noise_deg, (T, N))
    n_out = int(round(p.outlier_fraction * T * N))
    oi = rng.integers(0, T, n_out); oj = rng.integers(0, N, n_out)
    angle[oi, oj] += rng.normal(0, 0.5, n_out)
    if p.dead_sensor is not None:
        angle[:, p.dead_sensor] = np.round(offset[p.dead_sensor], 4)
        bad[ids[p.dead_sensor]] = "dead"
    angle = np.round(angle, 5)  # the sensors' resolution is 1e-4 deg; keep one more digit
    return angle, coef, lag, bad


def _initial_profile(rng):
    """The initial altitude z0(x), m: a grade plus three waves."""
    grade = rng.uniform(-3e-3, 3e-3)
    waves = rng.normal(0, 1, 3)

    def z0(xx):
        return 210.0 + grade * xx + 4e-3 * (waves[0] * np.sin(2 * np.pi * xx / 60) + waves[1] * np.cos(2 * np.pi * xx / 37)
                                            + waves[2] * np.sin(2 * np.pi * xx / 23))

    return z0


def _survey_and_controls(p, rng, x, days, z0, step_days, amounts):
    """Initial survey table and control surveys (None without control days)."""
    D = len(days)
    if p.survey_step_m is None:
        sx = x.copy()
    else:
        sx = np.arange(0.0, x[-1] + 1e-9, p.survey_step_m)
        if sx[-1] < x[-1]:
            sx = np.r_[sx, x[-1]]
    survey = pd.DataFrame({"x_m": np.round(sx, 3), "z_m": np.round(z0(sx) + rng.normal(0, 2e-3, sx.size), 4)})
    controls = None
    if p.control_days:
        rows = []
        cx = np.arange(0.0, x[-1] + 1e-9, p.survey_step_m or 10.0)
        cshape, _ = _bowl(cx, p.bowl_center_m, p.bowl_width_m)
        for cd in p.control_days:
            if cd >= D:
                continue
            z = z0(cx) + _depth_at(np.array([24.0 * cd + 12.0]), step_days, amounts)[0] * cshape \
                + rng.normal(0, 2e-3, cx.size)
            rows.append(pd.DataFrame({"date": days[cd].strftime("%Y-%m-%d"), "x_m": np.round(cx, 3),
                                      "z_m": np.round(z, 4)}))
        controls = pd.concat(rows, ignore_index=True) if rows else None
    return survey, controls
