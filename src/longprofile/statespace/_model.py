"""The linear-Gaussian state-space model (frozen data, validated once)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .._validation import as_float_array, require_symmetric_psd
from ..errors import ShapeError

__all__ = ["StateSpaceModel"]

# (field name, letter, base rank, side): side "transition" terms are per-step of length T-1,
# "observation" terms of length T.
_MATRIX_FIELDS = (
    ("transition", "F", 2, "transition"),
    ("observation", "H", 2, "observation"),
    ("process_cov", "Q", 2, "transition"),
    ("obs_cov", "R", 2, "observation"),
    ("input_transition", "B", 2, "transition"),
    ("input_observation", "D", 2, "observation"),
    ("state_offset", "c", 1, "transition"),
    ("obs_offset", "d", 1, "observation"),
)


@dataclass(frozen=True, eq=False)
class StateSpaceModel:
    r"""Linear-Gaussian state-space model.

    .. math::

        x_0 &\sim \mathcal N(x_0^-, P_0^-) \\
        x_{k+1} &= F_k x_k + B_k u_k + c_k + w_k, \qquad w_k \sim \mathcal N(0, Q_k) \\
        y_k &= H_k x_k + D_k u_k + d_k + v_k, \qquad v_k \sim \mathcal N(0, R_k)

    Parameters
    ----------
    transition : (n, n) or (T-1, n, n) array_like
        F. A 3-D array is time-varying: ``transition[k]`` maps step k to k+1.
    observation : (m, n) or (T, m, n) array_like
        H. A 3-D array is time-varying: ``observation[k]`` applies to ``y[k]``.
    process_cov : (n, n) or (T-1, n, n) array_like
        Q, symmetric positive semi-definite.
    obs_cov : (m, m) or (T, m, m) array_like
        R, symmetric positive semi-definite (positive definite on the observed rows).
    initial_mean : (n,) array_like
        Prior mean of the state at the first sample, before ``y[0]`` is seen.
    initial_cov : (n, n) array_like
        Prior covariance of the state at the first sample.
    input_transition : (n, p) or (T-1, n, p) array_like, optional
        B, multiplies the known input ``u``.
    input_observation : (m, p) or (T, m, p) array_like, optional
        D, feed-through of the known input.
    state_offset : (n,) or (T-1, n) array_like, optional
        c, a known additive term in the transition.
    obs_offset : (m,) or (T, m) array_like, optional
        d, a known additive term in the observation.
    check_psd : bool, default True
        Check that Q, R and P0 are symmetric positive semi-definite (an eigenvalue
        decomposition per matrix and step). Shapes and finiteness are always
        checked. Pass False only for terms that are PSD by construction, e.g. a
        model rebuilt hundreds of times in a likelihood search whose covariances
        are positive multiples of fixed Gram matrices (like scipy.linalg's
        ``check_finite=False``: a speed option for callers that know).

    Notes
    -----
    The rule for time variation is never a guess: a term is constant when it has
    its base rank (2 for matrices, 1 for offsets) and time-varying when it has
    exactly one extra leading axis, of length T-1 for transition-side terms
    (F, Q, B, c) and T for observation-side terms (H, R, D, d). The lengths are
    checked against the data when a filter runs.

    Glossary (ours -> textbook / statsmodels / dynamax): transition F / T /
    dynamics.weights; observation H / Z (design) / emissions.weights;
    process_cov Q / R Q R' (state_cov) / dynamics.cov; obs_cov R / H (obs_cov) /
    emissions.cov.
    """

    transition: np.ndarray
    observation: np.ndarray
    process_cov: np.ndarray
    obs_cov: np.ndarray
    initial_mean: np.ndarray
    initial_cov: np.ndarray
    input_transition: np.ndarray | None = None
    input_observation: np.ndarray | None = None
    state_offset: np.ndarray | None = None
    obs_offset: np.ndarray | None = None
    check_psd: bool = field(default=True, repr=False)

    def __post_init__(self):
        conv = {}
        for name, letter, base, _side in _MATRIX_FIELDS:
            val = getattr(self, name)
            if val is None:
                continue
            arr = as_float_array(f"{name} ({letter})", val, ndim=(base, base + 1), allow_nan=False)
            conv[name] = arr
        x0 = as_float_array("initial_mean", self.initial_mean, ndim=1, allow_nan=False)
        P0 = as_float_array("initial_cov", self.initial_cov, ndim=2, allow_nan=False)
        conv["initial_mean"], conv["initial_cov"] = x0, P0
        for k, v in conv.items():
            v = np.ascontiguousarray(v)
            v.setflags(write=False)
            object.__setattr__(self, k, v)

        n = x0.shape[0]
        F, H = self.transition, self.observation
        m = H.shape[-2]
        self._expect("transition (F)", F, (n, n))
        self._expect("observation (H)", H, (m, n))
        self._expect("process_cov (Q)", self.process_cov, (n, n))
        self._expect("obs_cov (R)", self.obs_cov, (m, m))
        self._expect("initial_cov (P0)", P0, (n, n), allow_tv=False)
        B, D = self.input_transition, self.input_observation
        p = None
        if B is not None:
            p = B.shape[-1]
            self._expect("input_transition (B)", B, (n, p))
        if D is not None:
            if p is not None and D.shape[-1] != p:
                raise ShapeError(f"input_observation (D) must have {p} columns like input_transition (B); "
                                 f"got shape {D.shape}.")
            p = D.shape[-1]
            self._expect("input_observation (D)", D, (m, p))
        if self.state_offset is not None:
            self._expect("state_offset (c)", self.state_offset, (n,))
        if self.obs_offset is not None:
            self._expect("obs_offset (d)", self.obs_offset, (m,))
        if self.check_psd:
            require_symmetric_psd("process_cov (Q)", self.process_cov)
            require_symmetric_psd("obs_cov (R)", self.obs_cov)
            require_symmetric_psd("initial_cov (P0)", P0)

    @staticmethod
    def _expect(name, arr, base_shape, allow_tv=True):
        if arr.shape[-len(base_shape):] != base_shape or (arr.ndim > len(base_shape) and not allow_tv):
            want = f"{base_shape}" + (f" or (T, *{base_shape})" if allow_tv else "")
            raise ShapeError(f"{name} must have shape {want}; got {arr.shape}.")

    # ------------------------------------------------------------------ sizes
    @property
    def n_states(self) -> int:
        """Number of states n."""
        return self.initial_mean.shape[0]

    @property
    def n_obs(self) -> int:
        """Number of observations m per step."""
        return self.observation.shape[-2]

    @property
    def n_inputs(self) -> int:
        """Number of known inputs p (0 without inputs)."""
        for arr in (self.input_transition, self.input_observation):
            if arr is not None:
                return arr.shape[-1]
        return 0

    def is_time_varying(self) -> bool:
        """True if any term has a leading time axis."""
        for name, _l, base, _s in _MATRIX_FIELDS:
            arr = getattr(self, name)
            if arr is not None and arr.ndim > base:
                return True
        return False

    def check_length(self, n_steps: int) -> None:
        """Check that time-varying terms match a series of ``n_steps`` samples.

        Raises :class:`~longprofile.errors.ShapeError` naming the first term whose
        leading axis is not T-1 (transition side) or T (observation side).
        """
        for name, letter, base, side in _MATRIX_FIELDS:
            arr = getattr(self, name)
            if arr is None or arr.ndim == base:
                continue
            want = n_steps - 1 if side == "transition" else n_steps
            if arr.shape[0] != want:
                raise ShapeError(
                    f"{name} ({letter}) is time-varying with {arr.shape[0]} steps, but the data have T = {n_steps} "
                    f"samples: {side}-side terms need {want} steps "
                    f"({'T-1: term k maps step k to k+1' if side == 'transition' else 'T: one per sample'}).")

    def replace(self, **changes) -> "StateSpaceModel":
        """Return a copy with some fields replaced (the model itself is immutable)."""
        return replace(self, **changes)

    # helpers used by the reference implementations and the kernels' wrappers
    def at(self, name: str, k: int):
        """Term ``name`` at step ``k`` (constant terms ignore ``k``); None if absent."""
        arr = getattr(self, name)
        if arr is None:
            return None
        base = next(b for f, _l, b, _s in _MATRIX_FIELDS if f == name)
        return arr[k] if arr.ndim > base else arr
