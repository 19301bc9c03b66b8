"""Synthetic road profiles with known truth (the test shapes of paper 000, §3 and §5.3).

Random roads of ISO 8608 classes are in :func:`longprofile.road.iso8608_profile`.
Every function returns a :class:`Profile` with stations ``0, dx, 2 dx, ...`` (N = floor(length/dx) + 1)
and elevations in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validation import require_positive
from ...core import Profile
from ...errors import InputError

__all__ = ["bump_profile", "crenel_profile", "speed_hump_profile", "sine_arcs_profile", "white_noise_profile",
           "simulate_apl_recording", "APLRecording", "SYNTHETIC_PROFILES"]


def _stations(length, dx):
    length = require_positive("length", length)
    dx = require_positive("dx", dx)
    n = int(np.floor(length / dx + 1e-9)) + 1
    if n < 4:
        raise InputError(f"length {length} m with dx {dx} m gives {n} samples; need at least 4.")
    return np.arange(n) * dx


def _check_inside(name, start, width, x):
    if start < 0 or start + width > x[-1] + 1e-12:
        raise InputError(f"{name} from {start} m to {start + width} m does not fit in the profile [0, {x[-1]:g}] m; "
                         "lengthen the profile or move the feature.")


def bump_profile(length: float = 60.0, dx: float = 0.05, *, width: float = 10.0, height: float = 0.02,
                 center: float | None = None, shape: str = "cosine") -> Profile:
    """An isolated bump on a flat road (paper 000, fig. 7: 10 m long, 20 mm high).

    Parameters
    ----------
    length, dx : float
        Profile length and spacing, m.
    width, height : float
        Base length (m) and height (m, negative for a dip) of the bump.
    center : float, optional
        Station of the bump's top, m (default: middle of the profile).
    shape : {"cosine", "half-sine", "triangle"}
        ``"cosine"``: h (1 - cos(2 pi s / width)) / 2 (smooth, default); ``"half-sine"``:
        h sin(pi s / width); ``"triangle"``: linear up and down. Assumption: the paper does not
        print the bump's shape; the raised cosine is our default.

    Returns
    -------
    Profile
    """
    x = _stations(length, dx)
    width = require_positive("width", width)
    c = x[-1] / 2 if center is None else float(center)
    _check_inside("bump", c - width / 2, width, x)
    s = x - (c - width / 2)
    inside = (s >= 0) & (s <= width)
    if shape == "cosine":
        z = 0.5 * (1 - np.cos(2 * np.pi * s / width))
    elif shape == "half-sine":
        z = np.sin(np.pi * s / width)
    elif shape == "triangle":
        z = 1 - np.abs(2 * s / width - 1)
    else:
        raise InputError(f"shape must be 'cosine', 'half-sine' or 'triangle'; got {shape!r}.")
    return Profile(x, np.where(inside, height * z, 0.0), name=f"bump {width:g} m x {height * 1e3:g} mm")


def crenel_profile(length: float = 80.0, dx: float = 0.05, *, width: float = 10.0, height: float = 0.01,
                   n_crenels: int = 1, gap: float | None = None, alternate: bool = True,
                   start: float | None = None) -> Profile:
    """Rectangular crenels (steps up and down) on a flat road (paper 000, fig. 8: 10 m x 10 mm).

    Parameters
    ----------
    length, dx : float
        Profile length and spacing, m.
    width, height : float
        Length (m) and height (m) of each crenel.
    n_crenels : int
        Number of crenels (each gives 2 fronts; essai 1 has 10 fronts = 5 crenels).
    gap : float, optional
        Flat length between crenels, m (default: ``width``).
    alternate : bool
        If True (default), crenels alternate positive and negative (fig. 8); else all positive.
    start : float, optional
        Station of the first front, m (default: the crenel train is centred).

    Returns
    -------
    Profile
    """
    x = _stations(length, dx)
    width = require_positive("width", width)
    if int(n_crenels) != n_crenels or n_crenels < 1:
        raise InputError(f"n_crenels must be a positive integer; got {n_crenels!r}.")
    n_crenels = int(n_crenels)
    gap = width if gap is None else require_positive("gap", gap, strict=False)
    total = n_crenels * width + (n_crenels - 1) * gap
    s0 = (x[-1] - total) / 2 if start is None else float(start)
    _check_inside("crenel train", s0, total, x)
    z = np.zeros_like(x)
    for i in range(n_crenels):
        a = s0 + i * (width + gap)
        sign = -1.0 if (alternate and i % 2) else 1.0
        z[(x >= a - 1e-9) & (x < a + width - 1e-9)] = sign * height
    return Profile(x, z, name=f"{n_crenels} crenel(s) {width:g} m x {height * 1e3:g} mm")


def speed_hump_profile(length: float = 60.0, dx: float = 0.05, *, width: float = 5.0, height: float = 0.05,
                       ramp: float = 0.5, center: float | None = None) -> Profile:
    """A trapezoidal speed hump (paper 000, fig. 9: "a crenel 5 m long and a few cm high").

    Parameters
    ----------
    width : float
        Length of the hump at its base, m (default 5).
    height : float
        Height, m (default 0.05; the paper says "quelques centimètres").
    ramp : float
        Length of each linear ramp, m (default 0.5; assumption, not printed in the paper).
    center : float, optional
        Station of the middle of the hump (default: middle of the profile).
    """
    x = _stations(length, dx)
    width = require_positive("width", width)
    ramp = require_positive("ramp", ramp)
    if 2 * ramp > width:
        raise InputError(f"two ramps of {ramp} m do not fit in a hump {width} m long.")
    c = x[-1] / 2 if center is None else float(center)
    _check_inside("speed hump", c - width / 2, width, x)
    s = np.abs(x - c)
    z = height * np.clip((width / 2 - s) / ramp, 0.0, 1.0)
    return Profile(x, z, name=f"speed hump {width:g} m x {height * 1e2:g} cm")


def sine_arcs_profile(length: float = 250.0, dx: float = 0.05, *, arc_length: float = 10.0, height: float = 0.01,
                      n_arcs: int = 5, gap: float | None = None, start: float | None = None) -> Profile:
    """Positive half-sine arcs separated by flats (paper 000, essai 2: "arcs de sinusoïdes", 5 arcs).

    Parameters
    ----------
    arc_length, height : float
        Base length (m) and height (m) of each arc h sin(pi s / arc_length).
    n_arcs : int
        Number of arcs.
    gap : float, optional
        Flat length between arcs, m (default: ``3 * arc_length``).
    start : float, optional
        Station of the first arc's start (default: the train is centred).
    """
    x = _stations(length, dx)
    arc_length = require_positive("arc_length", arc_length)
    if int(n_arcs) != n_arcs or n_arcs < 1:
        raise InputError(f"n_arcs must be a positive integer; got {n_arcs!r}.")
    n_arcs = int(n_arcs)
    gap = 3 * arc_length if gap is None else require_positive("gap", gap, strict=False)
    total = n_arcs * arc_length + (n_arcs - 1) * gap
    s0 = (x[-1] - total) / 2 if start is None else float(start)
    _check_inside("sine arcs", s0, total, x)
    z = np.zeros_like(x)
    for i in range(n_arcs):
        s = x - (s0 + i * (arc_length + gap))
        inside = (s >= 0) & (s <= arc_length)
        z[inside] = height * np.sin(np.pi * s[inside] / arc_length)
    return Profile(x, z, name=f"{n_arcs} sine arcs {arc_length:g} m x {height * 1e3:g} mm")


def white_noise_profile(length: float = 250.0, dx: float = 0.05, *, std: float = 0.005, rng=None) -> Profile:
    """A white Gaussian profile (paper 000, essai 3), seedable.

    Parameters
    ----------
    std : float
        Standard deviation of each elevation, m.
    rng : int, numpy.random.Generator or None
        Seed or generator.
    """
    x = _stations(length, dx)
    std = require_positive("std", std)
    z = np.random.default_rng(rng).normal(0.0, std, size=x.shape)
    return Profile(x, z, name=f"white noise {std * 1e3:g} mm")


@dataclass(frozen=True, eq=False)
class APLRecording:
    """A simulated APL recording with its truth.

    Attributes
    ----------
    distance : (N,) ndarray
        Stations, m.
    true_elevation : (N,) ndarray
        The road profile, m.
    signal : (N,) ndarray
        What the trailer records (model response + noise), m.
    noise_std : float
        Standard deviation of the added white measurement noise, m.
    """

    distance: np.ndarray
    true_elevation: np.ndarray
    signal: np.ndarray
    noise_std: float

    def to_frame(self):
        """The ``road simulate`` table: ``distance_m, true_m, apl_m`` (m)."""
        import pandas as pd

        return pd.DataFrame(dict(distance_m=self.distance, true_m=self.true_elevation, apl_m=self.signal))


SYNTHETIC_PROFILES = ("iso8608", "bump", "crenels", "speed-hump", "sine-arcs", "white-noise")


def simulate_apl_recording(kind: str, model, *, length: float = 1000.0, road_class: str = "C",
                           noise_fraction: float = 0.02, rng=None, road_rng=None) -> APLRecording:
    """Simulate an APL recording of a synthetic road with known truth.

    Parameters
    ----------
    kind : {"iso8608", "bump", "crenels", "speed-hump", "sine-arcs", "white-noise"}
        The synthetic profile (defaults of the matching ``*_profile`` function; crenels: 5, i.e. 10 fronts).
    model : APLModel
        The instrument (its ``dx`` sets the spacing).
    length : float
        m.
    road_class : str
        ISO 8608 class for ``"iso8608"``.
    noise_fraction : float
        Measurement noise std as a fraction of the noise-free signal RMS (default 0.02).
    rng : int, Generator or None
        Seed or generator of the noise and, without ``road_rng``, of the road: the road is drawn first, then the
        noise, from one generator.
    road_rng : int, Generator or None, optional
        Seed or generator of the road alone (random kinds: ``iso8608``, ``white-noise``). The noise is then what
        ``rng`` alone would add: the draws of ``rng`` after its own road. So ``road_rng=s, rng=s`` is ``rng=s``, and
        ``road_rng=s`` with another ``rng`` is the road of ``rng=s`` recorded with another noise.

    Returns
    -------
    APLRecording
    """
    from ..indices import iso8608_profile
    from ._model import apl_response

    if model.dx is None:
        raise InputError("the instrument model has no spacing dx; build it with apl_model(speed, dx).")
    dx = model.dx
    gen = np.random.default_rng(rng)
    makers = {
        "iso8608": lambda g: iso8608_profile(length, dx, road_class, rng=g),
        "bump": lambda g: bump_profile(length, dx),
        "crenels": lambda g: crenel_profile(length, dx, n_crenels=5),
        "speed-hump": lambda g: speed_hump_profile(length, dx),
        "sine-arcs": lambda g: sine_arcs_profile(length, dx),
        "white-noise": lambda g: white_noise_profile(length, dx, rng=g),
    }
    if kind not in makers:
        raise InputError(f"kind must be one of {SYNTHETIC_PROFILES}; got {kind!r}.")
    frac = require_positive("noise_fraction", noise_fraction, strict=False)
    prof = makers[kind](gen)  # the road of rng, drawn even with road_rng: the noise follows it in rng's stream
    if road_rng is not None:
        prof = makers[kind](np.random.default_rng(road_rng))
    u = prof.elevation[:, 0]
    y0 = apl_response(u, model)
    sd = frac * float(np.sqrt(np.mean(y0 ** 2)))
    y = y0 + (gen.normal(0.0, sd, y0.size) if sd > 0 else 0.0)
    return APLRecording(distance=prof.distance, true_elevation=u, signal=y, noise_std=sd)
