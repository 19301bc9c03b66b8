"""``road reconstruct`` as one library call: the trailer model for a record, its spacing checked, the reconstruction."""

from __future__ import annotations

import dataclasses

from ...core import Profile
from ...errors import InputError, ModelError, UnitsError
from ._deconvolution import Reconstruction, reconstruct_profile
from ._files import load_model
from ._model import TABLE1_CONFIGURATIONS, _table_key, apl_model
from ._resample import resample_model

__all__ = ["reconstruct_recording"]


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
