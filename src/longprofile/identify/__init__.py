"""System identification of polynomial input-output models (generic, not APL-specific).

fit_arx           -- least-squares ARX model A y = B u + e.
fit_output_error  -- output-error model y = B/F u + e by prediction-error ML (Gauss-Newton).
fit_armax         -- ARMAX model A y = B u + C e by prediction-error ML (Gauss-Newton).
simulate_model    -- noise-free simulation B/A u of an identified model.
step_response     -- unit-step response of an identified model.
IdentifiedModel   -- frozen result: polynomials, covariance, residual std, fits, roots, flags.
"""

from ._polynomial import IdentifiedModel, fit_armax, fit_arx, fit_output_error, simulate_model, step_response

__all__ = ["IdentifiedModel", "fit_arx", "fit_output_error", "fit_armax", "simulate_model", "step_response"]
