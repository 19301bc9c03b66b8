"""Random stable models and data for the state-space engine tests (shared helpers, not tests)."""

from __future__ import annotations

import numpy as np

from longprofile.statespace import StateSpaceModel


def random_spd(rng, k, floor=0.2):
    a = rng.normal(size=(k, k))
    return a @ a.T / k + floor * np.eye(k)


def random_stable(rng, n, radius=0.9):
    a = rng.normal(size=(n, n))
    return radius * a / max(np.max(np.abs(np.linalg.eigvals(a))), 1e-12)


def random_model(rng, n, m, T, *, tv=False, tv_cov=False, offsets=False, tv_offsets=False, p=0):
    """A random stable model; ``tv`` makes F and H time-varying, ``tv_cov`` Q and R, ``p`` adds inputs."""
    if tv:
        F = np.stack([random_stable(rng, n) for _ in range(T - 1)])
        H = rng.normal(size=(T, m, n))
    else:
        F = random_stable(rng, n)
        H = rng.normal(size=(m, n))
    if tv_cov:
        Q = np.stack([random_spd(rng, n) for _ in range(T - 1)])
        R = np.stack([random_spd(rng, m) for _ in range(T)])
    else:
        Q, R = random_spd(rng, n), random_spd(rng, m)
    kw = {}
    if offsets:
        kw["state_offset"] = rng.normal(size=(T - 1, n) if tv_offsets else n)
        kw["obs_offset"] = rng.normal(size=(T, m) if tv_offsets else m)
    if p:
        kw["input_transition"] = rng.normal(size=(n, p))
        kw["input_observation"] = rng.normal(size=(m, p))
    return StateSpaceModel(F, H, Q, R, rng.normal(size=n), random_spd(rng, n, 0.5), **kw)


def _gauss(rng, cov):
    w, V = np.linalg.eigh(cov)
    return V @ (np.sqrt(np.clip(w, 0.0, None)) * rng.standard_normal(len(w)))


def draw(model, T, rng, u=None):
    """Draw (x, y) with a plain loop (independent of the library's simulator)."""
    n, m = model.n_states, model.n_obs
    x = np.empty((T, n))
    y = np.empty((T, m))
    x[0] = model.initial_mean + _gauss(rng, model.initial_cov)
    for k in range(T):
        yk = model.at("observation", k) @ x[k] + _gauss(rng, model.at("obs_cov", k))
        if model.input_observation is not None:
            yk = yk + model.at("input_observation", k) @ u[k]
        if model.obs_offset is not None:
            yk = yk + model.at("obs_offset", k)
        y[k] = yk
        if k < T - 1:
            xk = model.at("transition", k) @ x[k] + _gauss(rng, model.at("process_cov", k))
            if model.input_transition is not None:
                xk = xk + model.at("input_transition", k) @ u[k]
            if model.state_offset is not None:
                xk = xk + model.at("state_offset", k)
            x[k + 1] = xk
    return x, y
