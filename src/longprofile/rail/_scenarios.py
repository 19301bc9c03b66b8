"""Independent scenario generators for calibrating the rail settlement estimator (issue 13).

Written separately from :mod:`longprofile.rail._synthetic` (whose noise model the estimator
assumes) so that the estimator can be validated on effects it does not model:

* a per-sensor first-order **thermal lag** with a random time constant of minutes to hours
  (log-uniform), a thermal coefficient of either sign and a small quadratic term;
* a **random-walk bias drift** per sensor, diffusion log-uniform in a range such as
  0.001-0.01 deg/sqrt(day), simulated at the reading interval;
* **temperature**: a daily cycle of random amplitude, **weather fronts** (steps of the daily
  mean of several deg C with a smooth transition) and a slow trend; a shade offset per sensor;
* heavy-tailed reading noise (Student t, 4 dof) of random scale and isolated outliers;
* **sensor faults**: reversed (placed where the bowl tilts the track, else undetectable and
  harmless), frozen (stuck from a random day on), detached (a jump of the angle at a random
  time and a new thermal coefficient), dead (no readings from an early day on);
* different **sensor counts and spacings** (irregular, jittered stations);
* **logger outages**: a group of consecutive sensors (one logger's) without any reading for whole days;
* **failed temperature channels**: a group of consecutive sensors whose temperature is empty or stuck at one value
  from a random day on, and whose own temperature (which drives their thermal bias) swings more or less and lags more than their
  neighbours' (sun exposure);
* a **settlement bowl** from nearby works with random depth, position, width and timing,
  appearing during night works on random days, plus slow creep between them.

Nothing here estimates anything: :func:`simulate_scenario` returns the tables ``rail settle``
reads and the truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from ..errors import InputError

__all__ = ["ScenarioFamily", "Scenario", "ScenarioTruth", "simulate_scenario", "SCENARIO_FAMILIES",
           "FAULT_KINDS", "BOWL_SHAPES", "SHAPE_FAMILIES"]

FAULT_KINDS = ("reversed", "frozen", "detached", "dead")
#: Settlement shapes of :attr:`ScenarioFamily.bowl_shape` (:func:`_bowl_shape`): the Gaussian bowl of every family of
#: :data:`SCENARIO_FAMILIES`, and shapes that are not a Gaussian bowl (robustness of the health tests, docs/rail.md).
BOWL_SHAPES = ("gaussian", "asymmetric", "two-bowls", "ramp", "tilt", "joint-step", "none")


@dataclass(frozen=True)
class ScenarioFamily:
    """Parameter ranges of one family member; every draw samples its site inside them.

    Ranges are (low, high); ``*_log`` ranges are sampled log-uniformly. ``control_surveys``: that many control
    surveys (the initial survey's points levelled again on distinct days of the last two thirds, with
    ``survey_noise_m``; :attr:`Scenario.controls`); 0, the default, none. ``logger_outages``: that many outages,
    each ``outage_sensors`` consecutive sensors without any reading for ``outage_days`` whole days after the
    reference day (:func:`_logger_outages`); 0, the default, none. ``temperature_failures``: that many groups of
    ``failure_sensors`` consecutive sensors whose temperature channel reports nothing (kind "empty") or one constant
    value ("stuck") from a random day on (day 0: the whole record; the kind drawn from ``failure_kinds``) and whose
    own temperature swings ``failure_swing`` times their neighbours' about its daily mean and lags
    ``failure_extra_lag_minutes`` more, for the whole record (:func:`_temperature_failures`; groups may overlap, and
    the later group decides a shared sensor's channel); 0, none.
    """

    name: str
    n_sensors: tuple = (20, 40)
    spacing_m: tuple = (2.0, 4.0)
    n_days: tuple = (21, 28)
    sampling_minutes: float = 30.0
    noise_deg: tuple = (2e-3, 6e-3)
    outlier_fraction: float = 0.001
    thermal_coef_deg_per_c: tuple = (0.5e-3, 3e-3)
    thermal_quadratic_deg_per_c2: float = 2e-5
    thermal_lag_minutes_log: tuple = (5.0, 240.0)
    drift_deg_per_sqrt_day_log: tuple | None = None
    daily_swing_c: tuple = (2.0, 8.0)
    front_std_c: float = 4.0
    front_every_days: tuple = (2.0, 5.0)
    trend_c: tuple = (-5.0, 5.0)
    bowl_depth_m: tuple = (0.005, 0.025)
    bowl_width_m: tuple = (6.0, 20.0)
    n_work_days: tuple = (2, 6)
    creep_fraction: tuple = (0.0, 0.3)
    faults: tuple = ()
    survey_step_m: tuple = (3.0, 10.0)
    survey_noise_m: float = 2e-3
    noise_free: bool = False
    bowl_shape: str = "gaussian"
    control_surveys: int = 0
    logger_outages: int = 0
    outage_sensors: tuple = (6, 12)
    outage_days: tuple = (1, 4)
    temperature_failures: int = 0
    failure_sensors: tuple = (2, 8)
    failure_swing: tuple = (0.6, 1.4)
    failure_extra_lag_minutes: tuple = (0.0, 120.0)
    failure_kinds: tuple = ("empty", "stuck")


SCENARIO_FAMILIES = {
    "lag-swings": ScenarioFamily("lag-swings"),
    "drift": ScenarioFamily("drift", drift_deg_per_sqrt_day_log=(1e-3, 1e-2)),
    "drift-fronts": ScenarioFamily("drift-fronts", drift_deg_per_sqrt_day_log=(1e-3, 1e-2), front_std_c=7.0,
                                   daily_swing_c=(4.0, 10.0)),
    "sparse-drift": ScenarioFamily("sparse-drift", n_sensors=(12, 18), spacing_m=(4.0, 6.0),
                                   drift_deg_per_sqrt_day_log=(1e-3, 1e-2)),
    "faults": ScenarioFamily("faults", drift_deg_per_sqrt_day_log=(1e-3, 3e-3), faults=FAULT_KINDS),
    # rails heated by the sun: daily swings of 15-30 degC and sensor lags of 1-6 h (hysteresis loops of paper 004 §5.1,
    # the farebersviller-like preset's), where the linear thermal model leaves a loop in every day's readings
    "sun-lag": ScenarioFamily("sun-lag", daily_swing_c=(15.0, 30.0), thermal_lag_minutes_log=(60.0, 360.0)),
    # loggers that stop for days (power, telemetry): two outages of 6-12 consecutive sensors for 1-4 days each
    "drift-outages": ScenarioFamily("drift-outages", drift_deg_per_sqrt_day_log=(1e-3, 1e-2), logger_outages=2),
    # temperature channels that fail (a probe, a logger's temperature bus): two groups of 2-8 consecutive sensors
    # report no temperature, or one stuck value, from a random day on; their own temperature is not quite their
    # neighbours'
    "drift-temperature-failures": ScenarioFamily("drift-temperature-failures", drift_deg_per_sqrt_day_log=(1e-3, 1e-2),
                                                 temperature_failures=2),
}
#: The ``faults`` family with a settlement that is not a Gaussian bowl (:data:`BOWL_SHAPES`; docs/rail.md, "Sensor
#: health, step 14"): what the health tests flag when the settlement has another shape.
SHAPE_FAMILIES = {f"faults-{kind}": replace(SCENARIO_FAMILIES["faults"], name=f"faults-{kind}", bowl_shape=kind)
                  for kind in BOWL_SHAPES[1:]}
#: ``transition``: the joint step without sensor faults (one side of the span settling through a 0.6-3 m transition,
#: e.g. an embankment against a bridge abutment or a culvert, seen by healthy sensors). In ``faults-joint-step`` the
#: reversed and frozen sensors are placed where the track tilts most, i.e. on the step's one or two witnesses
#: (docs/rail.md, "The settlement's ends when one sensor carries the evidence"); here the witnesses are healthy.
SHAPE_FAMILIES["transition"] = replace(SCENARIO_FAMILIES["faults"], name="transition", bowl_shape="joint-step",
                                       faults=())
#: The other shapes with healthy sensors too (``<shape>-healthy``): what the estimator does on the shape itself, apart
#: from the information the ``faults-*`` families remove by placing the reversed and frozen sensors on the shape's
#: steepest part (a ramp's or a narrow flank's one or two witnesses; docs/calibration.md).
SHAPE_FAMILIES.update({f"{kind}-healthy": replace(SCENARIO_FAMILIES["faults"], name=f"{kind}-healthy", bowl_shape=kind,
                                                  faults=()) for kind in ("asymmetric", "two-bowls", "ramp", "tilt")})


@dataclass(frozen=True, eq=False)
class ScenarioTruth:
    """Ground truth of a scenario.

    Attributes
    ----------
    days : (D,) datetime64[ns] ndarray
    x : (N,) ndarray
        Stations, m.
    settlement : (D, N) ndarray
        True altitude change since day 0 at the sensors, noon of each day, m (negative = down).
    slope_change : (D, N) ndarray
        True slope change dz'(x_i, noon) since day 0, rad.
    initial_z, initial_slope : (N,) ndarray
        True initial altitude (m) and slope dz0/dx at the sensors.
    thermal_coef, thermal_lag_minutes, drift_deg_per_sqrt_day : (N,) ndarray
        Each sensor's thermal coefficient (deg/degC), lag time constant (min) and drift diffusion.
    faults : dict
        sensor_id -> fault kind (:data:`FAULT_KINDS`).
    work_days : (D,) bool ndarray
    params : dict
        The scalars drawn for the site (bowl, temperatures, noise).
    """

    days: np.ndarray
    x: np.ndarray
    settlement: np.ndarray
    slope_change: np.ndarray
    initial_z: np.ndarray
    initial_slope: np.ndarray
    thermal_coef: np.ndarray
    thermal_lag_minutes: np.ndarray
    drift_deg_per_sqrt_day: np.ndarray
    faults: dict
    work_days: np.ndarray
    params: dict = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class Scenario:
    """Tables of a scenario (the columns ``rail settle`` reads) and its truth; ``controls`` (date, x_m, z_m) only with
    ``ScenarioFamily.control_surveys``."""

    sensors: pd.DataFrame
    readings: pd.DataFrame
    survey: pd.DataFrame
    truth: ScenarioTruth
    family: str
    seed: int
    controls: pd.DataFrame | None = None


def _loguniform(rng, lo_hi, size=None):
    lo, hi = lo_hi
    return np.exp(rng.uniform(np.log(lo), np.log(hi), size))


def _lagged(temp, dt_min, tau_min):
    """First-order lag of a regularly sampled temperature (exact for a step-held input), per column."""
    from scipy.signal import lfilter  # imported on use: scipy.signal costs ~1 s at start-up

    out = np.empty_like(temp)
    for i in range(temp.shape[1]):
        a = np.exp(-dt_min / tau_min[i])
        out[:, i] = lfilter([1.0 - a], [1.0, -a], temp[:, i], zi=[a * temp[0, i]])[0]
    return out


def simulate_scenario(family: ScenarioFamily | str, seed: int = 0, **overrides) -> Scenario:
    """Draw one site of a scenario family (module docstring) with its truth.

    Parameters
    ----------
    family : ScenarioFamily or str
        A member of :data:`SCENARIO_FAMILIES` or its name.
    seed : int
        Everything random comes from ``numpy.random.default_rng(seed)``.
    **overrides
        Fields of the family to replace for this draw (e.g. ``noise_free=True``).

    Returns
    -------
    Scenario
        ``sensors`` (sensor_id, x_m), ``readings`` (timestamp, sensor_id, angle_deg,
        temperature_c), ``survey`` (x_m, z_m) and ``truth``. With ``noise_free=True`` the angle is
        exactly arctan(z0' + dz') in degrees plus a constant offset per sensor (no noise, drift,
        thermal bias or fault) and the survey is exact.
    """
    if isinstance(family, str):
        known = {**SCENARIO_FAMILIES, **SHAPE_FAMILIES}
        if family not in known:
            raise InputError(f"unknown scenario family {family!r}; choose one of {sorted(known)}.")
        family = known[family]
    if overrides:
        family = replace(family, **overrides)
    f = family
    rng = np.random.default_rng(seed)
    N = int(rng.integers(f.n_sensors[0], f.n_sensors[1] + 1))
    D = int(rng.integers(f.n_days[0], f.n_days[1] + 1))
    gaps = rng.uniform(f.spacing_m[0], f.spacing_m[1], N - 1)
    x = np.round(np.r_[0.0, np.cumsum(gaps)], 3)
    L = x[-1]
    ids = [f"I{i + 1:03d}" for i in range(N)]
    start = pd.Timestamp("2024-01-08") + pd.Timedelta(days=int(rng.integers(0, 300)))
    days = pd.date_range(start, periods=D, freq="D")
    dt_min = float(f.sampling_minutes)
    t_min = np.arange(0.0, D * 1440.0, dt_min)
    T = t_min.size
    t_day = t_min / 1440.0
    bowl = _scenario_bowl(f, rng, L, D)
    depth_at, depth, width, center, work = bowl["depth_at"], bowl["depth"], bowl["width"], bowl["center"], bowl["work"]
    shape, dshape = _bowl_shape(f.bowl_shape, x, center, width, np.random.default_rng([int(seed), 7]))
    noon = np.arange(D) + 0.5
    settlement = depth_at(noon)[:, None] * shape[None, :]
    slope_change = depth_at(noon)[:, None] * dshape[None, :]
    z0, dz0 = _scenario_geometry(rng)
    slope_t = dz0(x)[None, :] + depth_at(t_day)[:, None] * dshape[None, :]  # (T, N) true slope
    true_angle = np.rad2deg(np.arctan(slope_t))
    offset = rng.normal(0, 0.5, N)
    temp, swing, base = _scenario_temperature(f, rng, t_day, D, N)
    failures = _temperature_failures(f, seed, N, D)
    temp_reported, temp_lost = _own_temperatures(temp, failures, t_day, dt_min)
    coef = rng.uniform(*f.thermal_coef_deg_per_c, N) * rng.choice([-1.0, 1.0], N)
    quad = rng.normal(0, f.thermal_quadratic_deg_per_c2, N)
    tau = _loguniform(rng, f.thermal_lag_minutes_log, N)
    drift_rate = (np.zeros(N) if f.drift_deg_per_sqrt_day_log is None
                  else _loguniform(rng, f.drift_deg_per_sqrt_day_log, N))
    noise = rng.uniform(*f.noise_deg)
    if f.noise_free:
        angle = offset[None, :] + true_angle
        faults = {}
        coef = np.zeros(N); quad = np.zeros(N); drift_rate = np.zeros(N)
    else:
        felt = _lagged(temp, dt_min, tau)
        tc = felt - base
        thermal = coef[None, :] * tc + quad[None, :] * tc**2
        drift = np.cumsum(rng.normal(0, 1, (T, N)) * drift_rate[None, :] * np.sqrt(dt_min / 1440.0), axis=0)
        sign = np.ones(N)
        angle = offset[None, :] + true_angle + thermal + drift
        angle += noise * rng.standard_t(4, (T, N)) / np.sqrt(2.0)  # unit-variance t(4)
        n_out = int(round(f.outlier_fraction * T * N))
        angle[rng.integers(0, T, n_out), rng.integers(1, N - 1, n_out)] += rng.normal(0, 0.3, n_out)
        faults = _scenario_faults(f, rng, angle, sign, ids, dshape, depth, work, tc, dt_min)
        angle = np.where(sign[None, :] < 0, 2 * offset[None, :] - angle, angle)
    if not f.noise_free:
        angle = np.round(angle, 5)  # 1e-4 deg resolution, one more digit kept
    outages = _logger_outages(f, seed, N, D)
    for j0, n, d0, k in outages:
        angle[(t_day >= d0) & (t_day < d0 + k), j0:j0 + n] = np.nan
    stamps = start + pd.to_timedelta(t_min, unit="min")
    readings = pd.DataFrame({"timestamp": np.repeat(stamps.to_numpy(), N), "sensor_id": np.tile(ids, T),
                             "angle_deg": angle.ravel(), "temperature_c": np.round(np.where(temp_lost, np.nan,
                                                                                           temp_reported).ravel(), 2)})
    readings = readings[np.isfinite(readings["angle_deg"].to_numpy())].reset_index(drop=True)
    step = rng.uniform(*f.survey_step_m)
    sx = np.arange(0.0, L + 1e-9, step)
    if sx[-1] < L:
        sx = np.r_[sx, L]
    sz = z0(sx) + (0.0 if f.noise_free else rng.normal(0, f.survey_noise_m, sx.size))
    survey = pd.DataFrame({"x_m": np.round(sx, 3), "z_m": sz if f.noise_free else np.round(sz, 4)})
    truth = ScenarioTruth(days=days.to_numpy(), x=x, settlement=settlement, slope_change=slope_change,
                          initial_z=z0(x), initial_slope=dz0(x), thermal_coef=coef, thermal_lag_minutes=tau,
                          drift_deg_per_sqrt_day=drift_rate, faults=faults,
                          work_days=np.isin(np.arange(D), work),
                          params=dict(depth_m=depth, width_m=width, center_m=center, first_work_day=int(work[0]),
                                      bowl_shape=f.bowl_shape,
                                      creep_fraction=bowl["creep"], daily_swing_c=swing, noise_deg=noise,
                                      n_sensors=N, n_days=D, sampling_minutes=dt_min,
                                      logger_outages=[dict(first_sensor=ids[j0], n_sensors=n, first_day=d0, n_days=k)
                                                      for j0, n, d0, k in outages],
                                      temperature_failures=[dict(first_sensor=ids[j0], n_sensors=n, first_day=d0,
                                                                 swing=g, extra_lag_minutes=lag, kind=kind)
                                                            for j0, n, d0, g, lag, kind in failures]))
    controls = None
    if f.control_surveys > 0:
        controls = _scenario_controls(f, seed, days, sx, z0, depth_at, center, width)
    return Scenario(sensors=pd.DataFrame({"sensor_id": ids, "x_m": x}), readings=readings, survey=survey,
                    truth=truth, family=f.name, seed=int(seed), controls=controls)


def _temperature_failures(f, seed, N: int, D: int) -> list:
    """``f.temperature_failures`` failures as (first sensor index, sensors, first day without a temperature, swing
    factor, extra lag in minutes, kind). Drawn from their own stream (``default_rng([seed, 17])``), so that a family's
    sites are otherwise the same with and without them."""
    rng = np.random.default_rng([int(seed), 17])
    out = []
    for _ in range(int(f.temperature_failures)):
        n = int(min(rng.integers(f.failure_sensors[0], f.failure_sensors[1] + 1), N))
        out.append((int(rng.integers(0, N - n + 1)), n, int(rng.integers(0, D - 1)), float(rng.uniform(*f.failure_swing)),
                    float(rng.uniform(*f.failure_extra_lag_minutes)), str(rng.choice(f.failure_kinds))))
    return out


def _own_temperatures(temp, failures, t_day, dt_min) -> tuple[np.ndarray, np.ndarray]:
    """Give the failing sensors their own temperature, in place: about each day's mean, ``swing`` times the site's
    swing, lagged ``extra_lag_minutes`` more (what drives their thermal bias, and what their channel reports until it
    fails). Returns the (T, N) temperatures the channels report (a stuck channel: its value at the failure) and the
    mask of the readings whose temperature is lost (empty)."""
    lost = np.zeros(temp.shape, bool)
    reported = temp.copy()
    day = np.floor(t_day).astype(int)
    for j0, n, d0, g, lag, kind in failures:
        cols = temp[:, j0:j0 + n]
        mean = np.stack([np.bincount(day, c) / np.bincount(day) for c in cols.T], axis=1)[day]
        own = mean + g * (cols - mean)
        temp[:, j0:j0 + n] = _lagged(own, dt_min, np.full(n, lag)) if lag > 0 else own
        after = t_day >= d0  # a sensor in two groups: the later group decides its channel
        reported[:, j0:j0 + n] = temp[:, j0:j0 + n]
        lost[:, j0:j0 + n] = False
        if kind == "stuck":
            reported[after, j0:j0 + n] = temp[np.argmax(after), j0:j0 + n]
        else:
            lost[after, j0:j0 + n] = True
    return reported, lost


def _logger_outages(f, seed, N: int, D: int) -> list:
    """``f.logger_outages`` outages as (first sensor index, sensors, first day, days): ``outage_sensors`` consecutive
    sensors silent for ``outage_days`` whole days, never the reference day 0. Drawn from their own stream
    (``default_rng([seed, 13])``), so that a family's sites are otherwise the same with and without them."""
    rng = np.random.default_rng([int(seed), 13])
    out = []
    for _ in range(int(f.logger_outages)):
        n = int(min(rng.integers(f.outage_sensors[0], f.outage_sensors[1] + 1), N))
        k = int(min(rng.integers(f.outage_days[0], f.outage_days[1] + 1), D - 1))
        out.append((int(rng.integers(0, N - n + 1)), n, int(rng.integers(1, D - k + 1)), k))
    return out


def _scenario_controls(f, seed, days, sx, z0, depth_at, center, width) -> pd.DataFrame:
    """Control surveys (date, x_m, z_m): ``f.control_surveys`` levellings of the initial survey's points on distinct
    days drawn from the last two thirds, each point with the survey's noise. Drawn from their own stream
    (``default_rng([seed, 11])``), so that a family's sites are the same with and without them."""
    rng = np.random.default_rng([int(seed), 11])
    D = len(days)
    pool = np.arange(max(1, D // 3), D)
    chosen = np.sort(rng.choice(pool, size=min(int(f.control_surveys), pool.size), replace=False))
    shape, _ = _bowl_shape(f.bowl_shape, sx, center, width, np.random.default_rng([int(seed), 7]))
    rows = []
    for d in chosen:
        z = z0(sx) + depth_at(np.array([d + 0.5]))[0] * shape
        if not f.noise_free:
            z = np.round(z + rng.normal(0, f.survey_noise_m, sx.size), 4)
        rows.append(pd.DataFrame({"date": days[d].strftime("%Y-%m-%d"), "x_m": np.round(sx, 3), "z_m": z}))
    return pd.concat(rows, ignore_index=True)


def _scenario_bowl(f, rng, L, D) -> dict:
    """Settlement bowl: night steps on random work days + creep between them (depth_at(t in days) -> m)."""
    depth = rng.uniform(*f.bowl_depth_m)
    width = rng.uniform(*f.bowl_width_m)
    center = rng.uniform(0.3 * L, 0.7 * L)
    # the instrumented span covers the works: the ends move < 0.32 % of the depth (|u| >= 3.4) (assumption 1 of docs/rail.md)
    width = min(width, min(center, L - center) / 3.4)
    first_work = int(rng.integers(max(2, D // 5), max(3, D // 2)))
    nwork = int(min(rng.integers(f.n_work_days[0], f.n_work_days[1] + 1), D - first_work))
    work = np.sort(rng.choice(np.arange(first_work, D), size=max(nwork, 1), replace=False))
    creep = rng.uniform(*f.creep_fraction)
    amounts = rng.dirichlet(np.full(work.size, 1.5)) * depth * (1.0 - creep)
    night = rng.uniform(0.5, 4.0, work.size) / 24.0  # step start, fraction of the day
    dur = rng.uniform(0.5, 2.5, work.size) / 24.0

    def depth_at(td):
        out = np.zeros_like(td, dtype=float)
        for d0, a, s, du in zip(work, amounts, night, dur):
            out += a * np.clip((td - (d0 + s)) / du, 0.0, 1.0)
        out += depth * creep * np.clip((td - work[0]) / max(D - work[0], 1.0), 0.0, 1.0)
        return out

    return dict(depth_at=depth_at, depth=depth, width=width, center=center, work=work, creep=creep)


def _bowl_shape(kind: str, x, center: float, width: float, rng):
    """Unit settlement shape at the stations and its exact derivative (1/m): (shape, dshape), shape -1 at the deepest
    point ("tilt": -1 at the far end; "none": 0). "gaussian" draws nothing from ``rng`` (the families' sites
    unchanged); the others draw their extra parameters from it: "asymmetric" one side 0.3-0.7 x as wide; "two-bowls" a
    second Gaussian of 0.4-1 x the depth and 0.5-1 x the width anywhere on the span; "ramp" a flat bottom of
    half-length 0.2-0.5 width between two linear ramps of 0.3-0.8 width; "tilt" a linear tilt over the whole span;
    "joint-step" one side lowered through a tanh transition of half-length 0.3-1.5 m at the centre."""
    x = np.asarray(x, float)
    u = (x - center) / width
    if kind == "gaussian":
        shape = -np.exp(-0.5 * u**2)
        return shape, -u / width * shape
    if kind == "asymmetric":
        w = np.where((x < center) == (rng.random() < 0.5), width, width * rng.uniform(0.3, 0.7))
        shape = -np.exp(-0.5 * ((x - center) / w) ** 2)
        return shape, -(x - center) / w**2 * shape
    if kind == "two-bowls":
        w2, a2 = width * rng.uniform(0.5, 1.0), rng.uniform(0.4, 1.0)
        c2 = rng.uniform(min(3.4 * w2, x[-1] / 2), max(x[-1] - 3.4 * w2, x[-1] / 2))
        g1, g2 = np.exp(-0.5 * u**2), a2 * np.exp(-0.5 * ((x - c2) / w2) ** 2)
        grid = np.linspace(x[0], x[-1], 2001)
        peak = np.max(np.exp(-0.5 * ((grid - center) / width) ** 2) + a2 * np.exp(-0.5 * ((grid - c2) / w2) ** 2))
        return -(g1 + g2) / peak, (u / width * g1 + (x - c2) / w2**2 * g2) / peak
    if kind == "ramp":
        h, ramp = width * rng.uniform(0.2, 0.5), width * rng.uniform(0.3, 0.8)
        d = np.abs(x - center) - h
        shape = -np.clip(1.0 - d / ramp, 0.0, 1.0)
        inside = (d > 0) & (d < ramp)
        return shape, np.where(inside, np.sign(x - center) / ramp, 0.0)
    if kind == "tilt":
        span = x[-1] - x[0]
        return -(x - x[0]) / span, np.full(x.size, -1.0 / span)
    if kind == "joint-step":
        half = rng.uniform(0.3, 1.5)
        v = (x - center) / half
        return -0.5 * (1.0 + np.tanh(v)), -0.5 / half / np.cosh(v) ** 2
    if kind == "none":
        return np.zeros(x.size), np.zeros(x.size)
    raise InputError(f"unknown bowl shape {kind!r}; choose one of {BOWL_SHAPES}.")


def _scenario_geometry(rng):
    """Initial geometry: grade + a few waves, z0(x) and its exact derivative dz0(x) for the angles."""
    grade = rng.uniform(-4e-3, 4e-3)
    amp = rng.normal(0, 3e-3, 3)
    wl = rng.uniform(15.0, 70.0, 3)
    ph = rng.uniform(0, 2 * np.pi, 3)

    def z0(xx):
        return 150.0 + grade * xx + np.sum(amp[:, None] * np.sin(2 * np.pi * np.asarray(xx)[None, :] / wl[:, None]
                                                                  + ph[:, None]), axis=0)

    def dz0(xx):
        return grade + np.sum(amp[:, None] * 2 * np.pi / wl[:, None]
                              * np.cos(2 * np.pi * np.asarray(xx)[None, :] / wl[:, None] + ph[:, None]), axis=0)

    return z0, dz0


def _scenario_temperature(f, rng, t_day, D, N):
    """Temperature: daily cycle + weather fronts + trend; per-sensor shade offset: (temp (T, N), swing, base)."""
    T = t_day.size
    swing = rng.uniform(*f.daily_swing_c)
    t_fronts = [0.0]
    while t_fronts[-1] < D:
        t_fronts.append(t_fronts[-1] + rng.uniform(*f.front_every_days))
    t_fronts = np.asarray(t_fronts)
    levels = np.cumsum(rng.normal(0, f.front_std_c, t_fronts.size)) * 0.7
    levels -= levels[0]
    mean_t = np.interp(t_day, t_fronts, levels)  # linear transitions between fronts
    trend = rng.uniform(*f.trend_c) * t_day / D
    base = rng.uniform(-2.0, 15.0)
    air = base + trend + mean_t + swing * np.sin(2 * np.pi * (t_day - 0.375))
    temp = air[:, None] + rng.normal(0, 0.5, N)[None, :] + rng.normal(0, 0.05, (T, N))
    return temp, swing, base


def _scenario_faults(f, rng, angle, sign, ids, dshape, depth, work, tc, dt_min) -> dict:
    """Apply the family's sensor faults in place (``angle``, ``sign``); returns {sensor id: fault}."""
    T, N = angle.shape
    faults = {}
    inner = np.arange(1, N - 1)
    bowl_zone = inner[np.abs(dshape[inner]) * depth > 0.25 * np.max(np.abs(dshape)) * depth]
    taken = set()
    for kind in f.faults:
        pool = [j for j in (bowl_zone if kind in ("reversed", "frozen") else inner) if j not in taken]
        if not pool:
            continue
        j = int(rng.choice(pool))
        taken.add(j)
        faults[ids[j]] = kind
        if kind == "reversed":
            sign[j] = -1.0
        elif kind == "frozen":
            k0 = int(rng.integers(T // 10, max(T // 10 + 1, int(work[0] * 1440 / dt_min))))
            angle[k0:, j] = angle[k0, j]
        elif kind == "detached":
            k0 = int(rng.integers(T // 5, 4 * T // 5))
            angle[k0:, j] += rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.2)
            angle[k0:, j] += rng.uniform(-3e-3, 3e-3) * (tc[k0:, j] - tc[k0, j])
        elif kind == "dead":
            k0 = int(rng.integers(0, T // 3))
            angle[k0:, j] = np.nan
    return faults
