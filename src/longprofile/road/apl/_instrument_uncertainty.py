"""The trailer model's own uncertainty in the printed std of a reconstruction (issue 13; paper 000, eq. 1 and §5).

The Kalman reconstruction (paper 000, §5) treats the instrument H(z) of eq. (1) as exact, so its posterior std says
nothing about a trailer whose pendulum or damper frequency, or whose gain, differs from the model's. When the user
declares the relative 1-sigma uncertainty of those parameters (:class:`InstrumentUncertainty`), the reconstruction
is rerun once per parameter with that parameter perturbed by its sigma (the same library functions, the same q, r
and latency), and the squared difference of the detrended estimates is added to the variance:

    std^2 = std_posterior^2 + sum_i delta_i^2,    delta_i = u_hat(theta + sigma_i e_i) - u_hat(theta).

Assumptions (named): (1) linearisation -- the estimate is linear in each parameter over +-1 sigma (one-sided finite
difference); (2) the parameters' errors are independent of each other and of the road and the noise (no cross
terms). Under (1) the error that the parameter errors eps_i (in sigmas) cause at sample k is sum_i eps_i delta_i(k),
whose variance over the parameters is sum_i delta_i(k)^2 at that very sample: the default takes it per sample
(``window_m`` = 0). ``window_m`` > 0 averages delta_i^2 over a centred window instead (a smoother band, which
spreads the variance from where the error is to the sign changes of delta_i between): measured on the trailer
mismatch family it lowers the worst draw's coverage (docs/road-apl.md, "Calibration").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import InputError, ModelError
from ._model import APLModel

__all__ = ["InstrumentUncertainty", "INSTRUMENT_ERROR_WINDOW_M", "perturbed_instrument", "instrument_parameters",
           "instrument_error_variance"]

#: Default window (m) over which delta_i^2 is averaged (0: per sample, the variance of the linearised error there).
INSTRUMENT_ERROR_WINDOW_M = 0.0

#: The spelling of :meth:`InstrumentUncertainty.parse` (``road reconstruct --instrument-uncertainty``).
_KEYS = {"freq": "frequency", "frequency": "frequency", "gain": "gain", "window": "window_m", "window_m": "window_m"}


@dataclass(frozen=True)
class InstrumentUncertainty:
    """Declared 1-sigma uncertainty of the trailer model, for the printed std of :func:`reconstruct_profile`.

    Attributes
    ----------
    frequency : float
        Relative 1-sigma of the natural frequency of *each* complex pole pair of the instrument (for eq. (1) of
        paper 000: the pendulum f1 and the damper f2, independently), e.g. 0.115 for a tolerance of +-20 %
        uniform (20 % / sqrt(3)). 0 <= frequency < 1.
    gain : float
        Relative 1-sigma of the instrument gain k. 0 <= gain < 1.
    window_m : float
        Length (m) of the centred moving average of delta_i^2 (0: the per-sample square, no averaging). Default
        :data:`INSTRUMENT_ERROR_WINDOW_M`.

    Raises
    ------
    InputError
        A value that is not finite, negative, or (for the relative sigmas) not below 1.

    Examples
    --------
    >>> InstrumentUncertainty.parse("freq=0.115,gain=0.029")
    InstrumentUncertainty(frequency=0.115, gain=0.029, window_m=0.0)
    """

    frequency: float = 0.0
    gain: float = 0.0
    window_m: float = INSTRUMENT_ERROR_WINDOW_M

    def __post_init__(self):
        for name in ("frequency", "gain", "window_m"):
            value = getattr(self, name)
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise InputError(f"instrument uncertainty {name} must be a number; got {value!r}.") from None
            upper = math.inf if name == "window_m" else 1.0
            if not (math.isfinite(v) and 0.0 <= v < upper):
                bound = "a finite length >= 0 m" if name == "window_m" else "a relative 1-sigma in [0, 1)"
                raise InputError(f"instrument uncertainty {name} must be {bound}; got {value!r}.")
            object.__setattr__(self, name, v)

    @property
    def is_zero(self) -> bool:
        """True when no parameter is uncertain (the printed std is then the posterior std, unchanged)."""
        return self.frequency == 0.0 and self.gain == 0.0

    @classmethod
    def parse(cls, text: str) -> InstrumentUncertainty:
        """From ``"freq=0.115,gain=0.029"`` (keys ``freq``/``frequency``, ``gain``, ``window``/``window_m``; each
        at most once; missing keys take their defaults)."""
        values = {}
        for item in str(text).split(","):
            key, sep, value = item.partition("=")
            key = key.strip().lower()
            if not sep or key not in _KEYS or _KEYS[key] in values:
                raise InputError(f"instrument uncertainty must read like 'freq=0.115,gain=0.029' (keys freq, gain, "
                                 f"window, each once); got {text!r}.")
            try:
                values[_KEYS[key]] = float(value)
            except ValueError:
                raise InputError(f"instrument uncertainty {key} must be a number; got {value.strip()!r} in "
                                 f"{text!r}.") from None
        return cls(**values)


def _pole_pairs(instrument: APLModel) -> list[int]:
    """Indices of the poles with a positive angle (one per complex-conjugate pair)."""
    p = instrument.poles
    return [i for i in range(p.size) if p[i].imag > 1e-12 * max(abs(p[i]), 1e-300)]


def _peak_frequency(instrument: APLModel) -> float:
    """Frequency (Hz) of the largest |H| on a log grid up to Nyquist (the pass band's reference)."""
    nyquist = 0.5 / instrument.dt
    f = np.geomspace(nyquist * 1e-6, nyquist * 0.999, 2001)
    return float(f[np.argmax(np.abs(instrument.response_at(f)))])


def instrument_parameters(instrument: APLModel) -> list[str]:
    """Names of the parameters :class:`InstrumentUncertainty` perturbs, in order: one ``"frequency of the pole
    pair at f Hz"`` per complex pole pair, then ``"gain"``."""
    f = [np.angle(instrument.poles[i]) / (2 * np.pi * instrument.dt) for i in _pole_pairs(instrument)]
    return [f"frequency of the pole pair at {fi:.4g} Hz" for fi in f] + ["gain"]


def perturbed_instrument(instrument: APLModel, parameter: int, relative: float) -> APLModel:
    """The instrument with one parameter (an index into :func:`instrument_parameters`) scaled by 1 + ``relative``.

    A pole pair p = |p| e^{j 2 pi f dt} moves to the frequency f (1 + relative) at the same modulus, and the gain
    is rescaled so that the pair's factor keeps its value where eq. (1) of paper 000 normalises it: at z = -1
    (high frequency) for a pair below the pass-band peak (the pendulum's high-pass pair), at z = 1 for a pair above
    it (the damper's low-pass pair). For the model of :func:`apl_model` this is exactly ``apl_model`` with the
    frequency in :class:`TrailerPoles` scaled (test). The last parameter is the gain k -> k (1 + relative).

    Raises
    ------
    InputError
        ``parameter`` out of range.
    ModelError
        A perturbed frequency at or beyond Nyquist.
    """
    pairs = _pole_pairs(instrument)
    if not 0 <= parameter <= len(pairs):
        raise InputError(f"parameter must index {instrument_parameters(instrument)}; got {parameter}.")
    poles = instrument.poles.copy()
    gain = instrument.gain
    if parameter == len(pairs):
        gain = gain * (1.0 + relative)
    else:
        i = pairs[parameter]
        p = poles[i]
        angle = np.angle(p) * (1.0 + relative)
        if not 0.0 < angle < np.pi:
            raise ModelError(f"the pole pair at {np.angle(p) / (2 * np.pi * instrument.dt):.4g} Hz scaled by "
                             f"{1 + relative:g} passes Nyquist; lower the frequency uncertainty.")
        q = abs(p) * np.exp(1j * angle)
        j = int(np.argmin(np.abs(poles - np.conj(p))))
        poles[i], poles[j] = q, np.conj(q)
        z = -1.0 if np.angle(p) / (2 * np.pi * instrument.dt) < _peak_frequency(instrument) else 1.0
        gain = gain * float(np.real((z - q) * (z - np.conj(q)) / ((z - p) * (z - np.conj(p)))))
    return APLModel(zeros=instrument.zeros, poles=poles, gain=gain, delay=instrument.delay, dt=instrument.dt,
                    speed=instrument.speed, dx=instrument.dx, name=f"{instrument.name} (perturbed)")


def _moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean over n samples (n <= 1: x itself), the window shortened at the ends."""
    if n <= 1:
        return x
    c = np.concatenate([[0.0], np.cumsum(x)])
    k = np.arange(x.size)
    lo = np.maximum(k - n // 2, 0)
    hi = np.minimum(k - n // 2 + n, x.size)
    return (c[hi] - c[lo]) / (hi - lo)


def instrument_error_variance(instrument: APLModel, uncertainty: InstrumentUncertainty, elevation: np.ndarray,
                              rerun, dx: float) -> np.ndarray | None:
    """Per-sample variance (m^2) of the reconstruction error that the declared instrument uncertainty causes.

    Parameters
    ----------
    instrument : APLModel
        The model the reconstruction used.
    uncertainty : InstrumentUncertainty
    elevation : (T,) ndarray
        The detrended estimate with ``instrument``.
    rerun : callable
        ``rerun(perturbed_instrument) -> (T,) detrended estimate``: the same reconstruction (same q, r, latency,
        detrending) with another instrument.
    dx : float
        Spacing, m (for the window).

    Returns
    -------
    (T,) ndarray or None
        sum_i <delta_i^2>_window over the parameters with a non-zero sigma (None when there is none). Assumes the
        linearisation and the independence named in the module docstring.
    """
    if uncertainty.is_zero:
        return None
    n_pairs = len(_pole_pairs(instrument))
    sigmas = [uncertainty.frequency] * n_pairs + [uncertainty.gain]
    window = int(round(uncertainty.window_m / dx))
    var = np.zeros(elevation.shape)
    for parameter, sigma in enumerate(sigmas):
        if sigma > 0.0:
            delta = np.asarray(rerun(perturbed_instrument(instrument, parameter, sigma))) - elevation
            var += _moving_mean(delta ** 2, window)
    return var
