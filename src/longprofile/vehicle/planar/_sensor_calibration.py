"""The gyro offset and the relative wheel radii from the drive log itself (issue 13; beyond paper 001).

Paper 001's estimators read the gyro as unbiased and every wheel with the car file's rolling radius, so a gyro
offset passes into r and a wheel-to-wheel radius spread fakes tyre slips, hence forces and grade
(docs/vehicle-slope.md, Calibration). A drive log reveals both, as an ESC calibrates its sensors while driving
(van Zanten, "Bosch ESP systems: 5 years of experience", SAE 2000-01-1633: gyro offset and relative wheel radii
learnt online from the wheel speeds). Each wheel's speed referred to the centre of gravity (eq. (18) solved for
V_x with the gyro r_g, as the V_x measurement does: ``kin_i``) reads, with a relative scale error e_i of its
speed (radius, tyre) and a gyro offset b_g (r_g = r + b_g),

    kin_i = V_x (1 + e_i) + b_g y_i + (the wheel's slip) + (terms common to both wheels of an axle),

y_i = +-S_b/2 the wheel's lateral position. On one axle the right minus the left wheel cancels V_x and the
common terms:

    kin_right - kin_left = (e_right - e_left) V_x - b_g S_b - tau S_b dr/dt + e_axle S_b r,

so a regression on [-S_b, V_x, -S_b dr/dt, S_b r] separates the gyro offset (a constant) from the wheels' relative
scale error (which grows with the speed); tau is the wheel speeds' lag against the gyro (the encoders' period
measurement, CAN latency), which a changing yaw rate otherwise turns into scatter, and e_axle the axle's mean
scale error, which scales the wheels' yaw part r y_i too (a nuisance parameter). On straight samples without
braking the front minus the rear axle mean, over V_x, is the front/rear scale difference plus the driven axle's
traction slip, sum F_x / (2 C_x0) with sum F_x = M a_x + C_x V_x |V_x| from the accelerometer; its offset makes
that difference uncertain by M sigma_a / (2 C_x0), the same confusion of a constant force error with the
accelerometer's offset as in :func:`~longprofile.vehicle.force_scale_fit`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ._params import P_CXA, Vehicle, default_vehicle
from ._regression import block_means, conjugate_regression
from ._simulate import DriveLog

__all__ = ["SensorCalibration", "calibrate_sensors", "CALIBRATION_MIN_BLOCKS"]

#: Fewest usable blocks per regression (an axle's left/right one, the front/rear one; at least 3 more than the
#: 4 coefficients of an axle, so that the Student-t variance factor dof/(dof - 2) is finite); fewer: that part keeps
#: its prior.
CALIBRATION_MIN_BLOCKS = 7
#: Samples enter the left/right regressions above this speed (m/s), with |a_y| below ``_MAX_LATERAL`` (m/s^2);
#: a driven axle's only where its modelled traction slip is below ``_MAX_SLIP``; the front/rear one only on
#: straights (|steer| and |r_g| below ``_STRAIGHT``, rad and rad/s).
_MIN_SPEED, _MAX_LATERAL, _MAX_SLIP, _STRAIGHT = 5.0, 4.0, 0.01, (0.02, 0.05)
#: Front share of the traction force per drivetrain.
_FRONT_SHARE = {"front": 1.0, "rear": 0.0, "all": 0.5}
#: Contrasts (d_rear, d_front, d_front_rear) -> wheel scale errors (FL, FR, RL, RR), the rear mean as reference.
_TO_WHEELS = np.array([[0.0, -0.5, 1.0], [0.0, 0.5, 1.0], [-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]])


@dataclass(frozen=True, eq=False)
class SensorCalibration:
    """The gyro offset and the wheels' relative scale errors found in a drive log (:func:`calibrate_sensors`).

    Attributes
    ----------
    gyro_offset : float
        Posterior mean of the gyro's offset b_g, rad/s (the gyro reads r + b_g).
    wheel_scale : (4,) ndarray
        Posterior means of each wheel speed's relative scale error e_i (FL, FR, RL, RR; the wheel reads
        (1 + e_i) times its speed with the car file's radius), relative to the rear axle's mean
        (e_RL + e_RR = 0: the common scale is not observable from the wheels and stays in
        ``SlopeUncertainty.radius_rel_std``).
    cov : (5, 5) ndarray
        Posterior covariance of (b_g, d_rear, d_front, d_front_rear, tau): the right-minus-left scale differences
        of the rear and the front axle, each relative to its axle's mean, the front axle's mean over the rear's
        minus 1, and the wheel speeds' lag against the gyro (s); the wheel scales are (1 + d_front_rear)
        (1 -+ d_front/2) - 1 at the front, -+ d_rear/2 at the rear. d_front_rear's variance includes the
        accelerometer offset's share (module docstring).
    lag : float
        Posterior mean of tau, s.
    prior_std : (4,) ndarray
        Prior stds of b_g (rad/s), of each wheel's scale error, of tau (s), and of the traction-slip model's
        relative error.
    residual_std : (3,) ndarray
        Std of the block means about the fit: rear and front right-minus-left (m/s), front/rear (relative);
        NaN for a part without enough blocks.
    n_blocks : (3,) ndarray of int
        Blocks used by the rear and front left/right regressions and the front/rear one (0: that part kept its
        prior).
    """

    gyro_offset: float
    wheel_scale: np.ndarray
    cov: np.ndarray
    lag: float
    prior_std: np.ndarray
    residual_std: np.ndarray
    n_blocks: np.ndarray

    @property
    def gyro_offset_std(self) -> float:
        """Posterior std of the gyro offset, rad/s."""
        return float(np.sqrt(self.cov[0, 0]))

    @property
    def wheel_scale_cov(self) -> np.ndarray:
        """(4, 4) posterior covariance of :attr:`wheel_scale` (first order in the scale errors)."""
        return _TO_WHEELS @ self.cov[1:4, 1:4] @ _TO_WHEELS.T

    @property
    def wheel_scale_std(self) -> np.ndarray:
        """(4,) posterior stds of :attr:`wheel_scale`."""
        return np.sqrt(np.diagonal(self.wheel_scale_cov))

    @property
    def front_rear_std(self) -> float:
        """Posterior std of the front-minus-rear axle scale difference: the wheels' fake slip that moves the
        tyre-force sum (``SlopeUncertainty`` Notes)."""
        return float(np.sqrt(self.cov[3, 3]))

    def corrected(self, log: DriveLog, *, front_rear: bool = True) -> DriveLog:
        """``log`` with the gyro offset subtracted and each wheel speed divided by (1 + its scale error).

        ``front_rear=False`` leaves the front axle's mean scale as it is (only its left/right difference is
        corrected): the front/rear difference is read against the accelerometer's traction force (module
        docstring), which a caller that trusts no accelerometer correction (``force_correction=False``) leaves out.
        """
        from dataclasses import replace

        scale = self.wheel_scale
        if not front_rear:
            scale = np.r_[(1.0 + scale[:2]) / (1.0 + 0.5 * (scale[0] + scale[1])) - 1.0, scale[2:]]
        return replace(log, yaw_rate=log.yaw_rate - self.gyro_offset, wheel_speeds=log.wheel_speeds / (1.0 + scale))


def calibrate_sensors(log: DriveLog, vehicle: Vehicle | None = None, *, gyro_prior_std: float = 5e-4,
                      wheel_prior_std: float = 5e-3, lag_prior_std: float = 0.05, accel_offset_std: float = 0.02,
                      slip_prior_std: float = 0.149, block: float = 1.0, skip: float = 1.0,
                      axle_prior_std: float | None = None) -> SensorCalibration:
    r"""Posterior of the gyro offset and the wheels' relative scale errors from the log (module docstring).

    Parameters
    ----------
    log : DriveLog
        Wheel speeds (rad/s), steering (rad), gyro (rad/s), accelerometers (m/s^2).
    vehicle : Vehicle, optional
        Radii, tracks, wheelbase, mass, drag, C_x0 and ``driven_axle`` (default :func:`default_vehicle`).
    gyro_prior_std : float
        Prior std of the gyro offset, rad/s (``SlopeUncertainty.gyro_offset_prior_std``).
    wheel_prior_std : float
        Prior std of each wheel's relative scale error before calibration
        (``SlopeUncertainty.wheel_scale_prior_std``, 0.5 %: tyre-to-tyre spread of wear and pressure); a difference
        of two wheels, or of two axle means, has sqrt(2) or 1 times this.
    lag_prior_std : float
        Prior std of the wheel speeds' lag against the gyro, s.
    accel_offset_std : float
        Std of the accelerometer's offset, m/s^2: the front/rear difference's share M sigma_a / (2 C_x0) is added
        to its posterior variance (it is not in the data).
    slip_prior_std : float
        Prior std of the traction-slip model's relative error (mass and tyre stiffness: hypot(0.05, 0.14)).
    block, skip : float
        Block length and start-up left out, s (as :func:`~longprofile.vehicle.force_scale_fit`).
    axle_prior_std : float, optional
        Prior std of an axle's mean scale error (the e_rear, e_front regressors of the yaw part r y_i): the common
        rolling radius error and the wheels' own spread, e.g. hypot(``SlopeUncertainty.radius_rel_std``,
        ``wheel_prior_std`` / sqrt(2)) as :func:`~longprofile.vehicle.estimate_slope` passes it; default
        ``wheel_prior_std`` (the calibration before 2026-12-06, which left the common radius out).

    Returns
    -------
    SensorCalibration

    Raises
    ------
    InputError
        For a log that is not a :class:`DriveLog`, or a prior, ``block`` or ``skip`` that is not finite and
        > 0 (``skip`` >= 0).

    Notes
    -----
    Samples: V_x >= 5 m/s, no service braking (sum F_x above ``-engine_brake_torque / R``), |a_y| <= 4 m/s^2;
    a driven axle's left/right pair only where its modelled traction slip is below 1 %; the front/rear
    difference only on straights (|steering| <= 0.02 rad, |r_g| <= 0.05 rad/s). Blocks of ``block`` seconds with
    at least half of their samples selected give one row each. The gyro offset comes from the rear axle, never
    steered (and undriven on a front-driven car): a conjugate regression (as
    :func:`~longprofile.vehicle.force_scale_fit`) of its right-minus-left block means on [-S_b, V_x, -S_b dr/dt,
    S_b r] for (b_g, d_rear, tau, e_rear), with the priors above (an axle mean's: ``wheel_prior_std``) and the
    least-squares residual variance times dof/(dof - 2) (the Student-t variance a variance from few blocks
    leaves). The steered front axle then gives d_front from z_f + S_b,f b_g on its own mean speed, with b_g's
    uncertainty carried over; the front/rear difference is a conjugate regression of (kin_F - kin_R)/V_x - lambda
    on [1, lambda], lambda the modelled traction slip difference.
    Assumptions (docs/vehicle-slope.md, Assumptions): one scale error per wheel and one gyro offset for the
    whole drive, one lag for all wheels, left and right wheels of a driven axle with equal traction slip
    (open differential, linear tyres), no rolling-radius change with load.
    """
    axle_prior_std = wheel_prior_std if axle_prior_std is None else axle_prior_std
    vehicle = _calibration_settings(log, vehicle, (gyro_prior_std, wheel_prior_std, lag_prior_std,
                                                   slip_prior_std, block, axle_prior_std), (accel_offset_std, skip))
    from scipy.ndimage import uniform_filter1d

    from ._speed_reference import _driven_radius, _wheel_kinematics

    T, dt = log.time.size, log.dt
    p = vehicle.as_array()
    kin = np.empty((T, 4))
    f_sum = np.empty(T)
    _wheel_kinematics(log.wheel_speeds, log.front_steering, log.yaw_rate, log.accel_x, log.accel_y, p, kin, f_sum)
    v = 0.5 * (kin[:, 2] + kin[:, 3])
    f_sum = f_sum + p[P_CXA] * v * np.abs(v)  # the tyre-force sum: accelerometer force plus the drag
    share = _FRONT_SHARE[vehicle.driven_axle]
    c_f, c_r = vehicle.longitudinal_stiffnesses
    slip = np.column_stack([share * f_sum / (2 * c_f), (1 - share) * f_sum / (2 * c_r)])  # front, rear axle
    base = (v >= _MIN_SPEED) & (f_sum >= -vehicle.engine_brake_torque / _driven_radius(vehicle)) \
        & (np.abs(log.accel_y) <= _MAX_LATERAL)
    rdot = np.gradient(uniform_filter1d(log.yaw_rate, max(int(round(0.05 / dt)), 1), mode="nearest"), dt)
    n = max(int(round(block / dt)), 1)
    start = min(int(round(skip / dt)), T)
    resid, counts = np.full(3, np.nan), [0, 0, 0]
    mean, cov = _left_right(kin, v, log.yaw_rate, rdot, base, slip, vehicle.tracks, n, start, resid, counts,
                            (gyro_prior_std, math.sqrt(2) * wheel_prior_std, lag_prior_std, axle_prior_std))
    per_accel = accel_offset_std * (share / (2 * c_f) - (1 - share) / (2 * c_r))
    mean[3], cov[3, 3], resid[2], counts[2] = _front_rear(kin, v, slip, base, log, vehicle, n, start, wheel_prior_std,
                                                          slip_prior_std, per_accel)
    d_r, d_f, d_fr = mean[1:4]
    scale = np.array([(1 + d_fr) * (1 - d_f / 2), (1 + d_fr) * (1 + d_f / 2), 1 - d_r / 2, 1 + d_r / 2]) - 1
    return SensorCalibration(gyro_offset=float(mean[0]), wheel_scale=scale, cov=cov,
                             lag=float(mean[4]), prior_std=np.array([gyro_prior_std, wheel_prior_std, lag_prior_std,
                                                                     slip_prior_std]),
                             residual_std=resid, n_blocks=np.array(counts))


def _left_right(kin, v, yaw, rdot, base, slip, tracks, n, start, resid, counts, prior):
    """Posterior mean (5,) and covariance (5, 5) of (b_g, d_rear, d_front, ., tau) from both axles' right-minus-left
    wheel speeds (index 3, the front/rear difference, left 0); fills ``resid[:2]`` and ``counts[:2]``. ``prior``:
    the stds of b_g, of a left/right difference, of tau and of an axle's mean scale error."""
    b_f, b_r = tracks
    sg, sd, st, se = prior
    mean, cov = np.zeros(5), np.zeros((5, 5))
    rear = [0, 1, 4]
    cov[rear, rear] = np.array([sg, sd, st]) ** 2
    cov[2, 2] = sd ** 2
    # the rear axle (never steered; not driven on a front-driven car): (b_g, d_rear, tau, e_rear)
    z, A = _axle_rows(kin[:, 3] - kin[:, 2], v, yaw, rdot, base & (np.abs(slip[:, 1]) <= _MAX_SLIP), b_r, n, start)
    if z.size >= CALIBRATION_MIN_BLOCKS:
        X = np.column_stack([np.full(z.size, -b_r), A])
        resid[0], s2 = _student_var(X, z)
        m, c, _ = conjugate_regression(X, z, [sg, sd, st, se], noise_var=s2)
        mean[rear], cov[np.ix_(rear, rear)], counts[0] = m[:3], c[:3, :3], z.size
    # the front axle given the rear's gyro offset: (d_front, tau_front, e_front) of z_f + S_b,f b_g, regressed on
    # the front axle's own mean speed; d_front moves with b_g by g = d(d_front)/d(b_g), which carries b_g's
    # uncertainty into it
    z, A = _axle_rows(kin[:, 1] - kin[:, 0], 0.5 * (kin[:, 0] + kin[:, 1]), yaw, rdot,
                      base & (np.abs(slip[:, 0]) <= _MAX_SLIP), b_f, n, start)
    if z.size >= CALIBRATION_MIN_BLOCKS:
        resid[1], s2 = _student_var(A, z + b_f * mean[0])
        m, c, _ = conjugate_regression(A, z + b_f * mean[0], [sd, st, se], noise_var=s2)
        g = float((c @ A.T @ np.full(z.size, b_f))[0]) / s2
        mean[2], counts[1] = m[0], z.size
        cov[2, rear] = cov[rear, 2] = g * cov[0, rear]
        cov[2, 2] = c[0, 0] + g * g * cov[0, 0]
    return mean, cov


def _axle_rows(diff, v, yaw, rdot, mask, track, n, start):
    """One axle's block rows: the right-minus-left ``diff`` (nb,) and its regressors [V_x, -S_b dr/dt, S_b r]
    (nb, 3) of the blocks with enough selected samples."""
    z, vb, rdb, rb = (block_means(a, n, start, mask) for a in (diff, v, rdot, yaw))
    ok = np.isfinite(z)
    return z[ok], np.column_stack([vb[ok], -track * rdb[ok], track * rb[ok]])


def _student_var(X, y):
    """(plug-in residual std of the least-squares fit, its variance times dof/(dof - 2)): the Student-t variance
    that a residual variance estimated from few blocks leaves."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    dof = y.size - X.shape[1]
    s2 = max(float(np.sum((y - X @ coef) ** 2)) / dof, 1e-30)
    return math.sqrt(s2), s2 * dof / (dof - 2)


def _front_rear(kin, v, slip, base, log, vehicle, n, start, wheel_prior_std, slip_prior_std, offset_per_accel):
    """(mean, variance, residual std, blocks) of the front-minus-rear scale difference from straight samples:
    (kin_F - kin_R)/V_x - lambda = d + k lambda, lambda = traction slip front minus rear (k: its model's relative
    error); the accelerometer offset's share (``offset_per_accel`` * M * sigma_a) is added to the variance."""
    straight = base & (np.abs(log.front_steering).max(axis=1) <= _STRAIGHT[0]) & (np.abs(log.yaw_rate) <= _STRAIGHT[1])
    lam = slip[:, 0] - slip[:, 1]
    ratio = (0.5 * (kin[:, 0] + kin[:, 1]) - v) / np.maximum(v, _MIN_SPEED) - lam
    yb, lb = block_means(ratio, n, start, straight), block_means(lam, n, start, straight)
    ok = np.isfinite(yb)
    if ok.sum() < CALIBRATION_MIN_BLOCKS:
        return 0.0, wheel_prior_std ** 2, float("nan"), 0
    mean, cov, s2 = conjugate_regression(np.column_stack([np.ones(ok.sum()), lb[ok]]), yb[ok],
                                         [wheel_prior_std, slip_prior_std])
    return float(mean[0]), float(cov[0, 0]) + (vehicle.mass * offset_per_accel) ** 2, math.sqrt(s2), int(ok.sum())


def _calibration_settings(log, vehicle, positive, non_negative) -> Vehicle:
    """calibrate_sensors' arguments checked; returns the vehicle (default :func:`default_vehicle`)."""
    if not isinstance(log, DriveLog):
        raise InputError(f"log must be a DriveLog; got {type(log).__name__}.")
    vehicle = default_vehicle() if vehicle is None else vehicle
    if not isinstance(vehicle, Vehicle):
        raise InputError(f"vehicle must be a Vehicle; got {type(vehicle).__name__}.")
    ok = all(isinstance(x, (int, float)) and math.isfinite(x) for x in positive + non_negative)
    if not (ok and all(x > 0 for x in positive) and all(x >= 0 for x in non_negative)):
        raise InputError("gyro_prior_std, wheel_prior_std, lag_prior_std, slip_prior_std, block and axle_prior_std "
                         "must be finite and "
                         f"> 0, accel_offset_std and skip finite and >= 0; got {positive + non_negative!r}.")
    return vehicle
