"""The towing speed of an APL record against the speed its instrument model is for (paper 000's constant speed).

Paper 000's instrument model (eq. 1, Table 1) is the trailer's continuous-time dynamics discretised at ONE towing
speed: dt = dx / V. A record towed at another speed, or at a varying one, has other discrete dynamics at the same
dx, and the reconstruction is wrong by more than its printed ``std`` once the speed is off by about 1 % (measured:
docs/road-apl.md, "Assumption: constant towing speed"). This module reads that speed from the record, checks it
against the model's and says where the record cannot be vouched for.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..._validation import true_runs
from ...core import Profile
from ...errors import InputError
from ._model import TABLE1_CONFIGURATIONS, TrailerPoles, apl_model

__all__ = ["SPEED_TOLERANCE", "SPEED_TOLERANCES", "towing_speed", "speed_tolerance", "STOP_SPEED", "DEFAULT_TOWING_SPEED", "TowingSpeed", "SpeedCheck", "recording_speed",
           "choose_towing_speed", "check_speed_samples", "speed_range", "trailer_at_speed", "without_off_speed_std"]

#: Relative speed mismatch beyond which the printed 90 % band no longer covers the error, per model speed (m/s;
#: measured on 2 km ISO 8608 class C records at 5 cm, two draws: at 20 m/s coverage 85-89 % at 1 %, 82-85 % at 1.5 %,
#: 77-80 % at 2 %; at 6 m/s 88-89 % at 0.25 %, 82-83 % at 0.5 %, 65-67 % at 1 %). docs/road-apl.md.
SPEED_TOLERANCES = {20.0: 0.01, 6.0: 0.0025}
#: The tolerance at 20 m/s (paper 000's 72 km/h).
SPEED_TOLERANCE = SPEED_TOLERANCES[20.0]


def speed_tolerance(model_speed: float) -> float:
    """:data:`SPEED_TOLERANCES` at ``model_speed`` (m/s); at a speed not measured, the smallest (0.25 %)."""
    key = next((v for v in SPEED_TOLERANCES if np.isclose(v, model_speed, rtol=1e-9, atol=0)), None)
    return SPEED_TOLERANCES[key] if key is not None else min(SPEED_TOLERANCES.values())
#: Below this speed, m/s, the trailer is taken as stopped (not part of the towing speed's median).
STOP_SPEED = 1.0
#: The towing speed without a --speed and without a speed column, m/s (paper 000's 72 km/h).
DEFAULT_TOWING_SPEED = 20.0


def recording_speed(speed, *, stop_speed: float = STOP_SPEED) -> float | None:
    """The towing speed of a record: the median of its speed samples above ``stop_speed`` (m/s); None when none."""
    moving = _moving(speed, stop_speed)
    return float(np.median(moving)) if moving.size else None


def speed_range(speed, *, stop_speed: float = STOP_SPEED) -> tuple | None:
    """5th and 95th percentiles of the speed samples above ``stop_speed`` (m/s); None when none."""
    moving = _moving(speed, stop_speed)
    return tuple(float(p) for p in np.percentile(moving, [5, 95])) if moving.size else None


def _moving(speed, stop_speed):
    v = np.asarray(speed, float)
    return v[np.isfinite(v) & (v > stop_speed)]


@dataclass(frozen=True)
class TowingSpeed:
    """The speed a record is reconstructed at.

    Attributes
    ----------
    speed : float
        m/s: the model's speed.
    file_speed : float or None
        The record's median speed over moving samples, m/s (None: no speed column).
    source : str
        ``"option"`` (--speed), ``"file"`` (the speed column) or ``"default"`` (20 m/s).
    note : str
        One line saying where the speed comes from (empty for the default without a speed column).
    """

    speed: float
    file_speed: float | None
    source: str
    note: str = ""


def _kmh(v: float) -> str:
    return f"{v * 3.6:.4g} km/h = {v:.4g} m/s"


def choose_towing_speed(file_speed: float | None, given: float | None, *, dx: float, column: str = "speed",
                        label: str = "record", model_speed: float | None = None,
                        tolerance: float | None = None, speed_range: tuple | None = None) -> TowingSpeed:
    """The speed to reconstruct a record at, from ``--speed`` and the record's speed column.

    Parameters
    ----------
    file_speed : float or None
        :func:`recording_speed` of the record's speed column, m/s (None: the record has none).
    given : float or None
        ``--speed``, m/s (None: not given).
    dx : float
        Spacing, m (the Table 1 configurations available at it).
    column, label : str
        The speed column and the record, for messages.
    model_speed : float or None
        The speed of a ``--model`` file (None: the Table 1 model).
    tolerance : float, optional
        Relative mismatch refused (default :func:`speed_tolerance` of the model's speed).
    speed_range : (float, float), optional
        5th and 95th percentiles of the moving speed, m/s, named in a refusal when they differ by more than the
        tolerance (a varying speed: no single model fits it).

    Returns
    -------
    TowingSpeed
        ``given`` when it is given; else the Table 1 (or model file) speed within ``tolerance`` of the file's; else,
        for a varying speed (``speed_range`` wider than the smallest tolerance), the calibrated speed nearest the
        file's (in ratio): the trailer re-discretised at each station's speed (:func:`reconstruct_towed`); else
        :data:`DEFAULT_TOWING_SPEED` when the record has no speed column.

    Raises
    ------
    InputError
        ``given`` and the file's speed differ by more than ``tolerance``; no --speed and a constant file speed
        within ``tolerance`` of no calibrated model (Table 1 at this dx, or the model file).
    """
    where = f"the median of its column {column!r} over moving samples"
    varies = speed_range is not None and speed_range[1] / speed_range[0] - 1.0 > min(SPEED_TOLERANCES.values())
    if varies:
        where += f"; it varies from {3.6 * speed_range[0]:.3g} to {3.6 * speed_range[1]:.3g} km/h (5-95 %)"
    if file_speed is None:
        if given is not None:
            return TowingSpeed(float(given), None, "option")
        return TowingSpeed(DEFAULT_TOWING_SPEED, None, "default")
    if given is not None:
        off = file_speed / given - 1.0
        tolerance = speed_tolerance(given) if tolerance is None else tolerance
        if abs(off) > tolerance:
            raise InputError(f"{label}: --speed is {given:g} m/s but the record was towed at {_kmh(file_speed)} "
                             f"({where}; {100 * off:+.3g} %, more than the {100 * tolerance:g} % a reconstruction "
                             f"tolerates): " + ("leave out --speed: a record whose speed varies is reconstructed at "
                             "the speed of each station (docs/road-apl.md, 'Varying towing speed'), or correct the "
                             "column if it is wrong." if varies else
                             f"leave out --speed to use the file's speed (or give --speed {file_speed:.4g}), or correct "
                             "the column if it is wrong."))
        return TowingSpeed(float(given), file_speed, "option",
                           f"towing speed {given:g} m/s (--speed); the file's {column!r}: {_kmh(file_speed)}")
    if model_speed is not None:
        candidates = [model_speed]
    else:
        candidates = sorted({v for v, h in TABLE1_CONFIGURATIONS if np.isclose(h, dx, rtol=1e-9, atol=0)})
    tolerances = {v: speed_tolerance(v) if tolerance is None else tolerance for v in candidates}
    near = [v for v in candidates if abs(file_speed / v - 1.0) <= tolerances[v]]
    if near:
        return TowingSpeed(near[0], file_speed, "file", f"towing speed from the file: {_kmh(file_speed)} ({where}) "
                           f"-> the model for {near[0]:g} m/s")
    if varies and candidates:  # reconstructed at each station's speed: the trailer calibrated nearest the median
        base = min(candidates, key=lambda v: abs(np.log(file_speed / v)))
        return TowingSpeed(base, file_speed, "file", f"towing speed from the file: {_kmh(file_speed)} ({where}) "
                           f"-> the trailer calibrated at {base:g} m/s, re-discretised at each station's speed")
    what = (f"the model file is for {model_speed:g} m/s" if model_speed is not None else
            f"paper 000's Table 1 calibrates the trailer at dx {dx:g} m only for "
            f"{', '.join(f'{v:g}' for v in candidates) or 'no speed'} m/s")
    tol = ", ".join(f"{100 * t:g} % at {v:g} m/s" for v, t in tolerances.items())
    fix = (f"identify the trailer at {file_speed:.3g} m/s (longprofile road identify ... --speed {file_speed:.3g} "
           f"--dx {dx:g} -o model.json) and pass --model model.json")
    raise InputError(f"{label}: the record was towed at {_kmh(file_speed)} ({where}) but {what} (tolerance {tol}): "
                     f"{fix}.")


def towing_speed(distance, speed_column, given: float | None, *, dx: float, model_speed: float | None = None,
                 label: str = "record") -> tuple[TowingSpeed, SpeedCheck | None]:
    """The speed to reconstruct a record at, and the samples towed off it (``road reconstruct``, ``batch
    reconstruct``).

    Parameters
    ----------
    distance : (T,) array_like
        The record's stations, m.
    speed_column : SpeedColumn or None
        The record's towing speed at each station (``longprofile.io.read_apl_record``; ``.values`` m/s and
        ``.column``), or None when the file has none.
    given : float or None
        ``--speed``, m/s (None: not given).
    dx : float
        Spacing, m.
    model_speed : float or None
        The speed of an identified ``--model`` (None: the Table 1 model), used only when ``given`` is None.
    label : str
        The record, for messages.

    Returns
    -------
    (TowingSpeed, SpeedCheck or None)
        :func:`choose_towing_speed` (``--speed``, else the speed column's median over moving samples matched to a
        calibrated model, else 20 m/s) and, with a speed column, :func:`check_speed_samples` at that speed.
    """
    if speed_column is None:
        return choose_towing_speed(None, given, dx=dx), None
    v = speed_column.values
    chosen = choose_towing_speed(recording_speed(v), given, dx=dx, column=speed_column.column, label=label,
                                 model_speed=model_speed if given is None else None, speed_range=speed_range(v))
    return chosen, check_speed_samples(distance, v, chosen.speed)


@dataclass(frozen=True)
class SpeedCheck:
    """Where a record's local speed is off the model's by more than the tolerance.

    Attributes
    ----------
    ok : (T,) bool ndarray
        True where |v / model speed - 1| <= tolerance (NaN speed: False).
    ranges : tuple of (float, float)
        Distance ranges (m) of the samples that are not ok.
    share : float
        Share of the samples that are not ok, 0-1.
    model_speed, tolerance : float
    """

    ok: np.ndarray
    ranges: tuple
    share: float
    model_speed: float
    tolerance: float

    @property
    def warning(self) -> str | None:
        """One line naming the ranges and the share (None when every sample is ok)."""
        if not self.ranges:
            return None
        shown = ", ".join(f"{a:.0f}-{b:.0f} m" for a, b in self.ranges[:5])
        more = f" and {len(self.ranges) - 5} more range(s)" if len(self.ranges) > 5 else ""
        return (f"the towing speed is more than {100 * self.tolerance:g} % off the model's {self.model_speed:g} m/s "
                f"over {100 * self.share:.1f} % of the record ({shown}{more}): std_m and raw_std_m are NaN there (the "
                "reconstruction assumes a constant towing speed; its error there is not covered by the printed "
                "band: docs/road-apl.md, 'Assumption: constant towing speed').")


def check_speed_samples(distance, speed, model_speed: float, *, tolerance: float | None = None) -> SpeedCheck:
    """Flag the samples whose local towing speed (m/s) is off ``model_speed`` by more than ``tolerance`` (default
    :func:`speed_tolerance` of ``model_speed``)."""
    tolerance = speed_tolerance(model_speed) if tolerance is None else tolerance
    x = np.asarray(distance, float)
    v = np.asarray(speed, float)
    with np.errstate(invalid="ignore"):
        ok = np.abs(v / model_speed - 1.0) <= tolerance
    ranges = tuple((float(x[a]), float(x[b])) for a, b in true_runs(~ok))
    return SpeedCheck(ok, ranges, float(np.mean(~ok)) if v.size else 0.0, float(model_speed), float(tolerance))


def without_off_speed_std(rec, check: SpeedCheck):
    """``rec`` (a :class:`Reconstruction`) with ``profile.std`` and ``raw_std`` NaN where ``check`` is not ok, and
    its warning added."""
    if check.warning is None:
        return rec
    p = rec.profile
    std = None
    if p.std is not None:
        std = np.array(p.std, float, copy=True)
        std[~check.ok] = np.nan
    raw_std = None if rec.raw_std is None else np.where(check.ok, rec.raw_std, np.nan)
    profile = Profile(p.distance, p.elevation, tracks=p.tracks, std=std, name=p.name)
    return dataclasses.replace(rec, profile=profile, raw_std=raw_std, warnings=(*rec.warnings, check.warning))


def trailer_at_speed(speed: float, dx: float, *, table_speed: float = 20.0):
    """The Table 1 trailer of ``(table_speed, dx)`` towed at ``speed``: the same continuous-time pendulum, damper
    and RC sections discretised at dt = dx / speed.

    Each Table 1 pole p = |p| e^{±j 2 pi f dt} is a continuous pole s with |p| = e^{Re(s) dt}: at the new step the
    modulus is |p|^(dt'/dt) and the frequency f (Hz) is kept; the RC section follows dt through :func:`apl_model`.
    This is what a record towed at ``speed`` sampled every ``dx`` is, for a trailer calibrated at ``table_speed``
    (paper 000, eq. 1; used to measure the error of a speed mismatch). Returns an :class:`APLModel`.
    """
    p = TABLE1_CONFIGURATIONS[(float(table_speed), float(dx))]
    ratio = table_speed / speed  # dt' / dt
    poles = TrailerPoles(p.pendulum_modulus ** ratio, p.pendulum_frequency, p.damper_modulus ** ratio,
                         p.damper_frequency)
    return apl_model(speed, dx, poles=poles)
