"""An identified trailer model re-discretised for another sampling step (a bench at a fixed rate, a survey at 5 cm)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..._validation import require_positive
from ...errors import ModelError
from ._model import APLModel

__all__ = ["MAX_POLE_FRACTION", "resample_model", "step_transitions"]

#: Largest pole frequency |angle(p)| / pi (a fraction of the Nyquist frequency) at the model's step and at the new
#: one: beyond it the samples do not resolve the dynamics and the continuous-time form is not determined.
MAX_POLE_FRACTION = 0.5


def resample_model(model: APLModel, dt: float, *, speed: float | None = None, dx: float | None = None) -> APLModel:
    """The same trailer sampled every ``dt``: the model's continuous-time form, discretised again.

    Parameters
    ----------
    model : APLModel
        A discrete instrument, e.g. identified from bench records at a fixed rate (paper 000 §4: Te = 7.5 ms).
        Its delay must be 0 (a direct feed-through) or 1 sample (a strictly proper model, as a zero-order-hold
        sampled system is: the OE(5, 5, 1) of §4.2).
    dt : float
        The new sampling step, s (a record's dx / speed).
    speed, dx : float, optional
        Towing speed (m/s) and spacing (m) of the new model (dx / speed must equal ``dt``).

    Returns
    -------
    APLModel
        Poles p' = p^(dt / T) (s = log(p) / T, the pole of the continuous form, z = exp(s dt)); zeros and gain from
        the state-space form: A' = A^(dt / T), B' = (A' - I)(A - I)^-1 B, C and D kept (zero-order-hold equivalence,
        exact both ways for a continuous system driven through a zero-order hold).

    Raises
    ------
    ModelError
        An unstable model, a pole on the negative real axis, at the origin or beyond :data:`MAX_POLE_FRACTION` of
        the Nyquist frequency at either step (the samples do not resolve it), a delay above 1 sample (a dead time).

    Notes
    -----
    ASSUMPTION: the model is the zero-order-hold discretisation of a linear time-invariant continuous system (the
    bench input held between samples); re-discretised for another towing speed it also assumes the trailer's
    dynamics in time do not depend on the speed (Table 1 of paper 000 shows 19-25 Hz damper frequencies across its
    configurations: within that spread, not better).
    """
    dt = require_positive("dt", dt)
    _check_resolved(model, dt / model.dt)
    return _rediscretised(model, dt, speed=speed, dx=dx)


def _realisation(model: APLModel):
    """(A, B, C, D) of ``model`` without its delay; for a delay of 1 sample the strictly proper form (A, B, C A^-1, 0)
    of H = z^-1 G (G(0) = 0: a zero at the origin), whose C is the output of the continuous state at the sample."""
    from ._deconvolution import instrument_state_space

    A, B, C, D = instrument_state_space(dataclasses.replace(model, delay=0))
    if model.delay == 1:
        C = np.linalg.solve(A.T, C.T).T
        D = np.zeros_like(D)
    return A, B, C, D


def _rediscretised(model: APLModel, dt: float, *, speed: float | None = None, dx: float | None = None) -> APLModel:
    """:func:`resample_model` without its checks (``model`` resolved at its own step; the new step may be coarse)."""
    from scipy import linalg, signal

    ratio = dt / model.dt
    A, B, C, D = _realisation(model)
    A2 = linalg.fractional_matrix_power(A, ratio)
    if np.abs(np.imag(A2)).max(initial=0.0) > 1e-9 * max(1.0, np.abs(A2).max()):
        raise ModelError("the model's state matrix has no real power (a pole on the negative real axis).")
    A2 = np.real(A2)
    eye = np.eye(A.shape[0])
    B2 = (A2 - eye) @ np.linalg.solve(A - eye, B)
    if model.delay == 1:  # back to z^-1 G': G' = z H' = (A', B', C A', C B')
        C, D = C @ A2, C @ B2
    zeros, _, gain = signal.ss2zpk(A2, B2, C, D)
    zeros = zeros[np.abs(zeros) > 1e-9]  # a zero at the origin is the factor (1 - 0 z^-1) = 1
    poles = model.poles ** ratio  # exactly exp(s dt), the principal branch (angles checked within +-pi/2)
    return APLModel(zeros=zeros, poles=poles, gain=float(np.real(gain)), delay=model.delay, dt=dt, speed=speed, dx=dx,
                    name=f"{model.name} (re-discretised from dt = {model.dt:.6g} s to {dt:.6g} s)")


def _check_resolved(model: APLModel, ratio: float) -> None:
    """Refuse a model whose continuous-time form is not determined by its samples, or not at the new step."""
    p = model.poles
    if not model.is_stable:
        raise ModelError(f"{model.name or 'the model'} is unstable (|p| up to {np.abs(p).max():.4g}); only a stable "
                         "model can be re-discretised.")
    if model.delay > 1:
        raise ModelError(f"{model.name or 'the model'} has a pure delay of {model.delay} samples (a dead time of "
                         f"{model.delay * model.dt:.6g} s): identify it with nk = 0 or 1 at the record's step.")
    if model.delay == 1 and model.zeros.size >= p.size:
        raise ModelError("a model with a delay of 1 sample and as many zeros as poles has a pole at the origin: it "
                         "cannot be re-discretised; identify it with nb <= na.")
    small = np.abs(p) < 1e-12
    angle = np.abs(np.angle(p[~small])) / np.pi
    worst = float(max(angle.max(initial=0.0), angle.max(initial=0.0) * ratio))
    if small.any() or worst > MAX_POLE_FRACTION:
        f = worst * 0.5 / model.dt / max(1.0, ratio)
        raise ModelError(f"{model.name or 'the model'} has a pole at the origin or on the negative real axis, or at "
                         f"{f:.4g} Hz, beyond {MAX_POLE_FRACTION:g} of the Nyquist frequency at a step of "
                         f"{model.dt * max(1.0, ratio):.6g} s: its samples do not resolve the dynamics (a pole on the "
                         "negative real axis is a sampling artefact, with no continuous-time form); identify the "
                         "trailer with fewer poles (e.g. road identify --orders 4 4 1) or at the record's step.")


def step_transitions(model: APLModel, dt) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The trailer's state-space matrices over steps of different durations (a record towed at a varying speed).

    Parameters
    ----------
    model : APLModel
        A discrete instrument resolved at its own step (delay 0 or 1; :func:`resample_model`'s conditions at its step).
    dt : (K,) array_like
        Duration of each step, s (> 0).

    Returns
    -------
    A : (K, n, n) ndarray
        A_k = A^(dt_k / T) = exp(A_c dt_k): the continuous-time form of ``model`` over each step, by the eigenvalues
        of A (its poles, raised to dt_k / T on the principal branch, as :func:`resample_model` does).
    B : (K, n, 1) ndarray
        B_k = (A_k - I)(A - I)^-1 B (zero-order hold over the step: the road held at the step's first station).
    C : (1, n) ndarray, D : (1, 1) ndarray
        Constant (the strictly proper form for a delay of 1 sample, :func:`resample_model`).

    Notes
    -----
    The steady state per unit level, (I - A_k)^-1 B_k = (I - A)^-1 B, is the same at every step, so a zero of the
    instrument at z = 1 (paper 000 eq. 1 has three) stays exact at every step. ASSUMPTION (as
    :func:`resample_model`): the trailer's dynamics in time do not depend on the towing speed.

    Raises
    ------
    ModelError
        ``model`` unresolved at its own step (:func:`resample_model`), or its poles repeated (eigenvectors
        ill-conditioned: condition number above 1e8).
    """
    _check_resolved(model, 1.0)
    dt = np.asarray(dt, dtype=float).reshape(-1)
    if np.any(~np.isfinite(dt) | (dt <= 0)):
        raise ModelError("every step of a record needs a finite, positive duration dt.")
    A, B, C, D = _realisation(model)
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) > 1e8:
        raise ModelError(f"{model.name or 'the model'} has repeated poles: its steps cannot be re-discretised one by "
                         "one (identify it with distinct poles).")
    powers = np.exp(np.log(lam.astype(complex))[None, :] * (dt / model.dt)[:, None])  # exp(s dt_k), principal branch
    Ak = np.real(np.einsum("ij,kj,jl->kil", V, powers, np.linalg.inv(V)))
    eye = np.eye(A.shape[0])
    Bk = (Ak - eye) @ np.linalg.solve(A - eye, B)
    return Ak, Bk, C, D
