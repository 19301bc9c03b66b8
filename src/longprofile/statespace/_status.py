"""Status codes of the compiled loops and the one place that turns them into exceptions (private).

A kernel cannot raise with a message, so it stops, writes a :class:`KernelStatus` code (and the step,
and for batches the series) into a small int64 array and returns; the wrapper then calls
:func:`raise_status`. The plain-int aliases below are what the kernels use (numba freezes them as
integer constants, exactly like the literals they replace).
"""

from __future__ import annotations

from enum import IntEnum

from ..errors import ModelError

__all__ = ["KernelStatus", "OK", "NOT_PD", "TRANSITION_NOT_FINITE", "OBSERVATION_NOT_FINITE",
           "COVARIANCE_NOT_FINITE", "status_error", "raise_status"]


class KernelStatus(IntEnum):
    """Why a compiled filter loop stopped (0 = it did not)."""

    OK = 0
    #: The innovation covariance S = H P H' + R is not positive definite (Cholesky failed).
    NOT_PD = 1
    #: f (or its Jacobian) returned non-finite values.
    TRANSITION_NOT_FINITE = 2
    #: h (or its Jacobian, or the innovation) is non-finite.
    OBSERVATION_NOT_FINITE = 3
    #: The predicted covariance F P F' + Q became non-finite.
    COVARIANCE_NOT_FINITE = 4


OK = int(KernelStatus.OK)
NOT_PD = int(KernelStatus.NOT_PD)
TRANSITION_NOT_FINITE = int(KernelStatus.TRANSITION_NOT_FINITE)
OBSERVATION_NOT_FINITE = int(KernelStatus.OBSERVATION_NOT_FINITE)
COVARIANCE_NOT_FINITE = int(KernelStatus.COVARIANCE_NOT_FINITE)

_KALMAN_NOT_PD = ("the innovation covariance H P H' + R is not positive definite at {where}; obs_cov (R) must be "
                  "positive definite on the observed components (or the predicted state covariance must make "
                  "H P H' positive definite there). Check R and the data.")
_EKF_MESSAGES = {
    KernelStatus.NOT_PD: "innovation covariance is not positive definite at step {k}; obs_cov (R) must be positive "
                         "definite on the observed components (or the covariance has lost definiteness: check Q, R).",
    KernelStatus.TRANSITION_NOT_FINITE: "transition_fn or its Jacobian returned non-finite values at step {k}.",
    KernelStatus.OBSERVATION_NOT_FINITE: "observation_fn or its Jacobian returned non-finite values at step {k}.",
    KernelStatus.COVARIANCE_NOT_FINITE: "the predicted covariance became non-finite at step {k} -> {k1}: the "
                                        "transition Jacobian is huge or the filter diverged; check transition_fn / "
                                        "transition_jacobian and the scaling of the states.",
}
_MESSAGES = {
    "kalman": {KernelStatus.NOT_PD: _KALMAN_NOT_PD},
    "ekf": _EKF_MESSAGES,
    "block_ekf": {**_EKF_MESSAGES, KernelStatus.NOT_PD: "innovation covariance of a block is not positive definite "
                                                        "at step {k}; check R and Q."},
}


def status_error(status, step, kind: str, series=None) -> ModelError | None:
    """The exception for a kernel's ``status`` at ``step`` (None when OK).

    ``kind`` is the loop that stopped: ``"kalman"`` (linear filter; ``series`` = index in the batch, or
    None when the input was not batched), ``"ekf"`` or ``"block_ekf"``.
    """
    code = KernelStatus(int(status))
    if code is KernelStatus.OK:
        return None
    k = int(step)
    where = f"step {k}" + (f" of series {series}" if series is not None else "")
    template = _MESSAGES[kind].get(code)
    if template is None:  # pragma: no cover - a kernel wrote a code its wrapper does not expect
        return ModelError(f"compiled {kind} loop stopped with status {code.name} at {where}.")
    return ModelError(template.format(k=k, k1=k + 1, where=where))


def raise_status(status, step, kind: str, series=None) -> None:
    """Raise :func:`status_error` unless ``status`` is OK."""
    err = status_error(status, step, kind, series)
    if err is not None:
        raise err
