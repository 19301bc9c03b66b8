"""Observability of the thesis-003 corner models (thesis §3.5, digest §5.4).

The thesis linearises a corner model at equilibrium (X = 0, U = 0), scales the states (positions 0.1 m,
velocities 0.1 m/s, disturbance force 2000 N — "values observed on the vehicle"), builds
``O = [C; C A; ...; C A^(n-1)]`` and reads the singular values and right singular vectors of the scaled
matrix. Two models:

* absolute corner model ``[Z2dot, Z2, Z1dot, Z1, P, Z0]``: a common vertical shift of Z2, Z1, Z0 is
  unobservable from a relative displacement (and from accelerations) -> the thesis rewrites the model in
  relative states;
* relative corner model ``[dZ21dot, dZ21, P, dZ10]`` (the one the EKF uses): observable, but with the
  displacement sensor alone the weakest direction is almost pure P (the vehicle disturbance is barely seen).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ._model import CK, CKBAR, CMW, SKT, damper_force, vertical_params_arrays
from ._params import VerticalVehicleParams

__all__ = ["ObservabilityResult", "corner_observability"]

_SCALES = {"velocity": 0.1, "position": 0.1, "force": 2000.0}


@dataclass(frozen=True, eq=False)
class ObservabilityResult:
    """SVD of the scaled observability matrix of a linearised corner model.

    Attributes
    ----------
    state_names : tuple of str
    singular_values : (n,) ndarray -- descending.
    right_singular_vectors : (n, n) ndarray -- column j is the state direction of ``singular_values[j]``
        (scaled coordinates, unit norm).
    rank : int -- numerical rank (singular values above ``rtol * max``).
    condition_number : float -- largest / smallest singular value (inf if singular).
    weakest_direction : (n,) ndarray -- last right singular vector (sign: largest entry positive).
    transition, observation : ndarray -- the continuous-time A (n, n) and C (m, n) in scaled coordinates.
    model, config : str, int
    """

    state_names: tuple
    singular_values: np.ndarray
    right_singular_vectors: np.ndarray
    rank: int
    condition_number: float
    weakest_direction: np.ndarray
    transition: np.ndarray
    observation: np.ndarray
    model: str
    config: int


def _corner_linearisation(params, corner_index):
    corner, coupling, scalars = vertical_params_arrays(params)
    c = corner_index
    _, cd = damper_force(0.0, *corner[c, 6:12], scalars[1])
    k = corner[c, CK] + corner[c, CKBAR]  # spring slope at 0 + own anti-roll bar (other side held)
    return 1.0 / coupling[c, c], corner[c, CMW], k, cd, scalars[SKT], coupling[c, c]


def corner_observability(config: int, *, model: str = "relative", params: VerticalVehicleParams | None = None,
                         corner: int = 0, tau_vehicle: float = 0.1, rtol: float = 1e-9) -> ObservabilityResult:
    """Observability analysis of one corner model for a sensor configuration (thesis §3.5).

    Parameters
    ----------
    config : {1, 2, 3}
        1: relative displacement; 2: + body-corner acceleration; 3: + wheel acceleration.
    model : {"relative", "absolute"}
        ``"relative"``: states [dZ21dot, dZ21, P, dZ10] (the EKF's model; P first-order with ``tau_vehicle``,
        dZ10 entering as a disturbance state). ``"absolute"``: [Z2dot, Z2, Z1dot, Z1, P, Z0] with the road
        height a random walk (road height is not mean-reverting).
    params : VerticalVehicleParams, optional
        Default thesis set; the corner uses its equivalent mass M_eq (§3.4.2), spring + anti-roll slope
        and damper slope at rest.
    corner : int
        0..3 (FL, FR, RL, RR); the thesis shows the front-left corner.
    tau_vehicle : float
        Time constant of the disturbance P, s (thesis 0.1 s).
    rtol : float
        Relative threshold on singular values for the numerical rank.

    Returns
    -------
    ObservabilityResult
    """
    if config not in (1, 2, 3):
        raise InputError(f"config must be 1, 2 or 3 (thesis sensor configurations); got {config!r}.")
    if model not in ("relative", "absolute"):
        raise InputError(f"model must be 'relative' or 'absolute'; got {model!r}.")
    if corner not in (0, 1, 2, 3):
        raise InputError(f"corner must be 0..3 (FL, FR, RL, RR); got {corner!r}.")
    p = params or VerticalVehicleParams()
    meq, mw, k, cd, kt, inv_meq = _corner_linearisation(p, corner)
    a_p = -1.0 / tau_vehicle
    if model == "absolute":
        names = ("Z2dot", "Z2", "Z1dot", "Z1", "P", "Z0")
        sv, sp, sf = _SCALES["velocity"], _SCALES["position"], _SCALES["force"]
        scale = np.array([sv, sp, sv, sp, sf, sp])
        A = np.zeros((6, 6))
        # Meq Z2dd = -k (Z2 - Z1) - c (Z2dot - Z1dot) + P ; mw Z1dd = k (Z2-Z1) + c (...) - kt (Z1 - Z0)
        A[0] = [-cd / meq, -k / meq, cd / meq, k / meq, 1 / meq, 0]
        A[1, 0] = 1
        A[2] = [cd / mw, k / mw, -cd / mw, -(k + kt) / mw, 0, kt / mw]
        A[3, 2] = 1
        A[4, 4] = a_p
        rows = [np.array([0, 1, 0, -1, 0, 0.0])]
        if config == 2:
            rows.append(A[0].copy())
        elif config == 3:
            rows.append(A[2].copy())
    else:
        names = ("dZ21dot", "dZ21", "P", "dZ10")
        scale = np.array([_SCALES["velocity"], _SCALES["position"], _SCALES["force"], _SCALES["position"]])
        A = np.zeros((4, 4))
        # dZ21dd = Z2dd - Z1dd with Z2dd = (-F + P)/Meq, Z1dd = (F - kt dZ10)/mw, F = k dZ21 + c dZ21dot
        A[0] = [-cd * (inv_meq + 1 / mw), -k * (inv_meq + 1 / mw), inv_meq, kt / mw]
        A[1, 0] = 1
        A[2, 2] = a_p
        A[3, 3] = -1.0 / 0.01  # dZ10: first-order disturbance (tau_route = 0.01 s)
        rows = [np.array([0, 1, 0, 0.0])]
        if config == 2:
            rows.append(np.array([-cd * inv_meq, -k * inv_meq, inv_meq, 0.0]))
        elif config == 3:
            rows.append(np.array([cd / mw, k / mw, 0.0, -kt / mw]))
    C = np.vstack(rows)
    T = np.diag(scale)
    As = np.linalg.solve(T, A @ T)
    Cs = C @ T
    n = As.shape[0]
    blocks = [Cs]
    for _ in range(n - 1):
        blocks.append(blocks[-1] @ As)
    O = np.vstack(blocks)
    # normalise each block row so the higher powers (large |A|) do not swamp the SVD, as the thesis' plots suggest
    O = O / np.maximum(np.linalg.norm(O, axis=1, keepdims=True), np.finfo(float).tiny)
    _, s, vt = np.linalg.svd(O)
    V = vt.T
    rank = int(np.sum(s > rtol * s[0]))
    weak = V[:, -1] * np.sign(V[np.argmax(np.abs(V[:, -1])), -1])
    cond = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    return ObservabilityResult(state_names=names, singular_values=s, right_singular_vectors=V, rank=rank,
                               condition_number=cond, weakest_direction=weak, transition=As, observation=Cs,
                               model=model, config=int(config))
