"""Plausibility of a vertical sensor log from its redundant channels (session 38): gravity left in the vertical
accelerometers, suspension deflections of the wrong sign.

Both used to pass without a word: a body or wheel accelerometer logged with gravity (+9.81 m/s², as most IMUs and
accelerometers log it) gave body-velocity RMS errors of 1-3 m/s (0.026 on the clean log), a deflection logged
positive in compression turned the damper-velocity epsilon from 98.5 to -205 and the zero check's warning blamed
the sensors' zero.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..._jit import njit
from ...errors import UnitsError
from ...statespace import filter_design, sos_filtfilt
from ._model import CORNER_NAMES, STAU, _body_accel, suspension_tensions

if TYPE_CHECKING:
    from ._params import VerticalVehicleParams
    from ._simulate import VerticalSensors

__all__ = ["VERTICAL_ACCEL_MEAN_LIMIT", "VERTICAL_VELOCITY_CHANGE_LIMIT", "check_vertical_accel_means",
           "deflection_sign_correlation", "DEFLECTION_SIGN_LIMIT", "SIGN_REFUSAL_LIMIT", "hop_correlation_matrix",
           "corner_order_problem", "lateral_roll_ratio", "ROLL_RATIO_RANGE", "BODY_ACCEL_RATIO_RANGE",
           "DEFLECTION_GAIN_RANGE", "GAIN_MIN_CORRELATION", "GAIN_MIN_DISTINCT", "body_accelerometer_ratio",
           "deflection_gains",
           "sensor_scale_problems"]

_G = 9.80665  # standard gravity, m/s^2

#: A vertical accelerometer whose mean over the log exceeds this (m/s²) AND implies a vertical velocity change
#: beyond :data:`VERTICAL_VELOCITY_CHANGE_LIMIT` is refused (:func:`check_vertical_accel_means`). On 150 clean
#: simulated drives (classes A-E, 5-40 m/s, 0.2-60 s, road / track / sweep, both cars) the means of logs of 10 s or
#: more stayed within 0.13 m/s² (the body accelerometers' mounting tilt on the track test): 0.5 leaves room for a
#: real sensor's offset and catches gravity in g (mean 1) on logs longer than 10 s.
VERTICAL_ACCEL_MEAN_LIMIT = 0.5
#: Largest change of a corner's vertical velocity over a log, m/s: a grade change of 25 % at 40 m/s. A clean
#: drive's accelerometer mean is that change over the log's length; the simulated drives reached 4.2 m/s.
VERTICAL_VELOCITY_CHANGE_LIMIT = 10.0


def _hint(means: np.ndarray, pattern: str) -> str:
    m = float(np.median(means))
    if 0.5 * _G <= abs(m) <= 1.5 * _G:
        if m > 0:
            return f"gravity is included: subtract {_G} m/s² (1 g) from these columns"
        return (f"gravity is included and the axis points down: negate these columns, then subtract {_G} m/s² "
                "(1 g)")
    if 0.5 <= abs(m) <= 1.5:
        return (f"in g with gravity included? subtract 1 g ({'' if m > 0 else 'after negating, '}the column then "
                f"averages ~0) and declare the unit: --units '{pattern}=g'")
    return "a sensor offset? subtract each column's reading at standstill (or its mean over the log)"


def check_vertical_accel_means(sensors: VerticalSensors, *, source: str = "log") -> None:
    """Refuse vertical accelerometers whose mean over the log is no car's: gravity included, or in g with gravity.

    A corner's vertical acceleration, integrated over a log of ``T`` s, is the change of its vertical velocity,
    bounded on a car (:data:`VERTICAL_VELOCITY_CHANGE_LIMIT`, ASSUMPTION: a grade change of at most 25 % at
    40 m/s): so its mean is ~0 on a long log (at most 10 m/s / T), while an accelerometer that still includes
    gravity averages ±9.81 m/s² (±1 in g). A ``body_accel_*`` or ``wheel_accel_*`` column is refused when
    ``|mean| > VERTICAL_ACCEL_MEAN_LIMIT`` AND ``|mean| T > VERTICAL_VELOCITY_CHANGE_LIMIT``: gravity in m/s² on
    logs longer than about 1 s, gravity in g on logs longer than 10 s. The thesis's model leaves the weight out (motions about the
    static equilibrium, digest §2.2 hypothesis 1), so its filters take the accelerations with gravity removed.

    Parameters
    ----------
    sensors : VerticalSensors
        The log, accelerations in m/s² (after the declared units).
    source : str
        Name of the log in the message.

    Raises
    ------
    UnitsError
        One line naming the columns, their means and the fix (subtract 1 g, negate, declare g).
    """
    duration = sensors.time.size * sensors.dt
    for prefix, acc in (("body_accel", sensors.body_accel), ("wheel_accel", sensors.wheel_accel)):
        if acc is None:
            continue
        mean = np.mean(acc, axis=0)
        bad = np.flatnonzero((np.abs(mean) > VERTICAL_ACCEL_MEAN_LIMIT)
                             & (np.abs(mean) * duration > VERTICAL_VELOCITY_CHANGE_LIMIT))
        if bad.size == 0:
            continue
        names = ", ".join(f"{prefix}_{CORNER_NAMES[c]}" for c in bad)
        means = ", ".join(f"{mean[c]:+.2f}" for c in bad)
        raise UnitsError(f"{source}: {names} average{'s' if bad.size == 1 else ''} {means} m/s² over the "
                         f"{duration:.3g} s log; a car corner's vertical acceleration averages ~0 over a drive (this "
                         f"would be a vertical speed change of {abs(mean[bad]).max() * duration:.3g} m/s): "
                         f"{_hint(mean[bad], prefix + '_*')}")


# ------------------------------------------------------------------------------------------- deflection sign

#: A deflection channel whose :func:`deflection_sign_correlation` is below minus this is reported as of inverted
#: sign. On 120 clean simulated drives (seed 11, classes A-E, 5-40 m/s, 2-40 s, road / track / sweep, both cars)
#: the correlation stayed above +0.82 per corner in configuration 2 and above -0.11 in configuration 3 (near 0 on
#: class A roads, where the wheel accelerometer's quantisation dominates the wheel hop); inverted, below -0.38 and
#: +0.11 (session 38, docs/vehicle-vertical.md).
DEFLECTION_SIGN_LIMIT = 0.3
_BODY_BAND = (0.5, 8.0)  # Hz: body modes and the handling response, below the 35 Hz engine order
_HOP_BAND = (8.0, 25.0)  # Hz: the wheel hop, where the wheel's acceleration is minus the deflection's


@njit(cache=True)
def _body_corner_accel(dz, dzdot, actuator, u, corner, coupling, tau):
    """Body-corner vertical accelerations the model's body equations give for the measured deflections and a_x, a_y,
    psidd: the filters' own corner acceleration (:func:`_body_accel`, the suspension tensions through the heave, roll
    and pitch coupling, without the model-error state)."""
    out = np.empty((dz.shape[0], 4))
    force = np.empty(4)
    ks = np.empty(4)
    cd = np.empty(4)
    no_error = np.zeros(16)
    for k in range(dz.shape[0]):
        suspension_tensions(dz[k], dzdot[k], actuator[k], corner, tau, force, ks, cd)
        for c in range(4):
            out[k, c] = _body_accel(no_error, u[k], corner, coupling, force, c)
    return out


def _correlation(a, b, band, dt):
    sos = filter_design("butter", 2, list(band), btype="band", fs=1.0 / dt, output="sos")
    a = sos_filtfilt(sos, a)
    b = sos_filtfilt(sos, b)
    a = a - a.mean(axis=0)
    b = b - b.mean(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.sum(a * b, axis=0) / np.sqrt(np.sum(a * a, axis=0) * np.sum(b * b, axis=0))
    return np.nan_to_num(r)


def deflection_sign_correlation(sensors: VerticalSensors, *, params: VerticalVehicleParams | None = None,
                                actuator_force=None) -> np.ndarray | None:
    """Correlation of each suspension deflection with what the accelerometers imply: ~+1 when ``dz21_*`` is
    positive in extension (body minus wheel, the thesis's convention), ~-1 when its sign is inverted.

    Configuration 3: in the wheel hop (8-25 Hz) the body stands still, so the wheel's acceleration is minus the
    deflection's second derivative (``dZ21 = Z2 - Z1``); the value is minus their correlation. Configuration 2:
    the body-corner accelerations that the 7-DOF model's body equations (heave, roll, pitch; digest §2.3, §2.6) give for
    the measured deflections, their damper velocities (50 Hz) and a_x, a_y, psidd, against the measured ones,
    in 0.5-8 Hz. Both use only the sign of a relation the thesis's model holds exactly (ASSUMPTION: the car's
    suspension pushes the body up when compressed); their size falls on a smooth road, where the sensors'
    quantisation dominates.

    Parameters
    ----------
    sensors : VerticalSensors
    params : VerticalVehicleParams, optional
        The car (default: thesis set), for configuration 2.
    actuator_force : (T, 4) array_like, optional
        The actuator forces the filter used, N (configuration 2; default 0).

    Returns
    -------
    (4,) ndarray or None
        FL, FR, RL, RR; None in configuration 1 (no accelerometer to compare with).
    """
    dz = np.ascontiguousarray(sensors.displacement, dtype=float)
    if sensors.wheel_accel is not None:
        return np.diagonal(hop_correlation_matrix(sensors)).copy()
    if sensors.body_accel is None:
        return None
    from ._estimate import damper_velocity_from_displacement, vertical_ekf_inputs
    from ._model import vertical_params_arrays
    from ._params import VerticalVehicleParams

    corner, coupling, scalars = vertical_params_arrays(params or VerticalVehicleParams())
    v = np.ascontiguousarray(damper_velocity_from_displacement(dz, sensors.dt, cutoff=50.0))
    act = np.zeros_like(dz) if actuator_force is None else np.ascontiguousarray(actuator_force, dtype=float)
    u = np.ascontiguousarray(vertical_ekf_inputs(sensors)[:, :3])
    implied = _body_corner_accel(dz, v, act, u, corner, coupling, scalars[STAU])
    return _correlation(sensors.body_accel, implied, _BODY_BAND, sensors.dt)


#: A sign correlation below minus this refuses the log (``estimate_vertical_log``; ``accept=("sensor_sign",)`` makes it
#: a warning): the evidence is overwhelming (clean drives stay above -0.11, see :data:`DEFLECTION_SIGN_LIMIT`).
SIGN_REFUSAL_LIMIT = 0.9


def _hop_band(sensors: VerticalSensors):
    """Minus each deflection's second derivative and each wheel accelerometer in the wheel hop (8-25 Hz, 2nd-order
    Butterworth, zero phase), means removed: (T, 4) and (T, 4)."""
    dt = sensors.dt
    dz = np.ascontiguousarray(sensors.displacement, dtype=float)
    second = np.gradient(np.gradient(dz, dt, axis=0), dt, axis=0)
    sos = filter_design("butter", 2, list(_HOP_BAND), btype="band", fs=1.0 / dt, output="sos")
    a = -sos_filtfilt(sos, second)
    b = sos_filtfilt(sos, np.asarray(sensors.wheel_accel, dtype=float))
    return a - a.mean(axis=0), b - b.mean(axis=0)


def _cross_correlation(a, b):
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (a.T @ b) / np.sqrt(np.outer(np.sum(a * a, axis=0), np.sum(b * b, axis=0)))
    return np.nan_to_num(r)


def hop_correlation_matrix(sensors: VerticalSensors) -> np.ndarray | None:
    """(4, 4) correlation, in the wheel hop (8-25 Hz), of minus each corner's deflection second derivative (row:
    ``dz21_*``) with each wheel accelerometer (column: ``wheel_accel_*``).

    In the hop band the body stands still, so ``d²dZ21/dt² = Z2dd - Z1dd ≈ -Z1dd``: the diagonal is ~+1 (its own
    wheel; the sign check, :func:`deflection_sign_correlation`), the off-diagonal terms ~0 on a road (each wheel
    hops on its own path). None without wheel accelerometers.
    """
    if sensors.wheel_accel is None:
        return None
    return _cross_correlation(*_hop_band(sensors))


#: :func:`corner_order_problem`: a deflection column is of another corner when its |correlation| with that corner's
#: wheel accelerometer exceeds ``HIGH`` and its own by ``MARGIN``, the two wheels hopping apart (their accelerometers'
#: correlation below ``DISTINCT``: a 4-poster heave sweep drives all four alike and cannot tell them apart). On the
#: 49 clean configuration-3 drives of session 40 (seeds 41, 42; docs/vehicle-vertical.md) the largest excess of
#: another corner's correlation over the own one was +0.09 (the rule needs +0.4).
CORNER_ORDER_HIGH = 0.5
CORNER_ORDER_MARGIN = 0.4
CORNER_ORDER_DISTINCT = 0.5


def corner_order_problem(sensors: VerticalSensors) -> str | None:
    """One line naming the deflection columns that move with another corner's wheel accelerometer (swapped corners,
    e.g. FL and FR), or None (no wheel accelerometers, or every column matches its own wheel)."""
    if sensors.wheel_accel is None:
        return None
    a, b = _hop_band(sensors)
    m, acc = _cross_correlation(a, b), np.abs(_cross_correlation(b, b))
    wrong = []
    for i in range(4):
        j = int(np.argmax(np.abs(m[i])))
        if (j != i and abs(m[i, j]) > CORNER_ORDER_HIGH and abs(m[i, j]) - abs(m[i, i]) > CORNER_ORDER_MARGIN
                and acc[i, j] < CORNER_ORDER_DISTINCT):
            wrong.append(f"dz21_{CORNER_NAMES[i]} moves with wheel_accel_{CORNER_NAMES[j]} (correlation "
                         f"{m[i, j]:+.2f} in the wheel hop, {m[i, i]:+.2f} with its own wheel)")
    if not wrong:
        return None
    return ("; ".join(wrong) + ": deflection (or wheel accelerometer) columns of swapped corners? the wheel hop "
            "(8-25 Hz) of each corner's deflection is its own wheel's acceleration: rename the columns to their "
            "corners (--rename OLD=NEW)")


#: Band of :func:`lateral_roll_ratio` that passes: about 1 for a_y in m/s² with y to the left and the filter's car
#: (a car with other anti-roll bars shifts it); ~10 for a_y in g, ~-1 for y to the right. On 24 clean simulated
#: track tests with turning (session 40, 90 drives, seeds 41, 42; docs/vehicle-vertical.md) it stayed in 0.42-1.23 (the
#: lowest on class E roads at 20-35 m/s, whose roll the model's flat road lacks).
ROLL_RATIO_RANGE = (0.1, 4.0)
#: :func:`lateral_roll_ratio` runs where the low-passed |yaw rate| exceeds this, rad/s (turns; independent of a_y's
#: unit and sign).
_ROLL_YAW_RATE = 0.05
_ROLL_CUTOFF = 1.0  # Hz: the handling response to the driver, below the body modes


def lateral_roll_ratio(sensors: VerticalSensors, *, params: VerticalVehicleParams | None = None):
    """Measured roll deflection over the one the model gives for the logged a_x, a_y and yaw rate: ~1.

    ``roll = dz21_FL - dz21_FR + dz21_RL - dz21_RR`` (left minus right, both axles), 1 Hz zero-phase low-pass; the
    model's is the flat-road handling response to the log's a_x, a_y, psidd (the filters' own model, digest §2.3: in
    a left turn, a_y > 0, the body rolls right and the left suspension extends). Least squares through the origin on
    the samples where the low-passed |yaw rate| exceeds 0.05 rad/s (turns, whatever a_y's unit or sign). The filters
    take a_y as a known input: a lateral axis to the right (a_y and yaw rate negated) gives ~-1, a_y in g ~10.
    ASSUMPTION: the car's roll stiffness is the filter's within the band :data:`ROLL_RATIO_RANGE`; the deflections'
    own sign is checked by :func:`deflection_sign_correlation`.

    Returns
    -------
    (float, int)
        The ratio (nan when not excited: less than 1 s of turning) and the number of samples it used.
    """
    from ._estimate import _handling_response, vertical_ekf_inputs
    from ._params import VerticalVehicleParams

    dt = sensors.dt
    if sensors.time.size < 64:
        return float("nan"), 0
    sos = filter_design("butter", 2, _ROLL_CUTOFF, btype="low", fs=1.0 / dt, output="sos")
    turning = np.abs(sos_filtfilt(sos, np.asarray(sensors.yaw_rate, dtype=float))) > _ROLL_YAW_RATE
    n = int(turning.sum())
    if n * dt < 1.0:
        return float("nan"), n
    _, hdz, _, _ = _handling_response(vertical_ekf_inputs(sensors), params or VerticalVehicleParams(), dt)
    weights = np.array([1.0, -1.0, 1.0, -1.0])
    measured = sos_filtfilt(sos, np.asarray(sensors.displacement, dtype=float) @ weights)[turning]
    model = sos_filtfilt(sos, np.asarray(hdz, dtype=float) @ weights)[turning]
    den = float(np.dot(model, model))
    return (float(np.dot(model, measured) / den) if den > 0 else float("inf")), n


# ------------------------------------------------------------------------------------ scale of the sensors (session 41)

#: :func:`body_accelerometer_ratio` outside this band: body accelerometers (or deflections) in another unit. In SI
#: units ~1 (0.96 on the guide's class C log); in g ~0.1 (1 / 9.81). Calibrated in session 41
#: (docs/vehicle-vertical.md, "Sensor scale").
BODY_ACCEL_RATIO_RANGE = (0.4, 2.5)
#: :func:`deflection_gains` outside this band names the channel (a sensor gain or scale error). Calibrated in session
#: 41 (docs/vehicle-vertical.md, "Sensor scale").
DEFLECTION_GAIN_RANGE = (0.7, 1.4)
#: Configuration 3: a corner is judged only where its deflection and wheel accelerometer correlate above this in the
#: wheel hop (their std ratio then brackets the gain within this factor; on a smooth road the deflections'
#: quantisation dominates their second derivative and the corner is not judged).
GAIN_MIN_CORRELATION = 0.85
#: Configuration 2: the fit is judged only when the four corners' sensitivities are distinct enough: the smallest
#: eigenvalue of their normalised Gram matrix above this (4-poster heave sweeps: 0.05-0.15, where a MagneRide car's
#: map error went into the gains, up to 10; roads and track tests: 0.20-0.98; session 41).
GAIN_MIN_DISTINCT = 0.18
_GAIN_BLOCK = 10.0  # s: the configuration-2 fit runs on at most _GAIN_BLOCKS blocks of this length (a long log)
_GAIN_BLOCKS = 12


def _implied_body_accel(sensors: VerticalSensors, params, actuator_force):
    """``evaluate(rows, scale)``: the body-corner accelerations the model's body equations give on ``rows`` of the log
    for the deflections multiplied by ``scale`` (4,) (:func:`_body_corner_accel`; configuration-2 checks)."""
    from ._estimate import damper_velocity_from_displacement, vertical_ekf_inputs
    from ._model import vertical_params_arrays
    from ._params import VerticalVehicleParams

    corner, coupling, scalars = vertical_params_arrays(params or VerticalVehicleParams())
    dz = np.ascontiguousarray(sensors.displacement, dtype=float)
    v = np.ascontiguousarray(damper_velocity_from_displacement(dz, sensors.dt, cutoff=50.0))
    act = np.zeros_like(dz) if actuator_force is None else np.ascontiguousarray(actuator_force, dtype=float)
    u = np.ascontiguousarray(vertical_ekf_inputs(sensors)[:, :3])

    def evaluate(rows, scale):
        return _body_corner_accel(np.ascontiguousarray(dz[rows] * scale), np.ascontiguousarray(v[rows] * scale),
                                  act[rows], u[rows], corner, coupling, scalars[STAU])
    return evaluate


def _gain_blocks(n: int, dt: float) -> list[slice]:
    """The rows the configuration-2 fit uses: the whole log, or :data:`_GAIN_BLOCKS` evenly spaced blocks of
    :data:`_GAIN_BLOCK` s of a longer one (the fit evaluates the model 20 times)."""
    block = int(round(_GAIN_BLOCK / dt))
    if n <= block * _GAIN_BLOCKS:
        return [slice(0, n)]
    starts = np.linspace(0, n - block, _GAIN_BLOCKS).astype(int)
    return [slice(int(s), int(s) + block) for s in starts]


def body_accelerometer_ratio(sensors: VerticalSensors, *, params: VerticalVehicleParams | None = None,
                             actuator_force=None) -> float | None:
    """Median over the corners of the least-squares slope of each body accelerometer on the body-corner acceleration
    the 7-DOF model's body equations give for the measured deflections (0.5-8 Hz, as
    :func:`deflection_sign_correlation`): ~1 when both are in SI units, ~0.1 for accelerations in g.

    The body equations (heave, roll, pitch; digest §2.3, §2.6) turn the suspension tensions into the body-corner
    accelerations; below the wheel hop the body accelerometers measure them (correlation above 0.89 on clean drives).
    None without body accelerometers (configurations 1 and 3) or on a log under 64 samples.
    """
    if sensors.body_accel is None or sensors.time.size < 64:
        return None
    evaluate = _implied_body_accel(sensors, params, actuator_force)
    sos = filter_design("butter", 2, list(_BODY_BAND), btype="band", fs=1.0 / sensors.dt, output="sos")
    a = sos_filtfilt(sos, np.asarray(sensors.body_accel, dtype=float))
    b = sos_filtfilt(sos, evaluate(slice(None), np.ones(4)))
    a, b = a - a.mean(axis=0), b - b.mean(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(np.median(np.sum(a * b, axis=0) / np.sum(b * b, axis=0)))


def deflection_gains(sensors: VerticalSensors, *, params: VerticalVehicleParams | None = None,
                     actuator_force=None) -> np.ndarray | None:
    """Each deflection channel's gain relative to what the accelerometers imply: ~1 right, 0.5 for a sensor reading
    half the travel (a wrong gain in its calibration), nan where not judged.

    Configuration 3: in the wheel hop (8-25 Hz) the body stands still and the wheel's acceleration is minus the
    deflection's second derivative (``dZ21 = Z2 - Z1``), so the ratio of their stds is the deflection's gain; judged
    only where their correlation exceeds :data:`GAIN_MIN_CORRELATION` (the ratio is then within that factor of the
    gain; a smooth road's quantisation noise would inflate it). Configuration 2: the four scale factors ``h`` that
    make the body-corner accelerations of the model's body equations (springs, dampers, anti-roll bars at
    ``h dz``; :func:`body_accelerometer_ratio`) fit the body accelerometers in 0.5-8 Hz best (Gauss-Newton, least
    squares); the gain is ``1 / h``, nan for all four when the corners move alike (:data:`GAIN_MIN_DISTINCT`). The
    model is the filter's car (ASSUMPTION: a car unlike it shifts the four gains alike; :func:`sensor_scale_problems`
    judges each over their median). None in configuration 1 or on a log under 2 s.
    """
    if sensors.time.size * sensors.dt < 2.0:
        return None
    if sensors.wheel_accel is not None:
        a, b = _hop_band(sensors)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.sqrt(np.sum(a * a, axis=0) / np.sum(b * b, axis=0))
        rho = np.diagonal(_cross_correlation(a, b))
        return np.where(rho > GAIN_MIN_CORRELATION, ratio, np.nan)
    if sensors.body_accel is None:
        return None
    evaluate = _implied_body_accel(sensors, params, actuator_force)
    sos = filter_design("butter", 2, list(_BODY_BAND), btype="band", fs=1.0 / sensors.dt, output="sos")
    blocks = _gain_blocks(sensors.time.size, sensors.dt)
    measured = np.concatenate([sos_filtfilt(sos, np.asarray(sensors.body_accel[rows], dtype=float))
                               for rows in blocks]).ravel()

    def model(scale):
        return np.concatenate([sos_filtfilt(sos, evaluate(rows, scale)) for rows in blocks]).ravel()

    start = (measured * model(np.ones(4))).reshape(-1, 4).sum(axis=0)
    h, step = np.where(start < 0.0, -1.0, 1.0), 1e-3  # from the sign each corner's correlation gives
    for _ in range(4):  # Gauss-Newton on the four scale factors, forward-difference Jacobian
        base = model(h)
        jac = np.column_stack([(model(h + step * np.eye(4)[e]) - base) / step for e in range(4)])
        h = h + np.linalg.lstsq(jac, measured - base, rcond=None)[0]
        h = np.where(h < 0.0, -1.0, 1.0) * np.clip(np.abs(h), 0.05, 20.0)  # a sign inverted goes to -1
    norm = np.sqrt(np.sum(jac * jac, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        gram = np.nan_to_num((jac.T @ jac) / np.outer(norm, norm))
    if np.linalg.eigvalsh(gram)[0] < GAIN_MIN_DISTINCT:  # the corners move alike (a 4-poster heave): not separable
        return np.full(4, np.nan)
    return 1.0 / h


def sensor_scale_problems(body_ratio: float | None, gains, *, wheel: bool) -> list[tuple[str, str]]:
    """(check name, one line) of :func:`body_accelerometer_ratio` outside :data:`BODY_ACCEL_RATIO_RANGE` (name
    ``body_accel_unit`` below it: a refusal unless accepted; ``""`` above: a warning) and of the
    :func:`deflection_gains` outside :data:`DEFLECTION_GAIN_RANGE` (a warning, ``""``): configuration 3 (``wheel``)
    each gain itself, configuration 2 each gain over the median of the four (the body equations are the filter's
    car: a car unlike it shifts every corner alike)."""
    out = []
    lo, hi = BODY_ACCEL_RATIO_RANGE  # magnitudes: a sign inverted is the sign check's (deflection_sign_correlation)
    body_ratio = None if body_ratio is None else abs(body_ratio)
    if body_ratio is not None and np.isfinite(body_ratio) and not lo <= body_ratio <= hi:
        out.append(("body_accel_unit" if body_ratio < lo else "",
                    f"the body accelerometers' 0.5-8 Hz content is {body_ratio:.2g} times the body-corner acceleration "
                    "that the suspension deflections imply through the car's body equations (about 1 when both are in "
                    f"SI units; {lo:g}..{hi:g} passes): "
                    + ("accelerations in g? Declare them: --units 'body_accel_*=g'" if body_ratio < lo else
                       "accelerations or deflections in another unit?")))
    if gains is None:
        return out
    gains = np.abs(np.asarray(gains, dtype=float))
    judged = np.isfinite(gains)
    if not wheel and judged.sum() >= 3:
        gains = gains / float(np.median(gains[judged]))
    elif not wheel:
        return out
    lo, hi = DEFLECTION_GAIN_RANGE
    bad = np.flatnonzero(judged & ((gains < lo) | (gains > hi)))
    if bad.size:
        names = ", ".join(f"dz21_{CORNER_NAMES[c]}" for c in bad)
        values = ", ".join(f"{gains[c]:.2f}" for c in bad)
        others = [f"{gains[c]:.2f}" for c in np.flatnonzero(judged) if c not in bad]
        what = ("the travel its wheel accelerometer implies in the wheel hop (8-25 Hz, where d²dz21/dt² is minus the "
                "wheel's acceleration)" if wheel else "the travel the body accelerometers imply through the car's body "
                "equations (0.5-8 Hz), relative to the median of the four corners")
        out.append(("", f"{names} read{'s' if bad.size == 1 else ''} {values} times {what} ({lo:g}..{hi:g} passes"
                    + (f"; the other corners {', '.join(others)}" if others else "") + "): a deflection sensor of "
                    "another gain (its calibration, mm per volt) or an accelerometer of another scale: check the "
                    "sensor's calibration; if the deflection's is wrong, divide the column by the gain found"))
    return out
