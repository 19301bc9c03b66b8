"""``road reconstruct`` as one library call: the trailer model for a record, its spacing checked, the reconstruction."""

from __future__ import annotations

from ...core import Profile
from ...errors import InputError, UnitsError
from ._deconvolution import Reconstruction, reconstruct_profile
from ._files import load_model
from ._model import TABLE1_CONFIGURATIONS, _table_key, apl_model

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
    instrument = apl_model(speed, dx) if model_file is None else load_model(model_file, speed=speed, dx=dx)
    return reconstruct_profile(signal, instrument, **options)


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
