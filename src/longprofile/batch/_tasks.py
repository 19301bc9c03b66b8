"""Batch tasks: the library calls of the single-file commands, as picklable per-file callables.

``IRITask`` is ``longprofile road iri`` (read_profile -> the IRI report -> segment table) and
``ReconstructTask`` is ``longprofile road reconstruct`` (APL recording -> reconstruct_profile with the CLI's
defaults) followed by the IRI of the reconstruction. Numpy is imported lazily (see ``_map``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from ..errors import InputError

__all__ = ["TaskOutput", "IRITask", "ReconstructTask", "options_hash", "TASKS"]

@dataclass(frozen=True, eq=False)
class TaskOutput:
    """What a task returns for one file.

    Attributes
    ----------
    segments : pandas.DataFrame
        One row per segment, the columns of the IRI report table (``start_m, end_m, iri_<track>_m_per_km``...).
    profile : pandas.DataFrame or None
        A per-sample table (the reconstructed profile for :class:`ReconstructTask`), else None.
    metadata : dict
        JSON-serialisable facts about the run (the IRI report's metadata, the fitted noise variances...).
    warning : str
        Empty, or one line about a suspicious result (an implausible IRI, no complete segment).
    """

    segments: Any
    profile: Any = None
    metadata: dict = field(default_factory=dict)
    warning: str = ""


def options_hash(name: str, options: dict) -> str:
    """Short sha256 of the task name and its options (canonical JSON): the key ``--resume`` compares."""
    text = json.dumps({"task": name, **options}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _finite_positive(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise InputError(f"{name} must be a finite number > 0; got {value!r}.")
    return float(value)


def _optional_float(name, value):
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"{name} must be a finite number or None; got {value!r}.")
    return float(value)


def _tracks_tuple(tracks):
    if tracks is None:
        return None
    names = (tracks,) if isinstance(tracks, str) else tuple(tracks)
    names = tuple(t.strip() for t in names if t and t.strip())
    if not names:
        raise InputError("tracks must name at least one track (or be None for all of them).")
    return names


# ---- the IRI report table ------------------------------------------------------------------------------------

#: Report units of ``iri_report``: length unit, metres per length unit, IRI unit, IRI per m/km, default interval.
_UNITS = {"si": ("m", 1.0, "m/km", 1.0, 100.0), "us": ("ft", 0.3048, "in/mi", 63.36, 528.0)}


def _iri_table(profile, task):
    """The report and its metadata from :func:`longprofile.road.iri_report` (the function ``road iri`` calls)."""
    from ..road import iri_report

    report = iri_report(profile, mode=task.mode, interval=task.interval, window=task.window, step=task.step,
                        start=task.start, units=task.units, tracks=task.tracks, lead_in=task.lead_in,
                        moving_average=task.moving_average, gaps=task.gaps, min_valid=task.min_valid)
    return report, dict(report.metadata)


def _warning(table, task, length_m: float) -> str:
    """One line about a result a user should look at (the notes of ``longprofile road iri``)."""
    lu, per_m, iu, factor, _ = _UNITS[task.units]
    if len(table) == 0:
        return (f"the profile ({length_m / per_m:g} {lu}) is shorter than one {task.window or task.interval:g} {lu} "
                "interval: no interval IRI; use a shorter --segment.")
    cols = [c for c in table.columns if str(c).startswith("iri_")]
    if not cols:
        return ""
    from ..road import iri_plausibility

    return iri_plausibility(table[cols].to_numpy(dtype=float) / factor, what="segment IRI")


def _tiny_profile(tracks, length):
    """A short smooth synthetic profile to compile the kernels on (ISO 8608 class A, 0.25 m)."""
    from ..road import iso8608_profile

    return iso8608_profile(length, 0.25, "A", rng=0, tracks=tracks)


def _default_tracks(path):
    """The rule of ``road iri``: a ``road reconstruct`` output is analysed on its profile track only, a ``road
    simulate`` recording on its true profile (its ``apl_m`` is the trailer's raw signal)."""
    from ..io import is_reconstruct_output, is_simulated_recording

    if is_reconstruct_output(Path(path)):
        return ("elevation",)
    return ("true",) if is_simulated_recording(Path(path)) else None


def _check_units(units):
    if units not in _UNITS:
        raise InputError(f"units must be 'si' (m, m/km) or 'us' (ft, in/mi); got {units!r}. The elevation unit of "
                         "file columns without one is elevation_unit (--elevation-unit).")


@dataclass(frozen=True)
class IRITask:
    """``longprofile road iri`` as a batch task: profile file -> :func:`~longprofile.road.iri_report` table.

    Parameters
    ----------
    mode : {"fixed", "continuous", "overlapping"}
        As ``iri_report`` (``--mode``).
    interval : float, optional
        Fixed segment length in the report's length unit (``--segment``; default 100 m, or 528 ft = 0.1 mi
        with ``units="us"``, as ``road iri``).
    window, step, start
        As ``iri_report``, report length unit.
    units : {"si", "us"}
        Report units: m and m/km, or ft and in/mi.
    tracks : sequence of str, optional
        Tracks to analyse (default: all tracks of each file; a ``road reconstruct`` output: ``elevation``).
    lead_in : float
        Initialisation length, m (ASTM E1926: 11 m).
    moving_average : {"auto", "on", "off"}
        The 250 mm moving average (``auto``: the ASTM E1926 rule).
    elevation_unit : str, optional
        Elevation unit of file columns that do not name one (``read_profile(units=...)``); never guessed.
    gaps : {"refuse", "restart"}
        Missing elevations: the file is refused (default; it fails in the manifest) or its IRI is computed over the
        measured parts, the quarter car restarted after each gap (``iri_report(gaps=...)``, ``--gaps``); the gaps
        are then the file's warning.
    min_valid : float
        With ``gaps="restart"``: the smallest measured fraction of an interval for its IRI (``--min-valid``).

    Calling the task on a path returns a :class:`TaskOutput`.
    """

    mode: str = "fixed"
    interval: float | None = None
    window: float | None = None
    step: float | None = None
    start: float | None = None
    units: str = "si"
    tracks: tuple[str, ...] | None = None
    lead_in: float = 11.0
    moving_average: str = "auto"
    elevation_unit: str | None = None
    gaps: str = "refuse"
    min_valid: float = 0.8

    name: ClassVar[str] = "iri"

    def __post_init__(self):
        _check_units(self.units)
        interval = _UNITS[self.units][4] if self.interval is None else self.interval
        object.__setattr__(self, "interval", _finite_positive("interval", interval))
        object.__setattr__(self, "lead_in", _finite_positive("lead_in", self.lead_in))
        for key in ("start", "window", "step"):
            object.__setattr__(self, key, _optional_float(key, getattr(self, key)))
        object.__setattr__(self, "tracks", _tracks_tuple(self.tracks))
        if self.moving_average not in ("auto", "on", "off"):
            raise InputError(f"moving_average must be 'auto', 'on' or 'off'; got {self.moving_average!r}.")
        if self.gaps not in ("refuse", "restart"):
            raise InputError(f"gaps must be 'refuse' or 'restart'; got {self.gaps!r}.")
        min_valid = _finite_positive("min_valid", self.min_valid)
        if min_valid > 1.0:
            raise InputError(f"min_valid must be a fraction in (0, 1]; got {self.min_valid!r}.")
        object.__setattr__(self, "min_valid", min_valid)

    def options(self) -> dict:
        """The options as a JSON-ready dict (stored in the manifest; their hash keys ``--resume``). ``gaps`` and
        ``min_valid`` only with ``gaps="restart"``: a results folder made before they existed resumes as it was."""
        d = dataclasses.asdict(self)
        d["tracks"] = None if self.tracks is None else list(self.tracks)
        if self.gaps == "refuse":
            del d["gaps"], d["min_valid"]
        return d

    def __call__(self, path) -> TaskOutput:
        from ..io import read_profile

        tracks = self.tracks if self.tracks is not None else _default_tracks(path)
        task = self if tracks == self.tracks else dataclasses.replace(self, tracks=tracks)
        profile = read_profile(path, units=self.elevation_unit, tracks=tracks)
        if tracks is not None and profile.tracks != tuple(tracks):  # found in another letter case (Left for left):
            profile = profile.renamed(dict(zip(profile.tracks, tracks)))  # one column per track across the network
        return task.analyse(profile)

    def analyse(self, profile) -> TaskOutput:
        """The task on a :class:`~longprofile.road.Profile` already in memory. The warning holds every warning
        ``road iri`` prints for the same file (:func:`~longprofile.road.iri_notes`: a dropout written as a held
        value, an implausible section IRI, coarse stations), then the batch's own (no complete segment, an
        implausible segment IRI) and the gaps of ``gaps="restart"``, joined by "; "."""
        from ..road import iri_notes

        report, meta = _iri_table(profile, self)
        table = report.to_frame()
        length = float(profile.distance[-1] - profile.distance[0])
        notes = (*iri_notes(report, profile), _warning(table, self, length), meta.get("gap_note", ""))
        warning = "; ".join(dict.fromkeys(w for w in notes if w))
        return TaskOutput(segments=table, metadata=meta, warning=warning)

    def warm(self) -> None:
        """Run the task once on a tiny synthetic profile (compiles or loads the numba kernels; checks options)."""
        from ..io import is_reconstruct_output, is_simulated_recording, read_profile  # noqa: F401  (imports of __call__)

        task = self if self.start is None else dataclasses.replace(self, start=None)
        span = (self.window or self.interval) * _UNITS[self.units][1]
        task.analyse(_tiny_profile(self.tracks or ("left", "right"), 2.0 * (self.lead_in + span) + 1.0))


# ---- APL reconstruction ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ReconstructTask:
    """``longprofile road reconstruct`` as a batch task, plus the IRI of the reconstruction per segment.

    Reads an APL recording (CSV/Parquet with ``distance_m`` and the signal ``column``), calls
    :func:`longprofile.road.reconstruct_profile` with the defaults of ``longprofile road reconstruct`` (Table 1
    instrument for ``speed``/``dx``; q and r by maximum likelihood unless given; ``stationary`` chosen by the
    library), and runs the IRI report (as :class:`IRITask`) on the reconstructed ``elevation`` track.

    Parameters
    ----------
    speed : float or None
        Towing speed, m/s; None (default): each file's speed column, else 20 m/s, as ``road reconstruct`` without
        ``--speed`` (:func:`longprofile.road.apl.towing_speed`: a given speed off a file's speed column by more
        than the tolerance fails that file; samples towed off the model's speed get NaN std and a warning).
    dx : float
        Spacing, m (must match the files' ``distance_m``).
    method : str
        ``"smoother"`` (default), ``"fixed-lag"``, ``"double"`` or ``"filter"``.
    column : str
        Signal column (metres, or named with its unit, e.g. ``apl_mm``).
    q, r, input_model, correlation_length, highpass_wavelength, lag
        As ``reconstruct_profile`` (``lag`` is its ``lag_m``).
    interval, start, units, lead_in
        The IRI report (fixed segments) of the reconstruction, as :class:`IRITask`.
    """

    speed: float | None = None
    dx: float = 0.05
    method: str = "smoother"
    column: str = "apl_m"
    q: float | None = None
    r: float | None = None
    input_model: str | None = None
    correlation_length: float | None = None
    highpass_wavelength: float | None = 100.0
    lag: float | None = None
    interval: float | None = None
    start: float | None = None
    units: str = "si"
    lead_in: float = 11.0

    name: ClassVar[str] = "reconstruct"

    def __post_init__(self):
        from ..road.apl import RECONSTRUCTION_METHODS

        _check_units(self.units)
        if self.interval is None:
            object.__setattr__(self, "interval", _UNITS[self.units][4])
        for key in ("dx", "interval", "lead_in") + (() if self.speed is None else ("speed",)):
            object.__setattr__(self, key, _finite_positive(key, getattr(self, key)))
        for key in ("q", "r", "correlation_length", "highpass_wavelength", "lag", "start"):
            object.__setattr__(self, key, _optional_float(key, getattr(self, key)))
        if self.method not in RECONSTRUCTION_METHODS:
            raise InputError(f"method must be one of {', '.join(RECONSTRUCTION_METHODS)}; got {self.method!r}.")

    def options(self) -> dict:
        return dataclasses.asdict(self)

    @property
    def iri_task(self) -> IRITask:
        return IRITask(interval=self.interval, start=self.start, units=self.units, tracks=("elevation",),
                       lead_in=self.lead_in)

    def __call__(self, path) -> TaskOutput:
        from ..io import read_apl_record
        from ..road.apl import reconstruct_towed

        record = read_apl_record(path, column=self.column, dx=self.dx)
        recording = record.recording
        towed = reconstruct_towed(recording.signal, record.speed, dx=self.dx, speed=self.speed, source=str(path),
                                  time_samples=record.time_samples, **self._reconstruction_options())
        notes = [*record.notes, *towed.notes]
        if recording.absent:
            first, last, _ = recording.absent[0]
            notes.append(f"{sum(k for *_, k in recording.absent)} station(s) absent from the record's grid (the "
                         f"first {first:.3f} .. {last:.3f} m) read as missing samples, bridged")
        check = None if towed.varying else towed.speed_check
        out = self._output(recording.signal, towed.reconstruction, towed.towing.speed,
                           None if check is None else check.warning)
        if not notes:
            return out
        note = "; ".join(notes)
        return dataclasses.replace(out, warning=f"{out.warning}; {note}" if out.warning else note)

    def analyse(self, signal, *, speed: float | None = None, speed_check=None) -> TaskOutput:
        """The task on an APL signal :class:`~longprofile.road.Profile` already in memory, towed at ``speed`` (m/s;
        default the task's, else 20 m/s); ``speed_check`` (:func:`longprofile.road.apl.check_speed_samples`) NaNs
        the std of the samples towed off it."""
        from ..road.apl import DEFAULT_TOWING_SPEED, apl_model, reconstruct_profile, without_off_speed_std

        speed = speed if speed is not None else (self.speed or DEFAULT_TOWING_SPEED)
        rec = reconstruct_profile(signal, apl_model(speed, self.dx), **self._reconstruction_options())
        if speed_check is not None:
            rec = without_off_speed_std(rec, speed_check)
        return self._output(signal, rec, speed, None if speed_check is None else speed_check.warning)

    def _reconstruction_options(self) -> dict:
        """The task's options as :func:`longprofile.road.apl.reconstruct_profile` takes them."""
        return dict(method=self.method, q=self.q, r=self.r, input_model=self.input_model,
                    correlation_length=self.correlation_length, highpass_wavelength=self.highpass_wavelength,
                    lag_m=self.lag)

    def _output(self, signal, rec, speed: float, off_speed: str | None) -> TaskOutput:
        """The IRI report of reconstruction ``rec`` of ``signal`` and its profile table (``off_speed``: the warning
        of the stations towed off the model's speed, or None)."""
        import numpy as np

        from ..road import Profile

        profile = Profile(rec.profile.distance, rec.profile.elevation, tracks=("elevation",), name=signal.name)
        iri_out = self.iri_task.analyse(profile)
        meta = dict(iri_out.metadata, method=rec.method, q_m2=rec.q, r_m2=rec.r, input_model=rec.input_model,
                    lag_m=rec.lag_m, speed_m_per_s=speed, n_samples=signal.n_samples,
                    n_missing=int(np.isnan(signal.elevation[:, 0]).sum()))
        if rec.speed_range is not None:
            meta["speed_min_median_max_m_per_s"] = list(rec.speed_range)
        warning = "; ".join(w for w in (iri_out.warning, off_speed) if w) or None
        return TaskOutput(segments=iri_out.segments, profile=rec.to_frame(), metadata=meta, warning=warning)

    def warm(self) -> None:
        """Reconstruct a short simulated recording once (compiles or loads the kernels; checks the options)."""
        from ..io import read_apl_recording  # noqa: F401  (imports of __call__, paid here)
        from ..road import Profile
        from ..road.apl import DEFAULT_TOWING_SPEED, apl_model, simulate_apl_recording

        span = self.interval * _UNITS[self.units][1]
        length = max(1.5 * (self.highpass_wavelength or 0.0), 250.0 * self.dx, 2.0 * (self.lead_in + span) + 1.0)
        rec = simulate_apl_recording("iso8608", apl_model(self.speed or DEFAULT_TOWING_SPEED, self.dx), length=length, road_class="B",
                                     noise_fraction=0.02, rng=0)
        task = self if self.start is None else dataclasses.replace(self, start=None)
        task.analyse(Profile(rec.distance, rec.signal, name="warm-up"))


#: Batch tasks by name (the ``longprofile batch`` sub-commands).
TASKS = {IRITask.name: IRITask, ReconstructTask.name: ReconstructTask}
