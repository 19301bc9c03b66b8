"""Maximum-likelihood fitting: against statsmodels' UnobservedComponents and coverage of the truth."""

import numpy as np
import pytest

from longprofile.errors import ConvergenceError, InputError, ModelError, ShapeError
from longprofile.statespace import MLEResult, StateSpaceModel, fit_mle

Q_TRUE, R_TRUE = 0.5, 2.0


def local_level(theta):
    """Random walk plus noise: x[k+1] = x[k] + w (var q), y = x + v (var r); near-diffuse prior."""
    q, r = theta
    if q < 0 or r <= 0:
        raise ModelError(f"variances must be >= 0 / > 0; got q={q}, r={r}")
    return StateSpaceModel(np.eye(1), np.eye(1), np.array([[q]]), np.array([[r]]), np.zeros(1), np.array([[1e7]]))


def simulate(T=400, seed=0, q=Q_TRUE, r=R_TRUE):
    rng = np.random.default_rng(seed)
    level = np.cumsum(rng.normal(0.0, np.sqrt(q), T))
    return level + rng.normal(0.0, np.sqrt(r), T)


def test_local_level_matches_statsmodels_unobserved_components():
    import statsmodels.api as sm

    y = simulate()
    ours = fit_mle(local_level, y, [1.0, 1.0], bounds=[(1e-8, None)] * 2, param_names=["q", "r"])
    assert isinstance(ours, MLEResult) and ours.converged
    ref = sm.tsa.UnobservedComponents(y, "llevel").fit(disp=False, cov_type="approx")
    # statsmodels orders (sigma2.irregular, sigma2.level) = (r, q)
    np.testing.assert_allclose(ours.params, ref.params[::-1], rtol=1e-3)
    np.testing.assert_allclose(ours.std_errors, ref.bse[::-1], rtol=2e-2)
    assert ours.param_names == ("q", "r")
    assert ours.n_observed == 400
    assert ours.aic == pytest.approx(4.0 - 2.0 * ours.log_likelihood)
    assert ours.bic == pytest.approx(2.0 * np.log(400) - 2.0 * ours.log_likelihood)
    np.testing.assert_allclose(np.sqrt(np.diag(ours.cov)), ours.std_errors)


@pytest.mark.parametrize("seed", [1, 2])
def test_truth_within_three_standard_errors_and_missing_data(seed):
    y = simulate(T=500, seed=seed)
    y[100:110] = np.nan  # a gap: only observed samples count
    res = fit_mle(local_level, y, [0.2, 5.0], bounds=[(1e-8, None)] * 2, method="L-BFGS-B")
    assert res.n_observed == 490
    assert np.all(np.abs(res.params - [Q_TRUE, R_TRUE]) < 3.0 * res.std_errors)
    # a derivative-free method lands on the same optimum
    nm = fit_mle(local_level, y, [0.2, 5.0], method="Nelder-Mead", options={"xatol": 1e-8, "fatol": 1e-10})
    np.testing.assert_allclose(nm.params, res.params, rtol=1e-3)


def test_parameter_at_bound_has_undefined_standard_error():
    y = simulate(T=300, seed=3, q=0.0)  # no level noise: q's MLE sits on its lower bound
    res = fit_mle(local_level, y, [0.5, 1.0], bounds=[(0.0, None), (1e-8, None)], param_names=["q", "r"])
    assert np.isnan(res.std_errors[0]) and np.isfinite(res.std_errors[1])
    assert "at a bound" in res.message and "q" in res.message


def test_failures_raise():
    y = simulate(T=200, seed=4)
    with pytest.raises(ConvergenceError, match="did not converge") as info:
        fit_mle(local_level, y, [5.0, 0.1], bounds=[(1e-8, None)] * 2, options={"maxiter": 1})
    assert info.value.result.converged is False
    with pytest.raises(InputError, match="not finite at theta0"):
        fit_mle(local_level, y, [-1.0, 1.0])
    with pytest.raises(InputError, match="within bounds"):
        fit_mle(local_level, y, [1.0, 1.0], bounds=[(2.0, None), (None, None)])
    with pytest.raises(ShapeError, match="one name per parameter"):
        fit_mle(local_level, y, [1.0, 1.0], param_names=["q"])
