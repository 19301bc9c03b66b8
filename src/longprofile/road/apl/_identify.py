"""Identification of the trailer from bench records (paper 000, §4): OE or ARMAX, as an :class:`APLModel`."""

from __future__ import annotations

import numpy as np

from ..._validation import require_positive
from ...errors import InputError
from ._model import APLModel, apl_model_from_polynomials

__all__ = ["IDENTIFICATION_STRUCTURES", "check_identification_structure", "identify_trailer"]

#: Model structures of :func:`identify_trailer`.
IDENTIFICATION_STRUCTURES = ("oe", "armax")


#: Largest |value| of a bench excitation or trailer response, m (a plausibility bound: a unit error beyond it).
MAX_BENCH_SIGNAL_M = 100.0


def check_identification_structure(structure: str, *, flag: str | None = None) -> str:
    """Return ``structure`` if :func:`identify_trailer` takes it, else raise one clear error.

    Parameters
    ----------
    structure : str
        A model structure (:data:`IDENTIFICATION_STRUCTURES`: ``"oe"``, ``"armax"``).
    flag : str, optional
        How the caller names the option in the message (e.g. a command-line flag); default ``structure``.

    Raises
    ------
    InputError
        An unknown structure.

    Examples
    --------
    >>> check_identification_structure("armax")
    'armax'
    """
    if structure not in IDENTIFICATION_STRUCTURES:
        raise InputError(f"{flag or 'structure'} must be one of {', '.join(map(repr, IDENTIFICATION_STRUCTURES))}; "
                         f"got {structure!r}.")
    return structure


def identify_trailer(u, y, *, speed: float, dx: float, orders: tuple[int, int, int] = (5, 5, 1),
                     structure: str = "oe", nc: int = 1, name: str | None = None):
    """Identify the trailer from sample-aligned bench input/output records (prediction-error ML, Gauss-Newton).

    Parameters
    ----------
    u, y : (T,) array_like
        Excitation (true profile) and response (trailer signal), sampled every dt = dx / speed.
    speed, dx : float
        Towing speed (m/s) and spacing (m) the model is for.
    orders : (na, nb, nk)
        Polynomial orders and pure delay (paper: 5 5 1).
    structure : {"oe", "armax"}
        Output error (:func:`longprofile.identify.fit_output_error`) or ARMAX
        (:func:`longprofile.identify.fit_armax`, with ``nc``).
    nc : int
        Order of C for ARMAX.
    name : str, optional
        Model name (default ``"OE(5,5,1)"`` etc.).

    Returns
    -------
    (APLModel, estimate)
        The instrument (for :func:`reconstruct_profile`, savable with :func:`save_model`) and the
        identification result (residual std, fit, iterations; ``to_dict()``).

    Raises
    ------
    InputError
        ``u`` and ``y`` differ in length, a sample is not finite or beyond ``MAX_BENCH_SIGNAL_M`` (a unit error),
        or an unknown structure.
    """
    from ...identify import fit_armax, fit_output_error

    check_identification_structure(structure)
    u = np.asarray(u)
    y = np.asarray(y)
    if u.size != y.size:
        raise InputError(f"the input has {u.size} samples but the output has {y.size}; they must be sample-aligned "
                         "(one output sample per input sample).")
    for what, v in (("input", u), ("output", y)):
        bad = ~np.isfinite(v) | (np.abs(v) > MAX_BENCH_SIGNAL_M)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"{what} sample {i} is {v[i]:.6g} m: identification needs finite samples within "
                             f"+-{MAX_BENCH_SIGNAL_M:g} m (a bench excitation or trailer response; no gaps); check "
                             "that value and the unit of the column.")
    na, nb, nk = orders
    dt = require_positive("dx (m)", dx) / require_positive("speed (m/s)", speed)
    if structure == "oe":
        est = fit_output_error(u, y, na=na, nb=nb, nk=nk, dt=dt)
    else:
        est = fit_armax(u, y, na=na, nb=nb, nc=nc, nk=nk, dt=dt)
    label = f"{structure.upper()}({na},{nb},{nk})" if name is None else name
    model: APLModel = apl_model_from_polynomials(est.numerator, est.denominator, dt=dt, speed=speed, dx=dx,
                                                 name=label)
    return model, est
