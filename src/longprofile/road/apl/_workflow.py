"""``road reconstruct`` as one library call: the trailer model for a record, its spacing checked, the reconstruction."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ...core import Profile
from ...errors import InputError, ModelError, UnitsError
from ._deconvolution import Reconstruction, reconstruct_profile
from ._files import load_model
from ._model import TABLE1_CONFIGURATIONS, _table_key, apl_model
from ._resample import resample_model

__all__ = ["reconstruct_recording", "reconstruct_towed", "TowedReconstruction"]


def reconstruct_recording(signal: Profile, *, speed: float, dx: float, model_file=None, source=None,
                          **options) -> Reconstruction:
    """Reconstruct a trailer recording towed at ``speed`` and sampled every ``dx`` (what ``road reconstruct`` runs).

    Parameters
    ----------
    signal : Profile
        The APL signal (one track, m), e.g. from :func:`longprofile.io.read_apl_signal`.
    speed, dx : float
        Towing speed (m/s) and spacing (m, ``--dx``) of the record; the stations must be ``dx`` apart.
    model_file : path-like, optional
        A model saved by ``road identify`` (:func:`load_model`, checked against speed and dx) instead of the
        Table 1 model :func:`apl_model` (speed, dx).
    source : str, optional
        Name of the record in error messages (default: ``signal.name``).
    **options
        Passed to :func:`reconstruct_profile` (``method``, ``q``, ``r``, ``input_model``, ``correlation_length``,
        ``highpass_wavelength``, ``lag_m``, ...).

    Returns
    -------
    Reconstruction

    Raises
    ------
    InputError
        Stations not evenly spaced; a (speed, dx) outside Table 1 without ``model_file`` (the message names what
        the command line offers: another --speed/--dx, or ``road identify`` and --model); every error of
        :func:`load_model` and :func:`reconstruct_profile`.
    UnitsError
        Stations not ``dx`` apart; a model file for another speed or spacing.
    """
    label = signal.name if source is None else source
    spacing = signal.spacing
    if spacing is None:
        raise InputError(f"{label}: distance_m is not evenly spaced; the APL samples every dx. Resample first.")
    if abs(spacing - dx) > 1e-6 * dx:
        raise UnitsError(f"{label}: the samples are {spacing:g} m apart but --dx is {dx:g} m.")
    if model_file is None and _table_key(speed, dx) is None:
        _refuse_uncalibrated(label, speed, dx)
    if model_file is None:
        return reconstruct_profile(signal, apl_model(speed, dx), **options)
    instrument, note = _model_for_record(model_file, speed, dx)
    rec = reconstruct_profile(signal, instrument, **options)
    return rec if note is None else dataclasses.replace(rec, warnings=(note, *rec.warnings))


def _model_for_record(model_file, speed: float, dx: float):
    """The model of ``model_file`` for a record at (speed, dx): as saved when identified at this speed and dx
    (:func:`load_model` checks them), else re-discretised at dt = dx / speed (:func:`resample_model`), with the
    note saying so; (model, note or None)."""
    saved = load_model(model_file)
    same = [v is None or abs(v - w) <= 1e-9 * w for v, w in ((saved.speed, speed), (saved.dx, dx))]
    if all(same) and abs(saved.dt - dx / speed) <= 1e-9 * saved.dt:
        return load_model(model_file, speed=speed, dx=dx), None
    try:
        model = resample_model(saved, dx / speed, speed=speed, dx=dx)
    except ModelError as exc:
        raise UnitsError(f"{model_file} was identified at dt = {saved.dt:.6g} s{_at(saved)}; this record is sampled "
                         f"at --dx {dx:g} m / --speed {speed:g} m/s = {dx / speed:.6g} s and the model cannot be "
                         f"re-discretised: {exc}") from None
    return model, (f"{model_file} was identified at dt = {saved.dt:.6g} s{_at(saved)}; re-discretised for this "
                   f"record's dt = {dx / speed:.6g} s (--dx {dx:g} m / --speed {speed:g} m/s) through its "
                   "continuous-time form (zero-order hold, poles z = exp(s dt)). Assumption: the trailer's dynamics "
                   "in time do not depend on the towing speed (docs/road-apl.md).")


def _at(model) -> str:
    """`` (dx 0.15 m at 20 m/s)`` for a model that states them, else ``""``."""
    return "" if model.dx is None or model.speed is None else f" (dx {model.dx:g} m at {model.speed:g} m/s)"


def _refuse_uncalibrated(label, speed: float, dx: float) -> None:
    """Refuse a (speed, dx) without Table 1 poles, naming what a command-line user can do (the library's
    ``apl_model`` names ``poles=TrailerPoles(...)``, which the command line has no option for)."""
    known = sorted(TABLE1_CONFIGURATIONS)
    listed = "; ".join(f"{v:g} m/s at dx {', '.join(f'{h:g}' for w, h in known if w == v)} m"
                       for v in sorted({w for w, _ in known}, reverse=True))
    raise InputError(f"{label}: no Table 1 calibration for --speed {speed:g} m/s and --dx {dx:g} m: paper 000 "
                     f"gives the trailer's poles only for {listed}. If the record was made at one of these, "
                     "give its --speed and --dx; otherwise identify your trailer at this configuration from bench "
                     f"records (longprofile road identify --input IN.csv --output OUT.csv --speed {speed:g} "
                     f"--dx {dx:g} -o model.json) and pass --model model.json.")


@dataclass(frozen=True)
class TowedReconstruction:
    """A record reconstructed at the speed it was towed at (:func:`reconstruct_towed`).

    Attributes
    ----------
    reconstruction : Reconstruction
    towing : TowingSpeed
        The speed of the model (the one calibrated nearest the record's for a varying speed) and its note.
    varying : bool
        True: the instrument was re-discretised at each station's speed (:func:`reconstruct_varying_speed`).
    notes : tuple of str
        What the caller should print (where the speed comes from; how a varying speed was handled).
    speed_check : SpeedCheck or None
        The stations against the model's speed (:func:`check_speed_samples`; None without a speed column).
    in_time : bool
        True: reconstructed at the file's time step (:func:`reconstruct_time_sampled`): no station is missing.
    """

    reconstruction: Reconstruction
    towing: object
    varying: bool
    notes: tuple = ()
    speed_check: object = None
    in_time: bool = False


#: Options of :func:`reconstruct_profile` that a varying-speed reconstruction does not take (not None = refused).
_CONSTANT_SPEED_ONLY = {"lag_m": "--lag", "instrument_uncertainty": "--instrument-uncertainty"}


def reconstruct_towed(signal: Profile, speed_column, *, dx: float, speed: float | None = None, model_file=None,
                      source=None, time_samples=None, **options) -> TowedReconstruction:
    """``road reconstruct`` and ``batch reconstruct``: the towing speed from ``--speed`` and the record's speed
    column, then the constant-speed or the varying-speed reconstruction.

    Parameters
    ----------
    signal : Profile
        The APL signal (one track, m) at stations ``dx`` apart.
    speed_column : SpeedColumn or None
        The record's speed at each station (``longprofile.io.read_apl_record``), or None.
    dx : float
        Spacing, m.
    speed : float, optional
        ``--speed``, m/s.
    model_file : path-like, optional
        A ``road identify`` model instead of Table 1.
    source : str, optional
        The record, in messages.
    time_samples : (time, distance, signal), optional
        A time-sampled record's own samples (``longprofile.io.read_apl_record``'s ``time_samples``): a varying speed
        is then reconstructed at the file's time step (:func:`reconstruct_time_sampled`) when they are complete.
    **options
        :func:`reconstruct_profile`'s options.

    Returns
    -------
    TowedReconstruction
        With a speed column whose moving samples stay within the tolerance of one calibrated speed
        (:func:`towing_speed`): :func:`reconstruct_recording` at that speed, exactly as before (stations whose speed
        cell is empty get NaN std, :func:`without_off_speed_std`). Otherwise (some station towed off it by more than
        the tolerance): :func:`reconstruct_varying_speed` with the trailer calibrated nearest the record's median
        speed (or ``model_file``), re-discretised at every station's speed (empty speed cells: linear in distance).

    Raises
    ------
    InputError
        :func:`towing_speed`'s refusals (a ``--speed`` off the file's; a constant speed off every calibration); a
        varying speed with ``--method double`` or ``fixed-lag``, ``--lag``, ``--instrument-uncertainty`` or
        ``--short-waves prior`` (what the varying-speed reconstruction does not do); every error of the
        reconstructions.
    """
    from ._speed import towing_speed, without_off_speed_std
    from ._varying_speed import reconstruct_time_sampled, reconstruct_varying_speed

    label = signal.name if source is None else source
    model_speed = None if model_file is None or speed is not None or speed_column is None else \
        load_model(model_file).speed
    towing, check = towing_speed(signal.distance, speed_column, speed, dx=dx, model_speed=model_speed, label=label)
    notes = (towing.note,) if towing.note else ()
    v = None if speed_column is None else np.asarray(speed_column.values, float)
    if check is None or not np.any(~check.ok & np.isfinite(v)):
        rec = reconstruct_recording(signal, speed=towing.speed, dx=dx, model_file=model_file, source=source, **options)
        return TowedReconstruction(rec if check is None else without_off_speed_std(rec, check), towing, False, notes,
                                   check)
    _check_varying_options(label, options, check)
    if model_file is None:
        instrument, model_note = apl_model(towing.speed, dx), None
    else:
        instrument, model_note = _model_for_record(model_file, towing.speed, dx)
    known = np.isfinite(v)
    if not known.all():
        notes += (f"{int((~known).sum())} station(s) without a speed: their speed is taken linear in distance "
                  "between their neighbours'",)
        v = np.interp(signal.distance, signal.distance[known], v[known])
    options = {k: val for k, val in options.items() if k not in _CONSTANT_SPEED_ONLY and k != "short_waves"}
    in_time = time_samples is not None and bool(np.all(np.isfinite(time_samples[2])))
    if in_time:
        rec = reconstruct_time_sampled(time_samples, signal, v, instrument, **options)
    else:
        rec = reconstruct_varying_speed(signal, v, instrument, **options)
    if model_note is not None:
        rec = dataclasses.replace(rec, warnings=(model_note, *rec.warnings))
    notes += (f"the towing speed varies ({v.min():.3g}-{v.max():.3g} m/s; {100 * check.share:.1f} % of the stations "
              f"more than {100 * check.tolerance:g} % off {towing.speed:g} m/s): the trailer (calibrated at "
              f"{instrument.speed if instrument.speed is not None else towing.speed:g} m/s) is re-discretised "
              + ("at each of the file's time steps, the road a random walk in distance" if in_time else
                 "at each station's speed") + " (docs/road-apl.md, 'Varying towing speed')",)
    return TowedReconstruction(rec, towing, True, notes, check, in_time)


def _check_varying_options(label, options: dict, check) -> None:
    """Refuse what the varying-speed reconstruction does not do, naming the speed and the option."""
    from ._varying_speed import VARYING_SPEED_METHODS

    why = (f"{label}: the towing speed varies ({100 * check.share:.1f} % of the stations more than "
           f"{100 * check.tolerance:g} % off {check.model_speed:g} m/s), which is reconstructed by the "
           f"{' or the '.join(VARYING_SPEED_METHODS)} at each station's speed")
    method = options.get("method", "smoother")
    if method not in VARYING_SPEED_METHODS:
        raise InputError(f"{why}; --method {method} assumes a constant speed: leave out --method (smoother), or "
                         "reconstruct separately the parts of the record towed at a constant speed.")
    for key, flag in _CONSTANT_SPEED_ONLY.items():
        if options.get(key) is not None:
            raise InputError(f"{why}, without {flag} (not yet for a varying speed): leave it out, or reconstruct "
                             "separately the parts of the record towed at a constant speed.")
    if options.get("short_waves") == "prior":
        raise InputError(f"{why}, with the printed std under the road the record shows (--short-waves record): "
                         "leave out --short-waves prior.")
