"""The kernels of the planar model (paper 001, eq. (11)-(19)) composed from ._equations agree with each other.

planar_rates_fast is the value part of planar_fused bit for bit (same per-wheel function, derivatives left out);
planar_fused and planar_rates_jac (the simulator's kernels: trigonometric slip angle, the paper's body sums)
agree to round-off, and their Jacobians agree with central differences; forces_fused gives the simulator's tyre
forces and, with the wheel-speed noise off, the delta-method std of F_res from planar_fused's Jacobian row.
"""

import numpy as np
import pytest

from longprofile.vehicle import default_vehicle
from longprofile.vehicle.planar._model import (
    ekf_next,
    ekf_step,
    forces_fused,
    normal_loads,
    planar_fused,
    planar_rates_fast,
    planar_rates_jac,
    tyre_kinematics_forces,
)
from longprofile.vehicle.planar._params import P_G, P_R_F, P_R_R

CAR = default_vehicle()
CARS = {
    "default": CAR,
    "heavier": CAR.with_changes(mass=CAR.mass * 1.1),
    "staggered": CAR.with_changes(track=(1.58, 1.60), wheel_radius=(0.30, 0.309),
                                  longitudinal_stiffness=(60000.0, 70000.0), cornering_stiffness=(50000.0, 65000.0)),
}


def _cases(p, n, seed, *, steer_lr, mu):
    """n random operating points (x, u, slope): slips of +-20 %, both Dugoff branches, equal or separate front angles."""
    rng = np.random.default_rng(seed)
    X = np.column_stack([rng.uniform(3.0, 40.0, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-0.5, 0.5, n)])
    U = np.zeros((n, 13))
    U[:, 0] = rng.uniform(-0.25, 0.25, n)
    U[:, 12] = U[:, 0] + (rng.uniform(-0.03, 0.03, n) if steer_lr else 0.0)
    for i in range(4):
        U[:, 1 + i] = X[:, 0] * (1.0 + rng.uniform(-0.2, 0.2, n)) / p[P_R_F if i < 2 else P_R_R]
    U[:, 5] = rng.uniform(-7.0, 7.0, n)
    U[:, 6] = rng.uniform(-7.0, 7.0, n)
    U[:, 8:12] = mu * rng.uniform(0.3, 1.0, (n, 4))
    return X, U, rng.uniform(-0.15, 0.15, n)


@pytest.mark.parametrize("name", sorted(CARS))
@pytest.mark.parametrize("steer_lr", [False, True])
def test_value_only_kernel_is_the_value_part_of_the_fused_step_bit_for_bit(name, steer_lr):
    p = CARS[name].as_array()
    X, U, S = _cases(p, 400, 1, steer_lr=steer_lr, mu=1.0)
    fast = np.array([planar_rates_fast(x[0], x[1], x[2], u, p, s) for x, u, s in zip(X, U, S)])
    fused = np.array([planar_fused(x[0], x[1], x[2], u, p, s)[:3] for x, u, s in zip(X, U, S)])
    assert np.isfinite(fast).all()
    assert fast.tobytes() == fused.tobytes()
    # the EKF's f and its fused step: the same Euler step
    out, F = np.empty(3), np.empty((3, 3))
    for x, u in zip(X[:50], U[:50]):
        u = u.copy()
        ekf_step(x, u, p, 1e-3, out, F)
        assert out.tobytes() == ekf_next(x, u, p, 1e-3).tobytes()


def _fd_rates(p, x, u, s, h=1e-6):
    """Central differences of planar_rates_fast w.r.t. (V_x, V_y, r, slope): (3, 4)."""
    z = np.append(x, s)
    cols = []
    for j in range(4):
        e = np.zeros(4)
        e[j] = h * max(1.0, abs(z[j]))
        hi = np.array(planar_rates_fast(*(z + e)[:3], u, p, (z + e)[3]))
        lo = np.array(planar_rates_fast(*(z - e)[:3], u, p, (z - e)[3]))
        cols.append((hi - lo) / (2.0 * e[j]))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("name", sorted(CARS))
@pytest.mark.parametrize("steer_lr,mu", [(False, 1.0), (True, 1.0), (False, 0.3)])
def test_fused_step_and_simulator_kernels_agree_and_match_finite_differences(name, steer_lr, mu):
    p = CARS[name].as_array()
    X, U, S = _cases(p, 150, 2, steer_lr=steer_lr, mu=mu)
    for x, u, s in zip(X, U, S):
        r = np.array(planar_fused(x[0], x[1], x[2], u, p, s))
        jac_f = np.column_stack([r[3:12].reshape(3, 3), r[12:15]])
        xdot, jac, dslope = np.empty(3), np.empty((3, 3)), np.empty(3)
        planar_rates_jac(x, u, p, s, xdot, jac, dslope)
        # two numerical forms (rational vs trigonometric slip angle, per-wheel vs paper body sums): round-off apart
        scale = np.abs(r[:3]).max() + 1.0
        np.testing.assert_allclose(xdot, r[:3], rtol=0, atol=1e-10 * scale)
        jscale = np.abs(jac_f).max() + 1.0
        np.testing.assert_allclose(np.column_stack([jac, dslope]), jac_f, rtol=0, atol=1e-9 * jscale)
        np.testing.assert_allclose(jac_f, _fd_rates(p, x, u, s), rtol=0, atol=2e-5 * jscale)


@pytest.mark.parametrize("name", sorted(CARS))
@pytest.mark.parametrize("steer_lr", [False, True])
def test_forces_kernel_matches_simulator_tyre_forces_and_the_fused_jacobian(name, steer_lr):
    p = CARS[name].as_array()
    n = 200
    X, U, S = _cases(p, n, 3, steer_lr=steer_lr, mu=0.8)
    rng = np.random.default_rng(4)
    A = rng.normal(size=(n, 4, 4)) * 0.05
    cov = A @ A.transpose(0, 2, 1) + 1e-6 * np.eye(4)
    mean = np.column_stack([X, S])
    fx, fy, fx_std, fy_std = (np.empty((n, 4)) for _ in range(4))
    mass = CARS[name].mass
    for k in range(n):
        x, u, s = X[k], U[k], S[k]
        res, res_std = forces_fused(mean, cov, U, p, S, 0.0, fx, fy, fx_std, fy_std, k)
        fn = np.empty(4)
        normal_loads(p, u[5], u[6], s, fn)
        out = [np.empty(4) for _ in range(4)]
        dfx, dfy, dfn, dfw = np.empty((4, 3)), np.empty((4, 3)), np.empty((2, 4)), np.empty((2, 4))
        tyre_kinematics_forces(x[0], x[1], x[2], u[0], u[12], u[1:5].copy(), fn, u[8:12].copy(), p, *out,
                               dfx, dfy, dfn, dfw)
        fscale = np.abs(out[2:]).max() + 1.0
        np.testing.assert_allclose(fx[k], out[2], rtol=0, atol=1e-11 * fscale)
        np.testing.assert_allclose(fy[k], out[3], rtol=0, atol=1e-11 * fscale)
        # delta method with the wheel-speed noise off: Var F_res = g' C g, g = M d(dV_x/dt)/d(V_x, V_y, r)
        r = np.array(planar_fused(x[0], x[1], x[2], u, p, s))
        g = mass * r[3:6]
        # eq. (21) against eq. (11): F_res / M = dV_x/dt + g sin(theta)
        np.testing.assert_allclose(res / mass, r[0] + p[P_G] * np.sin(s), rtol=0, atol=1e-10 * (abs(r[0]) + 10.0))
        np.testing.assert_allclose(res_std, np.sqrt(g @ cov[k, :3, :3] @ g), rtol=1e-9)
        # per-wheel stds: the force gradients of the simulator's kernel in the same quadratic form
        for i in range(4):
            np.testing.assert_allclose(fx_std[k, i], np.sqrt(dfx[i] @ cov[k, :3, :3] @ dfx[i]), rtol=1e-8)
            np.testing.assert_allclose(fy_std[k, i], np.sqrt(dfy[i] @ cov[k, :3, :3] @ dfy[i]), rtol=1e-8)
