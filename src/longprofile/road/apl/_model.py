"""The APL trailer as a linear instrument (paper 000, Piasco & Legeay, §2 and §4).

The Analyseur de Profil en Long (LCPC) is a towed single-wheel trailer; its signal is
the road profile seen through a 5th-order linear system, eq. (1) of the paper: an RC
high-pass, the pendulum (2nd-order high-pass) and the damper (2nd-order low-pass).

Everything here works on zeros/poles/gain and second-order sections; b, a polynomials
are only exposed for printing and identification, never used for filtering.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validation import as_float_array, require_positive
from ...core import Profile
from ...errors import InputError, ModelError, ShapeError, UnitsError
from ...statespace import filter_design, sos_filter

__all__ = [
    "APLModel",
    "FrequencyResponse",
    "TrailerPoles",
    "TABLE1_CONFIGURATIONS",
    "RC_TIME_CONSTANT",
    "PAPER_IDENTIFIED_MODELS",
    "apl_model",
    "apl_model_from_polynomials",
    "apl_model_from_dict",
    "paper_identified_model",
    "frequency_response",
    "passband",
    "apl_response",
    "apl_filter",
]

#: tau of the RC high-pass, s (paper §2: "il est égal à 0.4 pi seconde").
RC_TIME_CONSTANT = 0.4 * np.pi


@dataclass(frozen=True)
class TrailerPoles:
    """Pendulum and damper poles of one trailer at one (speed, spacing), as in Table 1.

    Attributes
    ----------
    pendulum_modulus, pendulum_frequency : float
        |p1| (dimensionless, per sample) and f1 (Hz) of the pendulum high-pass pair.
    damper_modulus, damper_frequency : float
        |p2| and f2 (Hz) of the damper low-pass pair.
    """

    pendulum_modulus: float
    pendulum_frequency: float
    damper_modulus: float
    damper_frequency: float


#: Table 1 of paper 000 (trailer no. 1), keyed by (speed m/s, spacing m).
TABLE1_CONFIGURATIONS: dict[tuple[float, float], TrailerPoles] = {
    (20.0, 0.05): TrailerPoles(0.9976, 0.2185, 0.8002, 19.28),
    (20.0, 0.15): TrailerPoles(0.9926, 0.2252, 0.5203, 22.83),
    (20.0, 0.20): TrailerPoles(0.9901, 0.2250, 0.4922, 25.0),
    (6.0, 0.05): TrailerPoles(0.9918, 0.2243, 0.4990, 23.65),
}


@dataclass(frozen=True, eq=False)
class APLModel:
    r"""A discrete single-input single-output instrument model in zero-pole-gain form.

    .. math::

        H(z) = k\, z^{-d} \frac{\prod_i (1 - z_i z^{-1})}{\prod_j (1 - p_j z^{-1})}

    Attributes
    ----------
    zeros, poles : (nz,), (np,) complex ndarray
        Zeros z_i and poles p_j (nz <= np; missing factors are 1).
    gain : float
        k.
    delay : int
        d, pure delay in samples (nk of an identified B(z) polynomial).
    dt : float
        Sampling step, s.
    speed : float or None
        Towing speed V, m/s (None for a bench model without a road speed).
    dx : float or None
        Spatial sampling step, m (dt = dx / V).
    name : str
        Where the model comes from.
    """

    zeros: np.ndarray
    poles: np.ndarray
    gain: float
    delay: int
    dt: float
    speed: float | None = None
    dx: float | None = None
    name: str = ""

    def __post_init__(self):
        z = np.atleast_1d(np.asarray(self.zeros, dtype=complex))
        p = np.atleast_1d(np.asarray(self.poles, dtype=complex))
        if z.ndim != 1 or p.ndim != 1:
            raise ShapeError(f"zeros and poles must be 1-D; got shapes {z.shape} and {p.shape}.")
        if z.size > p.size:
            raise ModelError(f"an instrument model must be proper: {z.size} zeros > {p.size} poles.")
        if not (np.isfinite(z).all() and np.isfinite(p).all() and np.isfinite(self.gain)):
            raise ModelError("zeros, poles and gain must be finite.")
        if int(self.delay) != self.delay or self.delay < 0:
            raise ModelError(f"delay must be a non-negative integer number of samples; got {self.delay!r}.")
        require_positive("dt", self.dt)
        for arr in (z, p):
            arr.setflags(write=False)
        object.__setattr__(self, "zeros", z)
        object.__setattr__(self, "poles", p)
        object.__setattr__(self, "gain", float(np.real(self.gain)))
        object.__setattr__(self, "delay", int(self.delay))

    @property
    def order(self) -> int:
        """Number of poles."""
        return int(self.poles.size)

    @property
    def is_stable(self) -> bool:
        """True when every pole lies strictly inside the unit circle."""
        return bool(np.all(np.abs(self.poles) < 1.0))

    @property
    def sos(self) -> np.ndarray:
        """(n_sections, 6) second-order sections of H without the pure delay (scipy layout): ``scipy.signal.zpk2sos``
        with ``pairing="nearest"``, through the engine's design cache (no scipy.signal import once cached)."""
        return filter_design("zpk2sos", self.zeros, self.poles, self.gain, pairing="nearest")

    @property
    def numerator(self) -> np.ndarray:
        """B in ascending powers of z^-1, delay included as leading zeros (for display / identification)."""
        b = self.gain * np.real(np.poly(self.zeros)) if self.zeros.size else np.array([self.gain])
        return np.concatenate([np.zeros(self.delay), b])

    @property
    def denominator(self) -> np.ndarray:
        """A in ascending powers of z^-1, A[0] = 1."""
        return np.real(np.poly(self.poles))

    def response_at(self, frequency) -> np.ndarray:
        """Complex frequency response H(e^{j 2 pi f dt}) at ``frequency`` (Hz), any shape."""
        f = np.asarray(frequency, dtype=float)
        zinv = np.exp(-2j * np.pi * f * self.dt)
        num = np.ones_like(zinv) * self.gain
        for zi in self.zeros:
            num = num * (1.0 - zi * zinv)
        den = np.ones_like(zinv)
        for pj in self.poles:
            den = den * (1.0 - pj * zinv)
        return num / den * zinv ** self.delay

    def to_dict(self) -> dict:
        """JSON-serialisable description (B/A coefficients, delay included, plus dt, speed, dx, name)."""
        return dict(kind="apl-model", numerator=self.numerator.tolist(), denominator=self.denominator.tolist(),
                    dt=self.dt, speed=self.speed, dx=self.dx, name=self.name)

    @property
    def dc_gain(self) -> float:
        """H(1), the response to a constant input (0 for the APL: it cannot see a constant level)."""
        return float(np.real(self.response_at(0.0)))


@dataclass(frozen=True, eq=False)
class FrequencyResponse:
    """Frequency response of an :class:`APLModel`.

    Attributes
    ----------
    frequency : (F,) ndarray
        Hz.
    wavelength : (F,) ndarray or None
        Road wavelength V / f, m (None when the model has no speed).
    magnitude : (F,) ndarray
        |H|.
    phase : (F,) ndarray
        Unwrapped phase of H, rad.
    group_delay : (F,) ndarray
        -d(phase)/d(omega), s.
    """

    frequency: np.ndarray
    wavelength: np.ndarray | None
    magnitude: np.ndarray
    phase: np.ndarray
    group_delay: np.ndarray


def apl_model(speed: float = 20.0, dx: float = 0.05, *, poles: TrailerPoles | None = None,
              rc_time_constant: float = RC_TIME_CONSTANT, gain_normalisation: str = "bilinear") -> APLModel:
    r"""The APL instrument model of eq. (1) for a towing speed and a spacing.

    Parameters
    ----------
    speed : float
        Towing speed V, m/s (default 20).
    dx : float
        Spatial sampling step, m (default 0.05). The time step is dt = dx / V.
    poles : TrailerPoles, optional
        Pendulum and damper poles (|p|, f in Hz) for this trailer at this (V, dx). Default:
        the Table 1 calibration of trailer no. 1, which exists only for (20, 0.05), (20, 0.15),
        (20, 0.20) and (6, 0.05); any other configuration needs its own calibration.
    rc_time_constant : float
        tau of the RC high-pass, s (default 0.4 pi, as printed).
    gain_normalisation : {"bilinear", "as-printed"}
        ``"bilinear"`` (default) uses the corrected gain
        k = (1 + p1)(1 + p1*)(1 - p2)(1 - p2*) / (16 (1 + dt / 2 tau)), which gives
        |H| = 1 in the pass band; ``"as-printed"`` uses the paper's
        (1 - p1)(1 - p1*)(1 - p2)(1 - p2*) / (16 (1 + dt / 2 tau)) (gain near 1e-7; see Notes).

    Returns
    -------
    APLModel

    Raises
    ------
    InputError
        If (speed, dx) is not in Table 1 and no ``poles`` are given, or an option is invalid.

    Notes
    -----
    Eq. (1) of paper 000:

    .. math::

        H(z) = k \frac{(1 - z^{-1})^3 (1 + z^{-1})^2}
                      {(1 - p_0 z^{-1})(1 - p_1 z^{-1})(1 - p_1^* z^{-1})(1 - p_2 z^{-1})(1 - p_2^* z^{-1})},
        \qquad p_0 = \frac{1 - dt/2\tau}{1 + dt/2\tau},\quad p_i = |p_i| e^{j 2\pi f_i dt}.

    Each factor is the bilinear transform of an analogue section: the RC high-pass
    (1 - z^-1) / ((1 + dt/2tau)(1 - p0 z^-1)) has gain 1 at z = -1; the pendulum's
    high-pass pair (1 - z^-1)^2 / ((1 - p1 z^-1)(1 - p1* z^-1)) has gain 4 / ((1 + p1)(1 + p1*))
    at z = -1 (high frequency), so it is normalised by (1 + p1)(1 + p1*) / 4; the damper's
    low-pass pair (1 + z^-1)^2 / (...) has gain 4 / ((1 - p2)(1 - p2*)) at z = 1 and is
    normalised by (1 - p2)(1 - p2*) / 4. The product is the corrected k above. The printed
    k uses (1 - p1)(1 - p1*), the normalisation a *low-pass* pair would need; with
    |p1| = 0.9976 at 400 Hz it is ~4.5e-6 times too small (misprint, documented in docs/road-apl.md).
    """
    V = require_positive("speed", speed)
    h = require_positive("dx", dx)
    tau = require_positive("rc_time_constant", rc_time_constant)
    if poles is None:
        key = _table_key(V, h)
        if key is None:
            raise InputError(
                f"no Table 1 calibration for speed {V} m/s and dx {h} m; the paper calibrates only "
                f"{sorted(TABLE1_CONFIGURATIONS)} (speed m/s, dx m). Pass poles=TrailerPoles(...) "
                "from your own trailer calibration, or identify the trailer at this configuration "
                "(CLI: road identify, then --model model.json).")
        poles = TABLE1_CONFIGURATIONS[key]
    dt = h / V
    nyquist = 0.5 / dt
    for label, mod, f in (("pendulum", poles.pendulum_modulus, poles.pendulum_frequency),
                          ("damper", poles.damper_modulus, poles.damper_frequency)):
        if not (0.0 < mod < 1.0):
            raise InputError(f"{label} pole modulus must be in (0, 1) (a stable trailer); got {mod}.")
        if not (0.0 <= f < nyquist):
            raise InputError(f"{label} pole frequency must be in [0, {nyquist:g}) Hz (Nyquist at dt = {dt:g} s); "
                             f"got {f} Hz.")
    a = dt / (2.0 * tau)
    p0 = (1.0 - a) / (1.0 + a)
    p1 = poles.pendulum_modulus * np.exp(2j * np.pi * poles.pendulum_frequency * dt)
    p2 = poles.damper_modulus * np.exp(2j * np.pi * poles.damper_frequency * dt)
    if gain_normalisation == "bilinear":
        k = (1 + p1) * (1 + np.conj(p1)) * (1 - p2) * (1 - np.conj(p2)) / (16.0 * (1.0 + a))
    elif gain_normalisation == "as-printed":
        k = (1 - p1) * (1 - np.conj(p1)) * (1 - p2) * (1 - np.conj(p2)) / (16.0 * (1.0 + a))
    else:
        raise InputError(f"gain_normalisation must be 'bilinear' or 'as-printed'; got {gain_normalisation!r}.")
    return APLModel(zeros=np.array([1.0, 1.0, 1.0, -1.0, -1.0]), poles=np.array([p0, p1, np.conj(p1), p2, np.conj(p2)]),
                    gain=float(np.real(k)), delay=0, dt=dt, speed=V, dx=h,
                    name=f"eq. (1), V = {V:g} m/s, dx = {h:g} m" + ("" if gain_normalisation == "bilinear"
                                                                    else ", gain as printed"))


def _table_key(speed, dx):
    for (V, h) in TABLE1_CONFIGURATIONS:
        if np.isclose(V, speed, rtol=1e-9, atol=0) and np.isclose(h, dx, rtol=1e-9, atol=0):
            return (V, h)
    return None


def apl_model_from_polynomials(numerator, denominator, *, dt: float, speed: float | None = None,
                               dx: float | None = None, name: str = "") -> APLModel:
    """An instrument model from B(z^-1) / A(z^-1) coefficients (e.g. an identified OE model).

    Parameters
    ----------
    numerator : (nb,) array_like
        B in ascending powers of z^-1; leading zeros are the pure delay nk.
    denominator : (na + 1,) array_like
        A in ascending powers of z^-1 with A[0] != 0 (normalised to 1).
    dt : float
        Sampling step, s.
    speed, dx : float, optional
        Towing speed (m/s) and spacing (m); if both are given, dx / speed must equal dt.

    Returns
    -------
    APLModel
    """
    b = as_float_array("numerator", numerator, ndim=1, allow_nan=False)
    a = as_float_array("denominator", denominator, ndim=1, allow_nan=False)
    if a.size == 0 or a[0] == 0:
        raise ModelError("denominator must start with a non-zero coefficient A[0].")
    if not np.any(b != 0):
        raise ModelError("numerator is identically zero.")
    b, a = b / a[0], a / a[0]
    a = np.trim_zeros(a, "b")
    nz = np.flatnonzero(b)
    delay = int(nz[0])
    b = np.trim_zeros(b[delay:], "b")
    if b.size > a.size:  # more zeros than poles (an FIR bench model, orders 0 nb nk): causal in z^-1; the missing
        a = np.concatenate([a, np.zeros(b.size - a.size)])  # poles sit at the origin, factors (1 - 0 z^-1) = 1
    dt = require_positive("dt", dt)
    if speed is not None and dx is not None and not np.isclose(dx / speed, dt, rtol=1e-6):
        raise UnitsError(f"dx / speed = {dx}/{speed} = {dx / speed:g} s differs from dt = {dt:g} s.")
    zeros = np.roots(b) if b.size > 1 else np.array([], dtype=complex)
    poles = np.roots(a) if a.size > 1 else np.array([], dtype=complex)
    return APLModel(zeros=zeros, poles=poles, gain=float(b[0]), delay=delay, dt=dt, speed=speed, dx=dx, name=name)


def apl_model_from_dict(data: dict) -> APLModel:
    """Rebuild an :class:`APLModel` from :meth:`APLModel.to_dict` output (e.g. a ``road identify`` JSON file).

    Raises
    ------
    InputFormatError
        If a required key is missing or malformed.
    """
    from ...errors import InputFormatError

    if not isinstance(data, dict) or data.get("kind") != "apl-model":
        raise InputFormatError("not an APL model description: expected a JSON object with kind = 'apl-model' "
                               "(written by `longprofile road identify`).")
    missing = [k for k in ("numerator", "denominator", "dt") if k not in data]
    if missing:
        raise InputFormatError(f"APL model description lacks {missing}.")
    try:
        return apl_model_from_polynomials(data["numerator"], data["denominator"], dt=data["dt"],
                                          speed=data.get("speed"), dx=data.get("dx"), name=data.get("name", ""))
    except (TypeError, ValueError) as exc:
        raise InputFormatError(f"APL model description is malformed: {exc}") from None


# Identified models of §4.2 (B/A as printed; nk = 1, sampling Te of the record).
PAPER_IDENTIFIED_MODELS: dict[str, dict] = {
    "4.2.1-crenels": dict(
        b=[0.0, -0.2960, 0.9482, -1.0688, 0.4769, -0.0603],
        a=[1.0, -3.7854, 5.6833, -4.3245, 1.7410, -0.3144], dt=7.5e-3, residual_std=0.1409, iterations=34),
    "4.2.2-sine-arcs": dict(
        b=[0.0, -0.1575, 0.5974, -0.8475, 0.5325, -0.1250],
        a=[1.0, -4.5968, 8.4689, -7.8239, 3.6285, -0.6766], dt=7.5e-3, residual_std=0.0441, iterations=20),
    "4.2.3-white-noise": dict(
        b=[0.0, -0.3369, 0.0887, -0.1522, 0.1597, -0.1150],
        a=[1.0, -0.0830, 0.6564, -0.0530, 0.1951, -0.0481], dt=7.5e-3, residual_std=0.1845, iterations=9),
    "4.2.4-test-track": dict(
        b=[0.0, -0.4932, 0.7430, -0.2204, 0.6956, -0.2254],
        a=[1.0, -1.9183, 0.1451, -1.6193, 0.9894, -0.1434], dt=1.0 / 120.0, residual_std=1.9748, iterations=43),
}

# §4.3: zeros and poles of the retained (crenel) model as listed; z4 printed "0.02039" is a
# misprint for 0.2039 (the printed B(z) has its real zero at 0.2037).
_SECTION_43_ZEROS = np.array([1.0012, 0.9992 + 0.00119j, 0.9992 - 0.00119j, 0.2039])
_SECTION_43_POLES = np.array([0.9915, 0.9921 + 0.0132j, 0.9921 - 0.0132j, 0.4047 + 0.3978j, 0.4047 - 0.3978j])


def paper_identified_model(name: str) -> APLModel:
    """One of the APL models identified in paper 000, by name.

    Parameters
    ----------
    name : str
        ``"4.2.1-crenels"``, ``"4.2.2-sine-arcs"``, ``"4.2.3-white-noise"``, ``"4.2.4-test-track"``
        (B/A coefficients exactly as printed in §4.2.1-4.2.4, nk = 1) or ``"4.3-roots"`` (the
        retained crenel model rebuilt from the zeros and poles listed in §4.3, gain b1 = -0.2960).

    Returns
    -------
    APLModel
        Bench models have dt = Te = 7.5 ms and no speed; the test-track model has dt = 1/120 s,
        speed 6 m/s and dx = 0.05 m.

    Notes
    -----
    Printed to 4 decimals, the near-unit roots of §4.2.1 are ill-conditioned: the printed A(z)
    has A(1) = 0 exactly (a pole at 1, cancelled by B(1) = 0), while §4.3 lists 0.9915 and
    0.9921 +/- 0.0132j. "4.3-roots" is the stable version of the same model, with zeros just off 1
    (1.0012, 0.9992 +/- 0.00119j): the gain of observability §5.2 relies on. As printed, the
    §4.2.2 and §4.2.4 denominators have roots outside the unit circle (|p| = 1.056 and 2.11):
    they are kept verbatim for reference, :attr:`APLModel.is_stable` is False, and
    :func:`apl_response` refuses them.
    """
    if name == "4.3-roots":
        return APLModel(zeros=_SECTION_43_ZEROS, poles=_SECTION_43_POLES, gain=-0.2960, delay=1, dt=7.5e-3,
                        name="paper 000 §4.3 zeros/poles (crenel model)")
    if name not in PAPER_IDENTIFIED_MODELS:
        raise InputError(f"unknown identified model {name!r}; choose one of "
                         f"{sorted(PAPER_IDENTIFIED_MODELS) + ['4.3-roots']}.")
    spec = PAPER_IDENTIFIED_MODELS[name]
    speed, dx = (6.0, 0.05) if name == "4.2.4-test-track" else (None, None)
    return apl_model_from_polynomials(spec["b"], spec["a"], dt=spec["dt"], speed=speed, dx=dx,
                                      name=f"paper 000 §{name.split('-')[0]} (as printed)")


def frequency_response(model: APLModel, frequency=None, *, n_points: int = 2000) -> FrequencyResponse:
    """Magnitude, unwrapped phase and group delay of an instrument model.

    Parameters
    ----------
    model : APLModel
    frequency : (F,) array_like, optional
        Frequencies, Hz, in (0, Nyquist]. Default: ``n_points`` log-spaced from 1e-3 Hz to Nyquist.
    n_points : int
        Number of default frequencies.

    Returns
    -------
    FrequencyResponse
        The group delay is computed analytically from the zeros and poles
        (sum of the per-root group delays), not by differentiating the phase.
    """
    nyq = 0.5 / model.dt
    if frequency is None:
        f = np.logspace(-3, np.log10(nyq), int(n_points))
    else:
        f = as_float_array("frequency", frequency, ndim=1, allow_nan=False)
        if np.any(f < 0) or np.any(f > nyq * (1 + 1e-12)):
            raise InputError(f"frequency must lie in [0, {nyq:g}] Hz (Nyquist for dt = {model.dt:g} s).")
    H = model.response_at(f)
    w = 2 * np.pi * f * model.dt  # rad/sample
    gd = np.full(f.shape, float(model.delay))
    for r, sign in [(zi, -1.0) for zi in model.zeros] + [(pj, 1.0) for pj in model.poles]:
        # d/dw arg(1 - r e^{-jw}) = Re[r e^{-jw} / (1 - r e^{-jw})]; a zero adds minus that to the
        # group delay (in samples), a pole adds it.
        e = r * np.exp(-1j * w)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.real(e / (1.0 - e))
        gd = gd + sign * g
    return FrequencyResponse(frequency=f, wavelength=(model.speed / np.where(f > 0, f, np.nan)) if model.speed else None,
                             magnitude=np.abs(H), phase=np.unwrap(np.angle(H)), group_delay=gd * model.dt)


def passband(model: APLModel, *, tolerance: float = 0.1, reference_frequency: float = 1.0) -> tuple[float, float]:
    """The contiguous band around ``reference_frequency`` where | |H| - 1 | <= ``tolerance``.

    Returns
    -------
    (f_low, f_high) : tuple of float
        Hz, found on a dense log grid (1000 points per decade) from 1e-3 Hz to Nyquist.

    Raises
    ------
    ModelError
        If |H(reference_frequency)| itself is outside 1 +/- tolerance.
    """
    nyq = 0.5 / model.dt
    f = np.logspace(-3, np.log10(nyq), int(1000 * np.log10(nyq / 1e-3)))
    ok = np.abs(np.abs(model.response_at(f)) - 1.0) <= tolerance
    i0 = int(np.searchsorted(f, reference_frequency))
    if not ok[i0]:
        raise ModelError(f"|H| at {reference_frequency} Hz is {abs(model.response_at(reference_frequency)):.3g}, "
                         f"not within 1 +/- {tolerance}: the model has no unit-gain band there.")
    lo = i0
    while lo > 0 and ok[lo - 1]:
        lo -= 1
    hi = i0
    while hi < f.size - 1 and ok[hi + 1]:
        hi += 1
    return float(f[lo]), float(f[hi])


def apl_filter(model: APLModel, x, *, axis: int = 0, initial: str = "steady") -> np.ndarray:
    """Filter samples by the instrument model (second-order sections, pure delay applied exactly).

    Parameters
    ----------
    model : APLModel
    x : array_like
        Input samples; filtered along ``axis`` (default 0, time first).
    initial : {"steady", "rest"}
        ``"steady"`` (default): the input is taken as constant and equal to its first sample
        before the record, so the instrument starts in steady state (no start-up transient
        from the absolute level); ``"rest"``: zero initial state and zero past input.

    Returns
    -------
    ndarray, same shape as ``x``
    """
    arr = as_float_array("x", x, allow_nan=False)
    arr = np.moveaxis(arr, axis, 0)
    if arr.shape[0] == 0:
        raise ShapeError("x has no samples.")
    if initial == "steady":
        x0 = arr[:1]
        out = sos_filter(model.sos, arr - x0) + model.dc_gain * x0
    elif initial == "rest":
        x0 = np.zeros_like(arr[:1])
        out = sos_filter(model.sos, arr)
    else:
        raise InputError(f"initial must be 'steady' or 'rest'; got {initial!r}.")
    if model.delay:
        d = min(model.delay, arr.shape[0])
        head = np.broadcast_to(model.dc_gain * x0, (d,) + arr.shape[1:])
        out = np.concatenate([head, out[:arr.shape[0] - d]], axis=0)
    return np.moveaxis(out, 0, axis)


def _check_profile_spacing(profile: Profile, model: APLModel) -> float:
    dx = profile.spacing
    if dx is None:
        raise InputError(f"profile {profile.name!r} has irregular stations; the APL model needs a constant spacing. "
                         "Resample it first.")
    if model.dx is not None and not np.isclose(dx, model.dx, rtol=1e-6):
        raise UnitsError(f"profile spacing {dx:g} m differs from the model's dx = {model.dx:g} m "
                         f"({model.name}); build the model for this spacing (apl_model(speed, dx={dx:g})).")
    return dx


def apl_response(profile, model: APLModel, *, initial: str = "steady"):
    """Simulate what the APL trailer records when towed over a profile.

    Parameters
    ----------
    profile : Profile or (N,) / (N, K) array_like
        True road profile, m. A :class:`Profile` must have a constant spacing equal to the
        model's ``dx``; a bare array is taken as sampled at the model's step.
    model : APLModel
        Instrument model (must be stable).
    initial : {"steady", "rest"}
        Start-up convention, see :func:`apl_filter`.

    Returns
    -------
    Profile or ndarray
        The recorded signal (the "pseudo-profile"), m, same type and shape as ``profile``.

    Raises
    ------
    ModelError
        If the model is unstable.
    UnitsError
        If the profile spacing and the model's dx differ.
    """
    if not isinstance(model, APLModel):
        raise InputError(f"model must be an APLModel; got {type(model).__name__}.")
    if not model.is_stable:
        raise ModelError(f"{model.name or 'the model'} is unstable (max |pole| = {np.abs(model.poles).max():.4f}); "
                         "simulating it is meaningless. Use a stable model (e.g. apl_model() or '4.3-roots').")
    if isinstance(profile, Profile):
        _check_profile_spacing(profile, model)
        z = profile.elevation
        if np.isnan(z).any():
            raise InputError(f"profile {profile.name!r} has {int(np.isnan(z).sum())} missing elevation(s); "
                             "the trailer needs a continuous profile. Fill or cut the gaps first.")
        y = apl_filter(model, z, initial=initial)
        return Profile(profile.distance, y, tracks=profile.tracks, name=f"APL response of {profile.name}".strip())
    return apl_filter(model, profile, initial=initial)
