"""Trailer model files: the JSON written by ``road identify`` and read by ``road reconstruct --model``."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from ..._atomic import atomic_write_bytes
from ...errors import InputError, InputFormatError, UnitsError
from ._model import APLModel, apl_model_from_dict

__all__ = ["load_model", "save_model"]


def load_model(path, *, speed: float | None = None, dx: float | None = None) -> APLModel:
    """Read a trailer model saved by :func:`save_model` (``road identify``), checked against a record's speed and dx.

    Parameters
    ----------
    path : path-like
        JSON file: ``{"model": APLModel.to_dict(), "fit": ...}`` or the bare model description.
    speed, dx : float, optional
        Towing speed (m/s) and spacing (m) of the record the model is for. When given, they must agree with
        the model's own speed, dx and dt = dx / speed (relative tolerance 1e-9); a model that does not state
        its speed or dx takes them from here, so that :func:`reconstruct_profile` checks the record's spacing.

    Returns
    -------
    APLModel

    Raises
    ------
    InputError
        No such file.
    InputFormatError
        Not valid JSON, or not an APL model description.
    UnitsError
        The model was identified for another spacing, speed or sampling step.
    """
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: no such file.") from None
    except json.JSONDecodeError as exc:
        raise InputFormatError(f"{path}: not valid JSON ({exc}).") from None
    model = apl_model_from_dict(data.get("model", data) if isinstance(data, dict) else data)
    if dx is not None and model.dx is not None and abs(model.dx - dx) > 1e-9 * dx:
        raise UnitsError(f"{path} was identified for dx = {model.dx:g} m; this record uses --dx {dx:g} m. "
                         "Identify the trailer at this spacing, or re-discretise the model "
                         "(longprofile.road.apl.resample_model; road reconstruct --model does it).")
    if speed is not None and model.speed is not None and abs(model.speed - speed) > 1e-9 * speed:
        raise UnitsError(f"{path} was identified for {model.speed:g} m/s; this record uses --speed {speed:g}.")
    if speed is not None and dx is not None:
        if abs(model.dt - dx / speed) > 1e-9 * model.dt:
            raise UnitsError(f"{path} has dt = {model.dt:g} s but --dx / --speed = {dx / speed:g} s.")
        if model.dx is None or model.speed is None:
            model = dataclasses.replace(model, speed=model.speed if model.speed is not None else speed,
                                        dx=model.dx if model.dx is not None else dx)
    return model


def save_model(path, model: APLModel, *, fit=None) -> Path:
    """Write ``{"model": model.to_dict(), "fit": fit.to_dict()}`` as indented JSON (read back by :func:`load_model`).

    ``fit`` is the identification result (an object with ``to_dict()``, e.g. from
    :func:`longprofile.identify.fit_output_error`), or None to write the model alone (``"fit": null``).
    """
    path = Path(path)
    text = json.dumps(dict(model=model.to_dict(), fit=None if fit is None else fit.to_dict()), indent=2)
    atomic_write_bytes(path, text.encode("utf-8"))  # an older model file survives a failure
    return path
