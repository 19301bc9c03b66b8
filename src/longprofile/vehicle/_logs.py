"""Vehicle sensor logs: declared units, conversion to SI, explicit resampling and plausibility checks (issue 14).

A real car's log rarely arrives in the SI units and the axes of paper 001 (x forward, y left, z up, yaw
rate positive counter-clockwise, road-wheel steering angle positive to the left). Units are never guessed:
each column is SI unless a unit is declared, either in its header (``yaw_rate [deg/s]``, ``time[ms]``, ``yaw_rate (deg/s)``) or
by a mapping (``units={"yaw_rate": "deg/s"}``, the CLI's ``--units yaw_rate=deg/s,time=ms``). The values are
then converted, and the physics checks the result: the channels of a car are redundant, so a wrong unit or
sign shows up as a ratio between two channels far from 1, and the error names the channel and the likely
mistake (:func:`check_drive_log`).

Redundancies used (planar model of paper 001, eq. (11) and (18), body axes x forward, y left):

* yaw rate vs rear-wheel speed difference: r = R (omega_RR - omega_RL) / S_b (undriven, unsteered axle;
  eq. (18) for a left/right pair), ratio gyro / wheels, expected 1;
* lateral acceleration vs V_x r: a_y = dV_y/dt + V_x r (eq. (11)), expected about 1 (body roll tilts the
  accelerometer: a few per cent per 0.1 g);
* steering vs yaw rate in turns: r = V_x delta / (L (1 + K V_x^2)) (steady-state bicycle model), so the
  ratio gyro / (V_x delta / L) lies in (0, 1.3] for an understeering car; negative is an opposite steering
  sign, below 0.3 a steering-WHEEL angle (or degrees);
* longitudinal acceleration vs dV_x/dt (eq. (11), the grade only offsets it), expected about 1.
* against the car file (:mod:`._consistency`): the yaw rate on steady turns against the steady-state bicycle model
  with the car's understeer (``steering_gain``: a wrong steering ratio), and the front/rear wheel speed ratio against
  the tractive force, which only the driven axle's slip moves (``axle_order``: front and rear columns swapped).

With the measured front road-wheel angles ``steer_fl``, ``steer_fr`` (both), the steering check uses their mean
(what the model steers by), and three more checks compare the steer channels (the ratios in turns, where one
of the two exceeds 0.01 rad):

* ``steer_fr_vs_steer_fl``: steer_fr / steer_fl, expected 0.6..1.67 (about 1; an Ackermann linkage makes the
  inner wheel steer more, up to ~1.3x at 0.6 rad); negative is one angle positive to the right, ~57 (or 1/57)
  one of them in degrees;
* ``steer_difference_vs_ackermann``: the largest |(steer_fl - steer_fr) - (Ackermann difference at their mean)|
  over its tolerance 0.035 rad + |Ackermann difference| (real linkages lie between parallel and twice
  Ackermann, plus toe and compliance), expected <= 1, over all moving samples; above is an offset between the
  two sensors, opposite signs, or a wrong body.track / wheelbase;
* ``steering_angle_vs_steer_mean``: steering_angle / mean(steer_fl, steer_fr), expected 0.8..1.25 (the model
  does not use steering_angle then; left out of the log, it is their mean and the ratio 1); ~15 is a
  steering-WHEEL angle.
"""

from __future__ import annotations

import fnmatch
import math
import re
from collections import Counter
from dataclasses import dataclass

import numpy as np

from .._validation import check_time_order, renamed_columns, time_seconds, true_runs, uniform_time_step
from ..errors import InputError, InputFormatError, UnitsError
from ._consistency import AXLE_SWAPPED, axle_message, axle_order, gain_message, gain_verdict, steering_gain
from ._steering import (
                        STEERING_OFFSET_LIMIT,
                        bicycle_yaw_gain,
                        offset_problem,
                        offset_warning,
                        steering_from_wheel_angle,
                        straight_steering_offset,
                        wheel_angle_hint,
)

__all__ = ["UNIT_FACTORS", "LogCheck", "parse_units", "expand_unit_patterns", "split_unit_headers", "convert_units",
           "resample_log",
           "read_drive_log", "check_drive_log", "check_sample_rate", "infer_vertical_config", "read_vertical_log"]

GRAVITY = 9.80665

#: Accepted units of each physical quantity and their factor to SI (value_SI = value * factor).
UNIT_FACTORS = {
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6},
    "angle": {"rad": 1.0, "deg": math.pi / 180.0, "mrad": 1e-3},
    "rate": {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0},
    "accel": {"m/s^2": 1.0, "m/s2": 1.0, "mm/s^2": 1e-3, "mm/s2": 1e-3, "g": GRAVITY},
    "length": {"m": 1.0, "mm": 1e-3, "cm": 1e-2},
    "current": {"a": 1.0, "ma": 1e-3},
    # wheel speeds may also be logged as the wheel's translational speed R omega (needs the rolling radius)
    "wheel": {"rad/s": 1.0, "deg/s": math.pi / 180.0, "rpm": 2.0 * math.pi / 60.0, "m/s": None, "km/h": None},
}

#: What each quantity of :data:`UNIT_FACTORS` is called in messages, with its article.
_QUANTITY_NAMES = {"time": "a time", "angle": "an angle", "rate": "an angular rate", "accel": "an acceleration",
                   "length": "a length", "current": "a current", "wheel": "a wheel speed"}

_PLANAR_QUANTITY = {"time": "time", "steering_angle": "angle", "steer_fl": "angle", "steer_fr": "angle",
                    "steering_wheel_angle": "angle",
                    "yaw_rate": "rate", "accel_x": "accel",
                    "accel_y": "accel", "wheel_speed_fl": "wheel", "wheel_speed_fr": "wheel",
                    "wheel_speed_rl": "wheel", "wheel_speed_rr": "wheel"}
_CORNERS = ("FL", "FR", "RL", "RR")
_VERTICAL_QUANTITY = {"time": "time", "ax": "accel", "ay": "accel", "yaw_rate": "rate",
                      **{f"dz21_{c}": "length" for c in _CORNERS}, **{f"body_accel_{c}": "accel" for c in _CORNERS},
                      **{f"wheel_accel_{c}": "accel" for c in _CORNERS}, **{f"current_{c}": "current" for c in _CORNERS}}

#: Other names of a channel, per log type: one CAN export feeds both readers (the planar log names the body's
#: accelerations ``accel_x``/``accel_y``, the vertical log ``ax``/``ay``). A column of the other name is read as the
#: channel when the log has no column of the channel's own name; ``--units`` keys may use either name.
_PLANAR_ALIASES = {"ax": "accel_x", "ay": "accel_y"}
_VERTICAL_ALIASES = {"accel_x": "ax", "accel_y": "ay"}


def _with_aliases(frame, units, quantities: dict, aliases: dict, *, source: str, strict: bool = False):
    """``frame`` with its header units split and its alias columns renamed to the channels, and the declared units
    ({channel: unit}, header then ``units``, pattern keys expanded) keyed by channel. With ``strict`` (vertical logs),
    a ``units`` entry that contradicts a header's unit is refused (else it overrides it)."""
    extended = {**quantities, **{a: quantities[c] for a, c in aliases.items()}}
    frame, declared = split_unit_headers(frame, extended)
    rename = {a: c for a, c in aliases.items() if a in frame.columns and c not in frame.columns}
    if rename:
        frame = frame.rename(columns=rename)
        declared = {rename.get(k, k): v for k, v in declared.items()}
    given = {(aliases.get(k, k) if isinstance(k, str) else k): v for k, v in dict(units or {}).items()}
    given = expand_unit_patterns(given, quantities, source=source)
    clash = [c for c, u in given.items() if strict and c in declared and _norm_unit(declared[c]) != _norm_unit(u)]
    if clash:
        c = clash[0]
        raise UnitsError(f"{source}: column {c!r} is headed in {declared[c]} but --units says {given[c]}: which is it? "
                         f"Drop the --units entry (the header is read) or correct the header.")
    declared.update(given)
    return frame, declared


#: ``name [unit]`` or ``name (unit)``
_HEADER = re.compile(r"^\s*(?P<name>[^\[\]()]*?)\s*(?:\[(?P<unit>[^\[\]]+)\]|\((?P<unit_p>[^()]+)\))\s*$")


#: Other spellings of the units of :data:`UNIT_FACTORS` (after lower-casing and removing blanks): the loggers' own
#: (kph, dps, 1/min) and the suffix forms, where ``_`` stands for ``/`` (``yaw_rate_deg_s``).
_UNIT_ALIASES = {"kph": "km/h", "kmh": "km/h", "km_h": "km/h", "mps": "m/s", "m_s": "m/s", "m_s^2": "m/s^2",
                 "m_s2": "m/s^2", "mps2": "m/s^2", "dps": "deg/s", "degps": "deg/s", "deg_s": "deg/s",
                 "deg/sec": "deg/s", "°/s": "deg/s", "°": "deg", "degree": "deg", "degrees": "deg", "radps": "rad/s",
                 "rad_s": "rad/s", "rad/sec": "rad/s", "1/min": "rpm", "u/min": "rpm", "min^-1": "rpm",
                 "sec": "s", "msec": "ms"}


def _norm_unit(u: str) -> str:
    u = u.strip().lower().replace(" ", "").replace("²", "^2").replace("µ", "u")
    return _UNIT_ALIASES.get(u, u)


def parse_units(text: str | None) -> dict:
    """Parse a ``--units`` mapping ``"col=unit,col=unit"`` into a dict (empty for None or "").

    A key may be a shell-style pattern (``wheel_speed_*=km/h``), expanded against the channels of the log by
    :func:`expand_unit_patterns` when the log is read."""
    if not text:
        return {}
    out = {}
    for item in text.split(","):
        if "=" not in item:
            raise InputError(f"--units must be comma-separated column=unit pairs, e.g. 'yaw_rate=deg/s,time=ms'; "
                             f"got {item!r}.")
        k, v = item.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def _is_pattern(key: str) -> bool:
    return any(ch in key for ch in "*?[")


def expand_unit_patterns(units: dict | None, quantities: dict, *, source: str = "log") -> dict:
    """Give the unit of each shell-style pattern key (``wheel_speed_*``, ``dz21_?L``; :mod:`fnmatch`, any letter
    case) to every channel of ``quantities`` it matches; an explicit key beats a pattern.

    Raises
    ------
    UnitsError
        For a pattern that matches no channel of this log type, or a channel that two patterns give different
        units (name it explicitly).
    """
    units = dict(units or {})
    out, by = {}, {}
    for key, unit in units.items():
        if not _is_pattern(key):
            continue
        hits = [ch for ch in quantities if fnmatch.fnmatchcase(ch.casefold(), key.strip().casefold())]
        if not hits:
            raise UnitsError(f"{source}: the unit pattern {key!r} matches no channel of this log (channels: "
                             f"{', '.join(quantities)}).")
        for ch in hits:
            if ch in out and _norm_unit(out[ch]) != _norm_unit(unit) and ch not in units:
                raise UnitsError(f"{source}: channel {ch!r} matches the unit patterns {by[ch]!r} ({out[ch]}) and "
                                 f"{key!r} ({unit}); declare it explicitly, e.g. --units {ch}={unit}.")
            out[ch], by[ch] = unit, key
    out.update({k: v for k, v in units.items() if not _is_pattern(k)})
    return out


def _suffix_unit(name: str, quantities: dict):
    """(channel, unit) of a header ``<channel>_<unit>`` (``time_ms``, ``accel_x_g``, ``steering_angle_deg``: a
    channel of ``quantities`` in any letter case, then a unit of its quantity, :data:`UNIT_FACTORS`), else None."""
    fold = str(name).casefold()
    if fold in {ch.casefold() for ch in quantities}:
        return None
    for channel in sorted(quantities, key=len, reverse=True):  # the longest channel name first
        unit = str(name)[len(channel) + 1:]
        if fold.startswith(channel.casefold() + "_") and _norm_unit(unit) in UNIT_FACTORS.get(quantities[channel], {}):
            return channel, unit
    return None


def _unknown_suffix_hints(columns, missing, quantities: dict) -> list[str]:
    """For each missing channel, the columns named ``<channel>_<suffix>`` whose suffix is no unit of the channel's
    quantity (``wheel_speed_fl_kmph``): what the user meant, and what to write instead."""
    hints = []
    for channel in missing:
        q = quantities.get(channel)
        for c in columns:
            if q and str(c).casefold().startswith(channel.casefold() + "_"):
                suffix = str(c)[len(channel) + 1:]
                hints.append(f"column {str(c)!r} looks like {channel} with the unit suffix {suffix!r}, which is not "
                             f"a unit of {_QUANTITY_NAMES[q]} ({', '.join(UNIT_FACTORS[q])}): rename it (--rename "
                             f"{c}={channel}) and declare its unit (--units {channel}=...)")
    return hints


def split_unit_headers(frame, channels=()):
    """Strip ``name [unit]``, ``name (unit)`` and ``name_unit`` headers: returns (frame with plain names, {name: unit}
    declared in the header).

    A name that differs from one of ``channels`` only in letter case (``Time``, ``ACCEL_X``, ``dz21_fl``) is given
    the channel's spelling, unless another column has the same name in another case (a spreadsheet's capitalised
    header reads as the original; two candidates are left as they are and reported missing by the reader). With
    ``channels`` a {channel: quantity} dict, ``<channel>_<unit>`` (``time_ms``, ``accel_x_g``; the form the rail
    tables and ``differentiate`` read) declares a unit of the channel's quantity too."""
    declared, rename = {}, {}
    by_fold = {ch.casefold(): ch for ch in channels}
    matches = {c: _HEADER.match(str(c)) for c in frame.columns}
    suffixed = {c: _suffix_unit(c, channels) for c in frame.columns} if isinstance(channels, dict) else {}
    names = {c: m.group("name") if m else (suffixed[c][0] if suffixed.get(c) else str(c)) for c, m in matches.items()}
    folds = Counter(n.casefold() for n in names.values())
    for c, name in names.items():
        if name not in channels and folds[name.casefold()] == 1 and name.casefold() in by_fold:
            name = by_fold[name.casefold()]  # the only column of that name in any case
        if name != c:
            rename[c] = name
        if matches[c]:
            declared[name] = matches[c].group("unit") or matches[c].group("unit_p")
        elif suffixed.get(c) and folds[name.casefold()] == 1:
            declared[name] = suffixed[c][1]
        elif suffixed.get(c):  # time_ms next to time: two candidates, left as they are
            rename.pop(c, None)
    return (frame.rename(columns=rename) if rename else frame), declared


def convert_units(frame, units: dict, quantities: dict, *, wheel_radius: float | dict | None = None,
                  source: str = "log"):
    """Convert the columns of ``frame`` named in ``units`` to SI (a copy); columns not named are SI already.

    Parameters
    ----------
    frame : pandas.DataFrame
        The log, plain column names.
    units : dict
        {column: unit} as declared (header or ``--units``); pattern keys are expanded (:func:`expand_unit_patterns`).
    quantities : dict
        {column: quantity} of the channels this reader knows (keys of :data:`UNIT_FACTORS`).
    wheel_radius : float or dict, optional
        Rolling radius R (m) to turn a translational wheel speed (m/s, km/h) into a spin rate (rad/s); a
        dict {column: R} gives each wheel's own radius (staggered tyres).

    Raises
    ------
    UnitsError
        For a column this log type does not have, or a unit that is not one of the column's quantity.
    """
    if not units:
        return frame
    units = expand_unit_patterns(units, quantities, source=source)
    converted = {}
    for col, unit in units.items():
        if col not in quantities:
            raise UnitsError(f"{source}: a unit is declared for {col!r}, which is not a channel of this log "
                             f"(channels: {', '.join(quantities)}).")
        if col not in frame.columns:
            continue
        q = quantities[col]
        table = UNIT_FACTORS[q]
        u = _norm_unit(unit)
        if u not in table:
            raise UnitsError(f"{source}: column {col!r}: unknown unit {unit!r} for {_QUANTITY_NAMES[q]} channel; use "
                             f"one of {', '.join(table)}.")
        factor = table[u]
        if factor is None:  # translational wheel speed -> spin rate
            if wheel_radius is None:
                raise UnitsError(f"{source}: column {col!r} in {unit}: a wheel radius is needed to convert it.")
            radius = wheel_radius.get(col) if isinstance(wheel_radius, dict) else wheel_radius
            if radius is None:
                raise UnitsError(f"{source}: column {col!r} in {unit}: a wheel radius is needed to convert it.")
            factor = (1.0 if u == "m/s" else 1.0 / 3.6) / radius
        import pandas as pd

        converted[col] = pd.to_numeric(frame[col], errors="coerce") * factor
    return frame.assign(**converted)


#: A time step longer than this many sample periods is a gap (lost samples), refused by :func:`check_sample_rate` and
#: :func:`resample_log` alike (interpolating across it would invent the signal).
MAX_GAP_STEPS = 3.0


def resample_log(frame, rate: float | None = None, *, max_gap_steps: float = MAX_GAP_STEPS, source: str = "log"):
    """Resample a jittered log onto a uniform time base by linear interpolation of every numeric column.

    Parameters
    ----------
    frame : pandas.DataFrame
        Log with a ``time`` column in s (increasing).
    rate : float, optional
        Output rate, Hz (default: 1 / mean step, the step rounded to 1e-6 s).
    max_gap_steps : float
        A step longer than this many output periods is a gap (lost samples): interpolating across it
        would invent data, so it is an error naming the time.

    Returns
    -------
    pandas.DataFrame
        Same columns, ``time`` = t0 + k / rate covering [t0, t_end].
    """
    import pandas as pd

    if rate is not None and not (math.isfinite(float(rate)) and float(rate) > 0):
        raise InputError(f"--resample rate must be a positive number of Hz; got {rate!r}.")
    frame = _without_repeated_rows(frame, source)
    t = pd.to_numeric(frame["time"], errors="coerce").to_numpy(float)
    if t.size < 3:
        raise InputFormatError(f"{source}: cannot resample: the log has {t.size} sample(s); it needs at least 3.")
    check_time_order(t, source=source, rows=frame.index.to_numpy())
    d = np.diff(t)
    tick = 1.0 / _tick_rate(d, float(np.median(d)))  # the logger's own period (dropped samples do not move it)
    step = round(float((t[-1] - t[0]) / (t.size - 1)), 6) if rate is None else 1.0 / float(rate)
    if step < tick * (1 - 1e-3):
        raise InputError(f"{source}: --resample {1 / step:g} Hz is above the log's own {1 / tick:.6g} Hz (median step "
                         f"{tick:.6g} s): upsampling by interpolation adds no information and makes the noise of "
                         f"neighbouring samples alike, which the filters take as independent (overconfident stds); "
                         f"resample at {1 / tick:.6g} Hz or below.")
    k = int(np.argmax(d))
    if d[k] > max_gap_steps * step:
        raise InputFormatError(f"{source}: the log has a gap of {d[k]:.4g} s at t = {t[k]:.6g} s (> {max_gap_steps:g} "
                               f"periods of {step:.4g} s); resampling would invent data: cut the log there.")
    n = int(math.floor((t[-1] - t[0]) / step + 1e-9)) + 1
    tn = t[0] + step * np.arange(n)
    cols = {"time": tn}
    for c in frame.columns:
        if c == "time":
            continue
        v = pd.to_numeric(frame[c], errors="coerce").to_numpy(float)
        cols[c] = np.interp(tn, t, v)  # a NaN spreads to its neighbours and is reported by the log's reader
    return pd.DataFrame(cols)


def _tick_rate(steps, median: float) -> float:
    """The logger's rate, Hz, to 4 digits: the mean of the steps near the median step (the mean over all steps counts
    dropped samples, 99 Hz for a 100 Hz logger that lost 1 %; the median alone follows the jitter, 999.654 Hz)."""
    near = steps[np.abs(steps - median) < 0.5 * median]
    return float(f"{1.0 / float(np.mean(near)):.4g}")


def _without_repeated_rows(frame, source: str):
    """``frame`` without the rows that repeat the row before exactly (time and every value: duplicated samples);
    two rows at one time with different values are refused (which one is right cannot be known)."""
    import pandas as pd

    values = frame.apply(pd.to_numeric, errors="coerce").to_numpy(float)
    t = values[:, list(frame.columns).index("time")]
    same_time = np.r_[False, t[1:] == t[:-1]]
    if not same_time.any():
        return frame
    equal = np.r_[False, np.all((values[1:] == values[:-1]) | (np.isnan(values[1:]) & np.isnan(values[:-1])), axis=1)]
    differ = same_time & ~equal
    if differ.any():
        i = int(np.flatnonzero(differ)[0])
        raise InputFormatError(f"{source}: rows {frame.index[i - 1]} and {frame.index[i]} have the same time "
                               f"({t[i]:.10g} s) but other values: two samples at one time; keep the right one and "
                               "drop the other.")
    return frame[~same_time]


def check_sample_rate(time, *, minimum: float, what: str, source: str = "log", jitter_rtol: float = 1e-3,
                      maximum: float | None = None) -> float:
    """Check the time base: increasing, uniform (else suggest ``--resample``), and fast enough; return dt (s).

    A median step of 0.5 s or more in a vehicle log is almost always milliseconds read as seconds, and the
    message says so. With ``maximum`` (Hz), a faster rate is refused too: a time in ms declared (or read) as
    seconds' thousandths, e.g. ``--units time=ms`` on a log in s, gives a 1 MHz log.
    """
    t = np.asarray(time, float)
    if t.size < 3:
        raise InputFormatError(f"{source}: the log has {t.size} sample(s); the filters need at least 3.")
    check_time_order(t, source=source, resample_hint=True)
    d = np.diff(t)
    dt = float(np.median(d))
    if dt >= 0.5:
        raise UnitsError(f"{source}: column 'time': median step {dt:g} s ({1 / dt:.3g} Hz) is implausible for a vehicle "
                         "log; if the time is in milliseconds declare it: header 'time [ms]' or --units time=ms.")
    # one rule with differentiate (longprofile._validation.uniform_time_step): a gap, stamps rounded too coarsely
    # (1024 Hz in whole ms), jitter; the mean step (whole-us stamps at 1024 Hz, 976/977 us, are uniform to 0.05 %)
    dt = uniform_time_step(t, source=source, max_gap_steps=MAX_GAP_STEPS,
                           gap_fix="the filters need a continuous log; cut the log at the gap and estimate each part",
                           rounded_fix="write the time with more digits",
                           jitter_fix=f"the filters use a fixed step: resample it explicitly with --resample "
                                      f"{_tick_rate(d, dt):g} (Hz, the logger's tick, not counting dropped samples; "
                                      "linear interpolation, gaps refused)")
    if maximum is not None and 1.0 / dt > maximum:
        raise UnitsError(f"{source}: column 'time': sample rate {1 / dt:.4g} Hz (median step {dt:.3g} s) is beyond the "
                         f"{maximum:g} Hz of a vehicle logger: a time unit mistake (time in s declared as ms, or in ks)?"
                         " declare the unit the column really has (header 'time [s]', 'time [ms]' or --units time=...).")
    if 1.0 / dt < minimum * (1 - 1e-6):  # 500 Hz from 0.0020000000000000018 s steps is 500 Hz
        raise InputError(f"{source}: sample rate {1 / dt:.4g} Hz is below the {minimum:g} Hz that {what}.")
    return dt


#: Longest run of blank cells that ``fill="hold"`` bridges, s: a channel logged at 10 Hz or faster (a longer run is a
#: dropout, not a slower channel).
MAX_HOLD = 0.1
FILLS = ("hold",)


def _prepared(frame, units, quantities: dict, aliases: dict, *, rename, fill, source: str, wheel_radius=None,
              strict: bool = False):
    """The log with its columns renamed (``rename``), header units split, aliases read, the time in seconds (numbers,
    ISO 8601 texts or datetime64), blanks held (``fill="hold"``) and the declared units converted to SI; with the
    file's own column names (for the messages)."""
    columns = [str(c) for c in frame.columns]
    if fill is not None and fill not in FILLS:
        raise InputError(f"--fill must be one of {list(FILLS)} (hold: each channel's last sample); got {fill!r}.")
    frame = renamed_columns(frame, dict(rename or {}), source=source)
    frame, declared = _with_aliases(frame, units, quantities, aliases, source=source, strict=strict)
    if "time" in frame.columns:
        t, start = time_seconds(frame, "time", source=source)
        if start is not None and "time" in declared:
            if _norm_unit(declared["time"]) != "s":
                raise UnitsError(f"{source}: column 'time' holds date-times (from {start}), read as seconds from the "
                                 f"first sample; the unit {declared['time']!r} declared for it does not apply: remove "
                                 "it.")
            declared.pop("time")
        frame = frame.assign(time=t)
        if fill == "hold":
            frame = _hold_blanks(frame, [c for c in quantities if c in frame.columns and c != "time"], t, source)
    frame = convert_units(frame, declared, quantities, wheel_radius=wheel_radius, source=source)
    return frame, columns


def _hold_blanks(frame, channels, t, source: str, max_hold: float = MAX_HOLD):
    """Zero-order hold of the blank cells of each channel (a multi-rate export leaves the slower channels blank
    between their samples): each blank takes the channel's last sample. ASSUMPTION: a blank is a sample the channel
    did not send; the hold delays a channel by up to its own period. Runs longer than ``max_hold`` s and text cells
    are refused; the first rows, before every channel's first sample (at most ``max_hold`` s), are dropped."""
    import pandas as pd

    held, first = {}, 0
    for c in channels:
        num = pd.to_numeric(frame[c], errors="coerce")
        text = (frame[c].notna() & num.isna()).to_numpy()
        if text.any():
            i = int(np.flatnonzero(text)[0])
            raise InputFormatError(f"{source}: column {c!r} holds {frame[c].iloc[i]!r} at row {frame.index[i]}: not a "
                                   "number; --fill hold fills blank cells only.")
        blank = num.isna().to_numpy()
        if blank.all():
            continue  # reported as a blank channel by the reader
        lead = int(np.argmax(~blank))
        first = max(first, lead)
        for a, b in true_runs(blank[lead:]):
            a, b = a + lead, b + lead
            end = t[b + 1] if b + 1 < t.size else t[b]
            if end - t[a - 1] > max_hold + 1e-9:
                raise InputFormatError(f"{source}: column {c!r} is blank for {end - t[a - 1]:.4g} s from row "
                                       f"{frame.index[a]} (t = {t[a]:.6g} s): longer than the {max_hold:g} s --fill "
                                       "hold bridges (a dropout, not a slower channel); cut the log there.")
        held[c] = num.ffill()
    if first and t[first] - t[0] > max_hold + 1e-9:
        raise InputFormatError(f"{source}: a channel starts {t[first] - t[0]:.4g} s after the first row (row "
                               f"{frame.index[first]}): --fill hold has nothing to hold before it; cut the first "
                               f"{t[first] - t[0]:.4g} s.")
    return frame.assign(**held).iloc[first:] if held else frame


def _missing_channels(frame, columns, need, quantities: dict, source: str, what: str) -> None:
    """Refuse a log without the channels ``need``, naming them with their SI unit, the file's columns and any column
    that looks like a missing channel with an unknown unit suffix."""
    missing = [c for c in need if c not in frame.columns]
    if not missing:
        return
    si = {"time": "s", "angle": "rad", "rate": "rad/s", "accel": "m/s^2", "length": "m", "current": "A",
          "wheel": "rad/s"}
    hints = "".join(f"; {h}" for h in _unknown_suffix_hints(columns, missing, quantities))
    raise InputFormatError(f"{source}: missing channel(s) {', '.join(f'{c} ({si[quantities[c]]})' for c in missing)}; "
                           f"{what}; the file has {columns}{hints}. Columns of other names: --rename OLD=NEW.")


def _blank_channels(frame, channels, source: str) -> None:
    """Refuse a blank or non-numeric cell in a channel, with its row, its share of the log and the remedies
    (``--fill hold`` for a multi-rate export, whose slower channels are blank between their samples)."""
    import pandas as pd

    for c in channels:
        bad = pd.to_numeric(frame[c], errors="coerce").isna().to_numpy()
        if bad.any():
            i, n = int(np.flatnonzero(bad)[0]), int(bad.sum())
            fix = ("a multi-rate export (the slower channels blank between their samples)? --fill hold holds each "
                   f"channel's last sample over blanks of up to {MAX_HOLD:g} s; else fill or cut the gap"
                   if n >= 0.1 * bad.size else
                   f"fill or cut the gap (--fill hold holds the last sample over blanks of up to {MAX_HOLD:g} s)")
            raise InputFormatError(f"{source}: column {c!r} has a blank or non-numeric value at row {frame.index[i]} "
                                   f"({n} of {bad.size} rows): {fix}; the estimators need every channel at every "
                                   "sample.")


# ------------------------------------------------------------------------------------------ planar logs

@dataclass(frozen=True)
class LogCheck:
    """One redundancy check of a drive log: ``ratio`` of a channel to its prediction from other channels.

    ``ok`` is None when the log did not excite the check enough (``samples`` below the minimum). ``steering_offset``
    holds the median steering angle on straight driving (rad) in ``ratio``, ``expected`` its refusal limits;
    ``warning`` is a passed check's caution for the user ("" if none).
    """

    name: str
    ratio: float
    expected: tuple
    samples: int
    ok: bool | None
    warning: str = ""


def _slope_through_origin(x, y, mask, min_samples):
    n = int(mask.sum())
    if n < min_samples:
        return math.nan, n
    xx, yy = x[mask], y[mask]
    return float(np.dot(xx, yy) / np.dot(xx, xx)), n


def _moving_average(x, n):
    """Centred moving average over n samples (odd width 2 (n // 2) + 1), shrinking at the ends."""
    h = n // 2
    if h == 0 or x.size <= 2 * h + 1:
        return x
    c = np.concatenate([[0.0], np.cumsum(x)])
    out = np.empty_like(x)
    w = 2 * h + 1
    out[h:x.size - h] = (c[w:] - c[:x.size - 2 * h]) / w
    for k in range(h):  # the ends: the window is cut by the record
        out[k] = c[k + h + 1] / (k + h + 1)
        j = x.size - 1 - k
        out[j] = (c[x.size] - c[j - h]) / (x.size - j + h)
    return out


def check_drive_log(log, vehicle, *, source: str = "log", raise_on_error: bool = True, accept=()) -> tuple:
    """Plausibility of a drive log's units and signs from its redundant channels (see the module notes).

    Parameters
    ----------
    log : DriveLog
        SI log (after :func:`convert_units`).
    vehicle : Vehicle
        R, S_b, L of the car.
    raise_on_error : bool
        Raise on a failed check (default), else only return the checks.
    accept : iterable of str
        Names of :data:`ACCEPTABLE_CHECKS` whose failure is printed as a warning instead (``--accept-check``).

    Returns
    -------
    tuple of LogCheck
        ``yaw_rate_vs_wheels``, ``accel_y_vs_vx_r``, ``steering_vs_yaw_rate``, ``accel_x_vs_dvx``,
        ``front_vs_rear_wheel_speed`` (the car file's front/rear rolling radii on steady straight driving),
        ``steering_gain`` and ``axle_order`` (the car file's understeer and driven axle, :mod:`._consistency`); with the
        ``steer_fl``, ``steer_fr`` channels (``log.wheel_steering``) also ``steer_fr_vs_steer_fl``,
        ``steer_difference_vs_ackermann`` and ``steering_angle_vs_steer_mean`` (see the module notes).

    Raises
    ------
    UnitsError
        Naming the channel(s), the ratio measured and the likely mistake (units, sign convention,
        steering-wheel angle), for every failed check in one message; also for out-of-range channels.
    """
    # the rear (undriven, unsteered on the default car) axle's radius and track; each wheel's own radius
    R, Sb, L = vehicle.wheel_radii[1], vehicle.tracks[1], vehicle.wheelbase
    dt = log.dt
    w = log.wheel_speeds
    v = R * 0.5 * (w[:, 2] + w[:, 3])
    dead = _dead_wheels(log, vehicle)
    if dead and raise_on_error:  # the ratios below would blame the car file or a unit for it
        raise InputFormatError(f"{source}: " + "; ".join(dead) + ".")
    problems = _range_problems(log, vehicle)
    smooth = max(1, int(round(0.2 / dt)))  # 0.2 s moving average: the checks are about gains, not noise
    rw = _moving_average(R * (w[:, 3] - w[:, 2]) / Sb, smooth)
    r = _moving_average(log.yaw_rate, smooth)
    vs = _moving_average(v, smooth)
    ay = _moving_average(log.accel_y, smooth)
    ax = _moving_average(log.accel_x, smooth)
    wheel_steering = getattr(log, "wheel_steering", None)
    # the angle the model steers by: the mean of the measured front wheels when the log has them
    steer = log.steering_angle if wheel_steering is None else 0.5 * (wheel_steering[:, 0] + wheel_steering[:, 1])
    steer_name = "steering_angle" if wheel_steering is None else "mean(steer_fl, steer_fr)"
    delta = _moving_average(steer, smooth)
    min_n = max(3, int(round(0.5 / dt)))  # half a second of turning (or accelerating)
    moving = vs > 3.0
    accept = _accepted(accept)
    axle = _axle_order_check(log, vehicle, (delta, vs, ay, ax), smooth, accept)
    swapped = axle.ok is False and "axle_order" not in accept
    if swapped and raise_on_error and not problems:  # alone: the ratios below would blame a unit or the car file
        raise InputFormatError(f"{source}: {axle_message(axle.ratio, vehicle)}.")
    checks = [_yaw_rate_check(rw, r, moving, min_n, R, problems)]
    ok1 = checks[0].ok
    vr = vs * r
    k2, n2 = _slope_through_origin(vr, ay, moving & (np.abs(vr) > 0.5), min_n)
    ok2 = None if math.isnan(k2) else bool(0.75 <= k2 <= 1.3)
    yaw_ok = ok1 is not False  # a wrong gyro spoils the next two ratios: report it alone
    checks.append(LogCheck("accel_y_vs_vx_r", k2, (0.75, 1.3), n2, ok2))
    if ok2 is False and yaw_ok:
        hint = _likely_factor(k2, {"accel_y in g (declare 'accel_y [g]')": 1 / GRAVITY,
                                   "accel_y of opposite sign (y to the right): negate accel_y": -1.0,
                                   "yaw_rate in deg/s (declare 'yaw_rate [deg/s]')": math.pi / 180}, (0.75, 1.3))
        problems.append(f"accel_y / (V_x yaw_rate) = {k2:.3g}, expected about 1 (eq. (11)): {hint}")
    offset, n_straight = straight_steering_offset(delta, r, ay, vs, dt) if yaw_ok else (math.nan, 0)
    ok_offset = None if math.isnan(offset) else bool(abs(offset) <= STEERING_OFFSET_LIMIT)
    ratio = getattr(vehicle, "steering_ratio", None)
    checks.append(LogCheck("steering_offset", offset, (-STEERING_OFFSET_LIMIT, STEERING_OFFSET_LIMIT), n_straight,
                           ok_offset, offset_warning(offset, n_straight, dt, steer_name, ratio) if ok_offset else ""))
    if ok_offset is False:
        problems.append(offset_problem(offset, n_straight, dt, steer_name, ratio))
    if ok_offset is not None:  # the bicycle check reads the angle less its offset (else it blames a steering wheel)
        delta = delta - offset
    kin = vs * delta / L
    k3, n3 = _slope_through_origin(kin, r, moving & (np.abs(kin) > 0.03), min_n)
    ok3 = None if math.isnan(k3) else bool(0.3 <= k3 <= 1.3)
    checks.append(LogCheck("steering_vs_yaw_rate", k3, (0.3, 1.3), n3, ok3))
    if ok3 is False and yaw_ok:
        turning = moving & (np.abs(kin) > 0.03)
        gain = bicycle_yaw_gain(vehicle, float(np.median(vs[turning]))) if turning.any() else math.nan
        problems.append(_steering_problem(k3, steer_name, wheel_steering is None, gain / k3, vehicle))
    checks.append(_steering_gain_check(vehicle, (delta, r, vs, ay), dt, steer_name, yaw_ok and ok3 is not False,
                                       accept, problems))
    dv = np.gradient(vs, dt)
    dv = _moving_average(dv, smooth)
    k4, n4 = _slope_through_origin(dv, ax, moving & (np.abs(dv) > 0.5), min_n)
    ok4 = None if math.isnan(k4) else bool(0.7 <= k4 <= 1.4)
    checks.append(LogCheck("accel_x_vs_dvx", k4, (0.7, 1.4), n4, ok4))
    if ok4 is False:
        hint = _likely_factor(k4, {"accel_x in g (declare 'accel_x [g]')": 1 / GRAVITY,
                                   "accel_x of opposite sign (x backward): negate accel_x": -1.0}, (0.7, 1.4))
        problems.append(f"accel_x / (dV_x/dt) = {k4:.3g}, expected about 1 (eq. (11); the grade only offsets it): "
                        f"{hint}")
    # front against rear axle speed on steady straight driving: the rolling radii of the car file (staggered tyres)
    Rf = vehicle.wheel_radii[0]
    vf = _moving_average(Rf * 0.5 * (w[:, 0] + w[:, 1]), smooth)
    steady = moving & (np.abs(ax) < 1.0) & (np.abs(r) < 0.05) & (np.abs(delta) < 0.02)
    k8, n8 = _slope_through_origin(vs, vf, steady, min_n)
    ok8 = None if math.isnan(k8) else bool(0.97 <= k8 <= 1.03)
    checks.append(LogCheck("front_vs_rear_wheel_speed", k8, (0.97, 1.03), n8, ok8))
    if ok8 is False and ok1 is not False:
        problems.append(f"R_f omega_front / (R_r omega_rear) = {k8:.4g} on steady straight driving, expected 1 within "
                        f"the tyres' slip (0.97..1.03): the vehicle file's wheels.radius {Rf:.4g} / {R:.4g} m (front / "
                        f"rear) does not match this car; staggered tyres? if the rear radius is right, the front one "
                        f"is about {Rf / k8:.4g} m (wheels.radius = [front, rear])")
    checks.append(axle)
    if swapped:
        problems.append(axle_message(axle.ratio, vehicle))
    if wheel_steering is not None:
        checks.extend(_wheel_steering_checks(log, vehicle, smooth, min_n, moving, problems))
    if problems and raise_on_error:
        raise UnitsError(f"{source}: implausible channels (units or signs): " + "; ".join(problems) + ".")
    return tuple(checks)


#: The checks of a log against the car file that ``accept`` (``--accept-check``) turns into warnings.
ACCEPTABLE_CHECKS = ("steering_gain", "axle_order")


def _accepted(accept) -> tuple:
    accept = (accept,) if isinstance(accept, str) else tuple(accept)
    unknown = [a for a in accept if a not in ACCEPTABLE_CHECKS]
    if unknown:
        raise InputError(f"--accept-check names {unknown}; the checks it can accept are {list(ACCEPTABLE_CHECKS)}.")
    return accept


def _steering_gain_check(vehicle, smoothed, dt, steer_name, steering_ok, accept, problems) -> LogCheck:
    """``steering_gain`` (:mod:`._consistency`); a refusal not in ``accept`` is appended to ``problems``, a warning
    (or an accepted refusal) is the check's warning. No check without steering excitation, and none when the cruder
    ``steering_vs_yaw_rate`` or the gyro already failed."""
    delta, r, vs, ay = smoothed
    gain, n, speed = steering_gain(delta, r, vs, ay, dt, vehicle) if steering_ok else (math.nan, 0, math.nan)
    ok, warn, band = gain_verdict(gain, speed, vehicle)
    text = gain_message(gain, speed, steer_name, vehicle, ok is False) if warn else ""
    if ok is False and "steering_gain" not in accept:
        problems.append(text)
    return LogCheck("steering_gain", gain, band, n, ok, text if ok or "steering_gain" in accept else "")


def _axle_order_check(log, vehicle, smoothed, smooth, accept) -> LogCheck:
    """``axle_order`` (:mod:`._consistency`): the front and rear wheel-speed columns told apart by the driven axle's
    slip; an accepted failure's line is the check's warning."""
    delta, vs, ay, ax = smoothed
    w = np.column_stack([_moving_average(log.wheel_speeds[:, j], smooth) for j in range(4)])
    q, n = axle_order(w, ax, ay, delta, vs, log.dt, vehicle)
    ok = None if math.isnan(q) else bool(q >= AXLE_SWAPPED)
    text = axle_message(q, vehicle) if ok is False and "axle_order" in accept else ""
    return LogCheck("axle_order", q, (AXLE_SWAPPED, math.inf), n, ok, text)


def _dead_wheels(log, vehicle) -> list[str]:
    """The wheel speed channels that do not turn while the others do: over at least half of the time the other three
    wheels' median R omega exceeds 3 m/s, the wheel reads below 10 % of it, or the same value throughout (a dead,
    disconnected or frozen sensor; a wheel locked under braking does so for a fraction of a second, a spinning one
    reads more, not less)."""
    w = np.asarray(log.wheel_speeds, dtype=float)
    speed = vehicle.wheel_radius_of_each * w
    names = ("wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr")
    out = []
    cols = [np.ascontiguousarray(speed[:, j]) for j in range(4)]
    for i, name in enumerate(names):
        a, b, c = (cols[j] for j in range(4) if j != i)
        others = np.maximum(np.minimum(a, b), np.minimum(np.maximum(a, b), c))  # their median, without a sort per row
        moving = others > 3.0
        if moving.sum() < 2:
            continue
        slow = float(np.mean(np.abs(speed[moving, i]) < 0.1 * others[moving]))
        stuck = bool(np.ptp(w[moving, i]) == 0.0)
        if slow >= 0.5 or stuck:
            what = (f"stays at {w[moving, i][0]:.4g} rad/s" if stuck else
                    f"reads below 10 % of the other wheels' speed over {100 * slow:.0f} % of the time they turn")
            out.append(f"{name} {what} while the other wheels turn (median {np.median(others[moving]):.3g} m/s): a "
                       "dead, disconnected or frozen wheel speed sensor? check it (the estimator needs all four)")
    return out


def _range_problems(log, vehicle) -> list[str]:
    """The channels out of any plausible range (wheel speeds, steering angle, yaw rate, accelerations)."""
    problems = []
    vmax = float(np.max(vehicle.wheel_radius_of_each * log.wheel_speeds))
    if vmax > 95.0:
        problems.append(f"wheel_speed_*: R omega reaches {vmax:.4g} m/s (> 95 m/s): wheel speeds in rpm or deg/s? "
                        "declare the unit (e.g. --units 'wheel_speed_*=rpm'), or check wheels.radius")
    smax = float(np.max(np.abs(log.steering_angle)))
    if smax > 0.8:
        problems.append(f"steering_angle reaches {smax:.3g} rad ({math.degrees(smax):.0f} deg), beyond a road wheel's "
                        "lock (~0.7 rad): a steering-WHEEL angle? name the column steering_wheel_angle and set "
                        "body.steering_ratio in the car file; or degrees ('steering_angle [deg]')?")
    rmax = float(np.max(np.abs(log.yaw_rate)))
    if rmax > 3.0:
        problems.append(f"yaw_rate reaches {rmax:.3g} rad/s (> 3 rad/s): deg/s? declare 'yaw_rate [deg/s]'")
    for k in ("accel_x", "accel_y"):
        amax = float(np.max(np.abs(getattr(log, k))))
        if amax > 20.0:
            problems.append(f"{k} reaches {amax:.3g} m/s^2 (> 2 g): check its unit")
    return problems


def _yaw_rate_check(rw, r, moving, min_n, R, problems) -> LogCheck:
    """``yaw_rate_vs_wheels``: the gyro against the rear wheels' speed difference (eq. (18)); a failure's likely
    cause is appended to ``problems``."""
    k1, n1 = _slope_through_origin(rw, r, moving & (np.abs(rw) > 0.03), min_n)
    ok1 = None if math.isnan(k1) else bool(0.93 <= k1 <= 1.07)
    if ok1 is False:
        hint = _likely_factor(k1, {
            "yaw_rate in deg/s (declare 'yaw_rate [deg/s]')": 180 / math.pi,
            "yaw_rate of opposite sign: a z-down / y-to-the-right (SAE) frame or a clockwise-positive gyro; negate "
            "yaw_rate and accel_y (and steering_angle if positive to the right)": -1.0,
            # a wheel column holding X = c omega is read as omega' = c omega, so the ratio is 1/c
            "wheel speeds in m/s (declare --units 'wheel_speed_*=m/s')": 1.0 / R,
            "wheel speeds in km/h (declare --units 'wheel_speed_*=km/h')": 1.0 / (3.6 * R),
            "wheel speeds in rpm (declare --units 'wheel_speed_*=rpm')": 2 * math.pi / 60,
            "left and right wheel columns swapped": -1.0,
        })
        if 0.8 <= k1 <= 1.25:
            hint += "; or wrong wheels.radius / body.track in the vehicle file"
        problems.append(f"yaw_rate / (R (omega_rr - omega_rl) / track) = {k1:.3g}, expected 1 (eq. (18)): {hint}")
    return LogCheck("yaw_rate_vs_wheels", k1, (0.93, 1.07), n1, ok1)


def _steering_problem(k3, steer_name, steering_angle_channel: bool, ratio_seen=math.nan, vehicle=None) -> str:
    """The failed ``steering_vs_yaw_rate`` check's message: sign, a steering-wheel angle or degrees, too small."""
    if k3 < 0:
        hint = (f"{steer_name} has the opposite sign of the turn: paper 001 wants it positive to the LEFT; "
                f"negate {'steering_angle' if steering_angle_channel else 'steer_fl and steer_fr'}")
    elif k3 < 0.3:
        hint = wheel_angle_hint(steer_name, 1 / k3, ratio_seen, vehicle)
    else:
        hint = f"{steer_name} too small: in mrad? or a steering ratio applied twice"
    return (f"yaw_rate / (V_x {steer_name} / wheelbase) = {k3:.3g}, expected 0.3..1.3 (bicycle "
            f"model, understeering car): {hint}")


#: Tolerance of the left-right steer difference around the Ackermann one, rad (2 deg: toe, compliance steer).
_STEER_DIFFERENCE_TOL = 0.035


def _wheel_steering_checks(log, vehicle, smooth, min_n, moving, problems) -> list:
    """The three checks of the measured front wheel angles (module notes); appends their failures to ``problems``."""
    fl = _moving_average(log.wheel_steering[:, 0], smooth)
    fr = _moving_average(log.wheel_steering[:, 1], smooth)
    mean = 0.5 * (fl + fr)
    turning = moving & (np.maximum(np.abs(fl), np.abs(fr)) > 0.01)
    checks = []
    k5, n5 = _slope_through_origin(fl, fr, turning, min_n)
    ok5 = None if math.isnan(k5) else bool(0.6 <= k5 <= 1.67)
    checks.append(LogCheck("steer_fr_vs_steer_fl", k5, (0.6, 1.67), n5, ok5))
    if ok5 is False:
        if k5 < 0:
            hint = ("steer_fl and steer_fr have opposite signs: both must be positive to the LEFT (paper 001); "
                    "negate the one that is positive to the right")
        else:
            hint = _likely_factor(k5, {"steer_fr in degrees (declare 'steer_fr [deg]')": 180 / math.pi,
                                       "steer_fl in degrees (declare 'steer_fl [deg]')": math.pi / 180,
                                       "steer_fr in mrad (declare 'steer_fr [mrad]')": 1000.0,
                                       "steer_fl in mrad (declare 'steer_fl [mrad]')": 1e-3}, (0.6, 1.67))
            if 0.3 < k5 < 3.0:
                hint = ("an offset (zero error) or a scale error of one of the two steer sensors: compare them on a "
                        "straight run and in a steady turn")
        problems.append(f"steer_fr / steer_fl = {k5:.3g}, expected about 1 (0.6..1.67 with Ackermann steering): "
                        f"{hint}")
    # measured left-right difference against the Ackermann linkage's at the same mean angle (ackermann_angles)
    L, hb = vehicle.wheelbase, 0.5 * vehicle.tracks[0]
    t = np.tan(mean)
    ackermann = np.arctan2(L * t, L - hb * t) - np.arctan2(L * t, L + hb * t)
    excess = np.abs((fl - fr) - ackermann) / (_STEER_DIFFERENCE_TOL + np.abs(ackermann))
    n6 = int(moving.sum())
    k6 = float(np.max(excess[moving])) if n6 >= min_n else math.nan
    ok6 = None if math.isnan(k6) else bool(k6 <= 1.0)
    checks.append(LogCheck("steer_difference_vs_ackermann", k6, (0.0, 1.0), n6, ok6))
    if ok6 is False and ok5 is not False:
        j = int(np.flatnonzero(moving)[np.argmax(excess[moving])])
        problems.append(f"steer_fl - steer_fr = {fl[j] - fr[j]:.3g} rad at t = {log.time[j]:.4g} s, but an Ackermann "
                        f"linkage gives {ackermann[j]:.3g} rad at their mean {mean[j]:.3g} rad (tolerance "
                        f"{_STEER_DIFFERENCE_TOL:g} rad + |Ackermann|): an offset between the two steer sensors, "
                        "opposite signs or units, or a wrong body.track / wheelbase")
    # steering_angle (left out of the log: it is their mean, the ratio is then 1)
    delta = _moving_average(log.steering_angle, smooth)
    k7, n7 = _slope_through_origin(mean, delta, turning, min_n)
    ok7 = None if math.isnan(k7) else bool(0.8 <= k7 <= 1.25)
    checks.append(LogCheck("steering_angle_vs_steer_mean", k7, (0.8, 1.25), n7, ok7))
    if ok7 is False:
        hint = _likely_factor(k7, {"steering_angle in degrees (declare 'steering_angle [deg]')": 180 / math.pi,
                                   "steering_angle of opposite sign (positive to the right)": -1.0}, (0.8, 1.25))
        if k7 > 5 and "degrees" not in hint:
            hint = (f"steering_angle is {k7:.3g} times the wheels' angle: a steering-WHEEL angle (divide by the "
                    "steering ratio)")
        elif 0.3 < k7 < 3.0:
            hint = "an offset (zero error) or a scale error between steering_angle and the steer sensors"
        problems.append(f"steering_angle / mean(steer_fl, steer_fr) = {k7:.3g}, expected about 1 (0.8..1.25): "
                        f"{hint}; with steer_fl and steer_fr the model does not use steering_angle (it may be "
                        "left out of the log)")
    return checks


def _likely_factor(ratio: float, candidates: dict, band=(0.9, 1.1)) -> str:
    """The candidate mistakes whose factor f explains ``ratio``: ratio / f within ``band`` (the check's range)."""
    hits = [name for name, f in candidates.items() if band[0] <= ratio / f <= band[1]]
    return " or ".join(dict.fromkeys(hits)) if hits else "a unit or sign mistake in one of these channels"


def read_drive_log(frame, vehicle, *, units: dict | None = None, resample: float | None = None,
                   check: bool = True, rename: dict | None = None, fill: str | None = None,
                   steering_offset: float = 0.0, accept=(), source: str = "log"):
    """Build a :class:`DriveLog` from a table with declared units, explicit resampling and plausibility checks.

    Parameters
    ----------
    frame : pandas.DataFrame
        The channels of docs/vehicle-slope.md, headers optionally ``name [unit]``; the optional ``steer_fl``,
        ``steer_fr`` (measured front-left and front-right road-wheel angles, angle units) are read too.
    vehicle : Vehicle
        Needed for wheel speeds logged in m/s or km/h (R) and for the checks.
    units : dict, optional
        {column: unit}, overrides the header units.
    resample : float, optional
        Resample onto this rate (Hz) by linear interpolation first (jittered time stamps).
    check : bool
        Run :func:`check_drive_log` (default True).
    rename : dict, optional
        {file's column: channel name} applied first (``--rename``; :func:`~longprofile._validation.renamed_columns`).
    fill : {None, "hold"}
        ``"hold"``: each channel's blank cells take its last sample (a multi-rate export), over up to
        :data:`MAX_HOLD` s.
    steering_offset : float
        Subtracted from the road-wheel steering angles (rad; ``--steering-offset``): a steering sensor's zero error,
        as the ``steering_offset`` check measures it. A ``steering_wheel_angle`` column (any angle unit) is divided
        by ``vehicle.steering_ratio`` first.
    accept : iterable of str
        Checks of :data:`ACCEPTABLE_CHECKS` whose failure is a warning, not a refusal (``--accept-check``).

    Returns
    -------
    (DriveLog, tuple of LogCheck)
    """
    from .planar import LOG_COLUMNS, DriveLog
    from .planar._simulate import WHEEL_STEERING_COLUMNS

    radii = dict(zip(("wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr"),
                     vehicle.wheel_radius_of_each.tolist()))
    frame, columns = _prepared(frame, units, _PLANAR_QUANTITY, _PLANAR_ALIASES, rename=rename, fill=fill,
                               source=source, wheel_radius=radii)
    # steering_wheel_angle / body.steering_ratio, less the stated --steering-offset
    frame = steering_from_wheel_angle(frame, vehicle, offset=steering_offset, source=source)
    steer = all(c in frame.columns for c in WHEEL_STEERING_COLUMNS)
    need = [c for c in LOG_COLUMNS if not (steer and c == "steering_angle")]
    _missing_channels(frame, columns, need, _PLANAR_QUANTITY, source,
                      f"a drive log needs {list(LOG_COLUMNS)} (see docs/vehicle-slope.md)")
    _blank_channels(frame, need[1:] + (list(WHEEL_STEERING_COLUMNS) if steer else []), source)  # time: its own check
    if "time" in frame.columns:
        if resample is not None:
            frame = resample_log(frame, resample, source=source)
        import pandas as pd

        check_sample_rate(pd.to_numeric(frame["time"], errors="coerce").to_numpy(float), minimum=50.0,
                          what="the planar EKF of eq. (20) needs (explicit Euler step; ABS logs run at 100 Hz to 1 kHz)",
                          source=source, jitter_rtol=1e-6)
    log = DriveLog.from_frame(frame, source=source)
    checks = check_drive_log(log, vehicle, source=source, accept=accept) if check else ()
    return log, checks


# ------------------------------------------------------------------------------------------ vertical logs

def _partial_sets(cols) -> list[tuple[str, list[str], list[str]]]:
    """(prefix, corners present, corners missing) of each corner channel group present at some corners only."""
    out = []
    for prefix in ("wheel_accel", "body_accel", "current"):
        have = [c for c in _CORNERS if f"{prefix}_{c}" in cols]
        if 0 < len(have) < 4:
            out.append((prefix, have, [c for c in _CORNERS if c not in have]))
    return out


def infer_vertical_config(columns, *, source: str = "log") -> int:
    """Sensor configuration (thesis 003) from the columns: 3 with wheel_accel_*, 2 with body_accel_*, else 1.

    Raises
    ------
    InputError
        Both body_accel_* and wheel_accel_* columns, or accelerometers at some corners only (one channel lost:
        the configuration the user means is not known; a silent configuration 1 dropped the other three); the
        message names the missing channels and ``--config``.
    """
    cols = set(map(str, columns))
    for prefix, have, missing in _partial_sets(cols):
        if prefix == "current":
            continue
        cfg, alt, alt_prefix = (3, 2, "body_accel") if prefix == "wheel_accel" else (2, 3, "wheel_accel")
        other = alt if all(f"{alt_prefix}_{c}" in cols for c in _CORNERS) else 1
        raise InputError(f"{source}: the log has {', '.join(f'{prefix}_{c}' for c in have)} but no "
                         f"{', '.join(f'{prefix}_{c}' for c in missing)}: configuration {cfg} needs all four; add the "
                         f"missing channel(s), or say which configuration to run: --config {other} ignores the "
                         f"{prefix}_* columns.")
    wheel = all(f"wheel_accel_{c}" in cols for c in _CORNERS)
    body = all(f"body_accel_{c}" in cols for c in _CORNERS)
    if wheel and body:
        raise InputError(f"{source}: the log has both body_accel_* and wheel_accel_* columns; choose the "
                         "configuration with --config 2 or --config 3.")
    return 3 if wheel else 2 if body else 1


def _ignored_channels(cols, config: int) -> list[str]:
    """The accelerometer columns that configuration ``config`` does not read."""
    used = {2: "body_accel", 3: "wheel_accel"}.get(config)
    return [f"{p}_{c}" for p in ("body_accel", "wheel_accel") if p != used for c in _CORNERS if f"{p}_{c}" in cols]


#: Lowest sample rate accepted by the vertical estimators (the thesis's filters run at Te = 1 ms).
VERTICAL_MIN_RATE = 500.0
#: Highest sample rate a vertical log is believed to have, Hz (suspension loggers run at 0.1-10 kHz): beyond it the
#: time column's unit is wrong (session 40: ``--units time=ms`` on a log in s gave a 1 MHz log, a 1 us step and a
#: tyre-load RMS error of 1.15 kN instead of 0.20 kN).
VERTICAL_MAX_RATE = 100_000.0
#: Largest damper current of a MagneRide log accepted, A: automotive MR coils are driven 0-5 A
#: (``MRDamperParams.max_current``); twice that leaves room for another car and still refuses mA (5000).
MAX_DAMPER_CURRENT = 10.0
#: Most negative damper current accepted, A (a current driver's offset; the map reads negative currents as 0).
MIN_DAMPER_CURRENT = -0.5


def _check_currents(current, source: str) -> None:
    """Refuse damper currents out of an MR coil's range: in mA (beyond :data:`MAX_DAMPER_CURRENT`), or negative."""
    if current is None:
        return
    top, low = np.max(current, axis=0), np.min(current, axis=0)
    if np.any(top > MAX_DAMPER_CURRENT):
        bad = [f"current_{c}" for c, v in zip(_CORNERS, top) if v > MAX_DAMPER_CURRENT]
        raise UnitsError(f"{source}: {', '.join(bad)} reach{'es' if len(bad) == 1 else ''} {float(np.max(top)):.4g} A "
                         f"(> {MAX_DAMPER_CURRENT:g} A; MR dampers are driven 0-5 A): in mA? declare it: --units "
                         "'current_*=mA' (or head each column as 'current_FL [mA]').")
    if np.any(low < MIN_DAMPER_CURRENT):
        bad = [f"current_{c}" for c, v in zip(_CORNERS, low) if v < MIN_DAMPER_CURRENT]
        raise UnitsError(f"{source}: {', '.join(bad)} go{'es' if len(bad) == 1 else ''} down to "
                         f"{float(np.min(low)):.4g} A: an MR coil's current is >= 0 (the map reads it as 0, no force): "
                         "a sign or an offset of the current sensor? negate the column or subtract its zero reading.")


def read_vertical_log(frame, config: int | None = None, *, units: dict | None = None, resample: float | None = None,
                      rename: dict | None = None, fill: str | None = None, source: str = "log",
                      notes: list | None = None):
    """Build :class:`VerticalSensors` from a table with declared units, resampling, rate and range checks.

    Returns (sensors, config). ``config`` None infers it from the columns (:func:`infer_vertical_config`);
    ``rename`` and ``fill`` as in :func:`read_drive_log`. ``notes``, a list, receives one line per accelerometer
    group that an explicit ``config`` leaves out (``--config 1`` on a configuration-3 log).

    Raises
    ------
    UnitsError
        For a suspension deflection beyond +-0.3 m (the sensor range: a log in mm read as m), an
        accelerometer beyond 50 g, a sample rate beyond :data:`VERTICAL_MAX_RATE` (a time unit mistake), damper
        currents beyond :data:`MAX_DAMPER_CURRENT` (mA) or negative.
    InputError
        Below :data:`VERTICAL_MIN_RATE` Hz: the corner EKFs' coloured noises (tau = 10 ms for the tyre
        deflection, thesis 003 section 4.3) and the 13 Hz wheel hop are not resolved by explicit Euler at
        Te >= 2 ms. Accelerometers or damper currents at some corners only (:func:`infer_vertical_config`).
    """
    import pandas as pd

    from .vertical import DEFLECTION_RANGE, sensors_from_frame

    frame, columns = _prepared(frame, units, _VERTICAL_QUANTITY, _VERTICAL_ALIASES, rename=rename, fill=fill,
                               source=source, strict=True)
    cols = set(map(str, frame.columns))
    for prefix, have, missing in _partial_sets(cols):
        if prefix == "current":  # a MagneRide log: without one current the filter's actuator forces are all wrong
            raise InputError(f"{source}: the log has {', '.join(f'current_{c}' for c in have)} but no "
                             f"{', '.join(f'current_{c}' for c in missing)}: a MagneRide log needs the current of "
                             "each damper (the MR map's force); add the missing channel(s).")
    if config is None:
        config = infer_vertical_config(frame.columns, source=source)
    elif notes is not None and _ignored_channels(cols, config):
        notes.append(f"--config {config} ignores the log's {', '.join(_ignored_channels(cols, config))}")
    kinds = ("dz21",) + {2: ("body_accel",), 3: ("wheel_accel",)}.get(config, ())
    need = ["time", "ax", "ay", "yaw_rate"] + [f"{k}_{c}" for k in kinds for c in _CORNERS]
    if config in (1, 2, 3):  # another config is refused by sensors_from_frame
        _missing_channels(frame, columns, need, _VERTICAL_QUANTITY, source, f"configuration {config} needs {need}")
        _blank_channels(frame, need[1:], source)  # time: its own check
    if "time" in frame.columns:
        if resample is not None:
            frame = resample_log(frame, resample, source=source)
        check_sample_rate(pd.to_numeric(frame["time"], errors="coerce").to_numpy(float), minimum=VERTICAL_MIN_RATE,
                          what="the corner EKFs of thesis 003 need (tuned for Te = 1 ms)", source=source,
                          maximum=VERTICAL_MAX_RATE)
    sensors = sensors_from_frame(frame, config, source=source)
    dmax = float(np.max(np.abs(sensors.displacement)))
    if dmax > DEFLECTION_RANGE:
        raise UnitsError(f"{source}: dz21_*: suspension deflection reaches {dmax:.4g} m (> {DEFLECTION_RANGE:g} m, the "
                         "sensor range): in mm? declare it: --units 'dz21_*=mm' (or head each column as 'dz21_FL [mm]')")
    for name, a in (("body_accel_*", sensors.body_accel), ("wheel_accel_*", sensors.wheel_accel)):
        if a is not None and float(np.max(np.abs(a))) > 50 * GRAVITY:
            raise UnitsError(f"{source}: {name} exceeds 50 g: check its unit.")
    for name in ("ax", "ay"):
        if float(np.max(np.abs(getattr(sensors, name)))) > 20.0:
            raise UnitsError(f"{source}: {name} exceeds 20 m/s^2 (2 g): check its unit.")
    rmax = float(np.max(np.abs(sensors.yaw_rate)))
    if rmax > 3.0:  # the drive log's bound (_range_problems)
        raise UnitsError(f"{source}: yaw_rate reaches {rmax:.3g} rad/s (> 3 rad/s): deg/s? declare it: --units "
                         "yaw_rate=deg/s (or head the column 'yaw_rate [deg/s]').")
    _check_currents(sensors.damper_current, source)
    return sensors, int(config)
