"""Zero-phase "double filtering" of the APL signal (paper 000, §3, eqs. 4-5)."""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array
from ...core import Profile
from ...errors import InputError, ShapeError
from ._model import APLModel, _check_profile_spacing, apl_filter

__all__ = ["double_filter"]


def double_filter(signal, model: APLModel, *, initial: str = "steady"):
    r"""The paper's double filtering: reverse the APL signal, filter it by H, reverse again.

    Parameters
    ----------
    signal : Profile or (N,) / (N, K) array_like
        The recorded APL signal (pseudo-profile), m, sampled at the model's step.
    model : APLModel
        Instrument model H (e.g. :func:`apl_model`).
    initial : {"steady", "rest"}
        Start-up of the backward pass (which starts at the end of the record): ``"steady"``
        (default) assumes the signal was constant and equal to its last sample beyond the end;
        ``"rest"`` starts from zero. See :func:`apl_filter`.

    Returns
    -------
    Profile or ndarray
        The new pseudo-profile g (same type and shape as ``signal``).

    Notes
    -----
    Eq. (4)-(5) of paper 000: G(z) = H(z^{-1}) Y(z) = H(z^{-1}) H(z) U(z), so for a sinusoid
    G(f) = |H(f)|^2 U(f): the phase distortion of the trailer is removed (zero phase; an image of
    a symmetric defect is symmetric and centred on the defect) at the price of the attenuation
    applied twice outside the pass band. Filtering is by second-order sections.
    """
    if isinstance(signal, Profile):
        _check_profile_spacing(signal, model)
        z = signal.elevation
        if np.isnan(z).any():
            raise InputError(f"the APL signal {signal.name!r} has {int(np.isnan(z).sum())} missing sample(s); "
                             "double filtering needs a continuous record. Cut the record at the gaps.")
        g = double_filter(z, model, initial=initial)
        return Profile(signal.distance, g, tracks=signal.tracks, name=f"double-filtered {signal.name}".strip())
    y = as_float_array("signal", signal, ndim=(1, 2), allow_nan=False)
    if y.shape[0] < 2:
        raise ShapeError(f"signal needs at least 2 samples; got {y.shape[0]}.")
    return apl_filter(model, y[::-1], initial=initial)[::-1].copy()
