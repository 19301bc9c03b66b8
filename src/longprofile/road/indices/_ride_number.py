"""Ride Number (ASTM E1489): a quarter-car Profile Index mapped onto a 0..5 subjective ride scale.

The quarter-car filter runs in the state-space engine (:func:`longprofile.statespace.linear_recursion`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..._validation import require_positive
from ...core import Profile
from ...errors import InputError
from ...statespace import linear_recursion

__all__ = ["RN_CAR", "RN_SPEED", "RideNumberResult", "ride_number", "ride_number_filter", "rn_from_pi"]

#: Quarter-car parameters of the Ride Number filter (per unit sprung mass: tyre k1 and suspension k2 in 1/s^2,
#: damping c in 1/s, mass ratio mu). ASSUMPTION: recalled from the NCHRP 1-23 / ASTM E1489 algorithm as
#: implemented in UMTRI's RoadRuf and FHWA ProVAL; not confirmed against the text of ASTM E1489 here
#: (see docs/road-acceptance.md). Pass ``car=`` to use other values.
RN_CAR = {"k1": 5120.0, "k2": 390.0, "c": 17.0, "mu": 0.036}
#: Simulated speed, 80 km/h in m/s (as the IRI; ASSUMPTION, same source status as RN_CAR).
RN_SPEED = 80.0 / 3.6
#: RN = 5 exp(-160 PI), PI in m/m (ASTM E1489 Eq 1 as recalled; the 5 and 160 are an ASSUMPTION, see docs).
_RN_SCALE, _RN_RATE = 5.0, 160.0
_C_RATE = np.array([[1.0, 0.0, -1.0, 0.0]])


@dataclass(frozen=True, eq=False)
class RideNumberResult:
    """Ride Number of a profile.

    Attributes
    ----------
    ride_number : float
        RN of the profile (0 = impassable, 5 = perfect), from the combined PI.
    profile_index : (K,) ndarray
        PI per track: RMS of the filter output, m/m.
    combined_profile_index : float
        ``sqrt(mean(PI_k^2))`` over the tracks (for two tracks ``sqrt((PI_L^2 + PI_R^2) / 2)``), m/m.
    track_ride_number : (K,) ndarray
        RN of each track alone.
    tracks : tuple of str
    metadata : dict
        Filter parameters, speed, moving average and the status of every constant.
    """

    ride_number: float
    profile_index: np.ndarray
    combined_profile_index: float
    track_ride_number: np.ndarray
    tracks: tuple[str, ...]
    metadata: dict = field(default_factory=dict)


def rn_from_pi(pi):
    """Ride Number of a Profile Index (m/m): ``RN = 5 exp(-160 PI)`` (ASTM E1489 Eq 1 as recalled; ASSUMPTION, see
    docs/road-acceptance.md). A float for a float, an array for an array."""
    return _RN_SCALE * np.exp(-_RN_RATE * pi)


def _car_matrices(car: dict, dx: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    from scipy.linalg import expm

    unknown = set(car) - {"k1", "k2", "c", "mu"}
    if unknown or len(car) != 4:
        raise InputError(f"car must give exactly k1, k2, c, mu; got {sorted(car)}.")
    k1, k2, c, mu = (require_positive(f"car[{k!r}]", car[k]) for k in ("k1", "k2", "c", "mu"))
    aug = np.zeros((5, 5))
    aug[:4, :4] = [[0.0, 1.0, 0.0, 0.0], [-k2, -c, k2, c], [0.0, 0.0, 0.0, 1.0],
                   [k2 / mu, c / mu, -(k1 + k2) / mu, -c / mu]]
    aug[3, 4] = k1 / mu
    e = expm(aug * (dx / speed))
    return e[:4, :4], e[:4, 4:5]


def ride_number_filter(profile: Profile, *, tracks=None, car: dict | None = None, speed: float = RN_SPEED,
                       lead_in: float = 11.0, moving_average: bool | None = None,
                       base_length: float = 0.25) -> tuple[np.ndarray, np.ndarray, tuple[str, ...], bool]:
    """Quarter-car filter output ``zs' - zu'`` (m/m) of the Ride Number, per step.

    Parameters
    ----------
    profile : Profile
        Constant step (resample irregular profiles first), m; no NaN.
    tracks : str or sequence of str, optional
    car : dict, optional
        ``{"k1", "k2", "c", "mu"}`` (default :data:`RN_CAR`).
    speed : float
        m/s (default 80 km/h).
    lead_in : float
        The initial state is ``[s0, 0, s0, 0]`` with ``s0`` the slope over the first ``lead_in`` m (the IRI's
        initialisation, ASTM E1926; an ASSUMPTION for the RN).
    moving_average : bool, optional
        250 mm moving average before the filter; default (None): applied when ``round(0.25 / dx) >= 2``
        (the IRI rule; an ASSUMPTION for the RN).
    base_length : float
        Moving-average base, m.

    Returns
    -------
    station : (M,) ndarray
        Station at the end of each filter step, m.
    output : (M, K) ndarray
        Filter output, m/m.
    tracks : tuple of str
    moving_average : bool
        Whether the moving average was applied.
    """
    dx = profile.spacing
    if dx is None:
        raise InputError("the Ride Number filter needs a constant sample interval; resample the profile first "
                         "(e.g. numpy.interp onto a regular grid) -- longprofile does not resample silently.")
    speed = require_positive("speed (m/s)", speed)
    lead_in = require_positive("lead_in (m)", lead_in)
    names = profile.tracks if tracks is None else ((tracks,) if isinstance(tracks, str) else tuple(tracks))
    z = np.column_stack([profile.track(t) for t in names])
    x = profile.distance
    if np.isnan(z).any():
        i, j = np.argwhere(np.isnan(z))[0]
        raise InputError(f"track {names[j]!r} has a missing (NaN) elevation at station {x[i]:.3f} m; the Ride "
                         "Number needs a continuous profile.")
    k = max(1, int(np.floor(base_length / dx + 0.5)))
    apply = (k >= 2) if moving_average is None else bool(moving_average)
    if apply and k >= 2:
        if x.size <= k:
            raise InputError(f"the profile ({x.size} samples) is shorter than the moving-average base ({k}).")
        z = np.lib.stride_tricks.sliding_window_view(z, k, axis=0).mean(axis=-1)
        lo = (k - 1) // 2 if k % 2 else k // 2
        x = x[lo:lo + z.shape[0]]
    n_lead = max(1, int(np.floor(lead_in / dx + 0.5)))
    if x.size <= n_lead:
        raise InputError(f"the profile ({x[-1] - x[0]:.3f} m) is shorter than the lead-in ({lead_in:g} m).")
    st, pr = _car_matrices(dict(RN_CAR if car is None else car), dx, speed)
    slopes = np.diff(z, axis=0) / dx
    s0 = (z[n_lead] - z[0]) / (n_lead * dx)
    out = np.empty_like(slopes)
    for j in range(z.shape[1]):
        res = linear_recursion(st, pr, slopes[:, j], np.array([s0[j], 0.0, s0[j], 0.0]), output_matrix=_C_RATE)
        out[:, j] = res.outputs[:, 0]
    return x[1:], out, tuple(names), apply and k >= 2


def ride_number(profile: Profile, *, tracks=None, car: dict | None = None, speed: float = RN_SPEED,
                lead_in: float = 11.0, moving_average: bool | None = None) -> RideNumberResult:
    """Ride Number (ASTM E1489) of a profile: ``RN = 5 exp(-160 PI)``.

    Parameters
    ----------
    profile : Profile
        Constant step, m; one or two tracks (any number is accepted: PI is combined by RMS).
    tracks, car, speed, lead_in, moving_average
        See :func:`ride_number_filter`.

    Returns
    -------
    RideNumberResult

    Notes
    -----
    Each track is filtered by a quarter car (:data:`RN_CAR`, 80 km/h) whose output ``zs' - zu'`` is a slope
    (m/m); its RMS over the profile is the Profile Index PI of the track; the tracks' PI combine as
    ``sqrt((PI_L^2 + PI_R^2) / 2)`` and ``RN = 5 exp(-160 PI)`` (ASTM E1489-08, Section 8, as recalled). The
    filter implementation is verified against an independent continuous-time simulation
    (:func:`scipy.signal.lsim`) and the closed-form frequency response on a sine; the constants themselves are
    marked as assumptions in docs/road-acceptance.md until checked against the standard's text or a published
    worked example.
    """
    _, out, names, applied = ride_number_filter(profile, tracks=tracks, car=car, speed=speed, lead_in=lead_in,
                                                moving_average=moving_average)
    pi = np.sqrt(np.mean(out * out, axis=0))
    pi_all = float(np.sqrt(np.mean(pi * pi)))
    meta = {"standard": "ASTM E1489-08 (Ride Number); constants recalled, see docs/road-acceptance.md",
            "car": dict(RN_CAR if car is None else car), "speed_m_per_s": float(speed), "lead_in_m": float(lead_in),
            "moving_average_applied": bool(applied), "formula": "RN = 5 exp(-160 PI), PI = RMS(zs' - zu') in m/m"}
    return RideNumberResult(ride_number=float(rn_from_pi(pi_all)), profile_index=pi,
                            combined_profile_index=pi_all, track_ride_number=rn_from_pi(pi),
                            tracks=names, metadata=meta)
