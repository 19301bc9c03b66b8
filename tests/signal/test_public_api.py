"""The public namespace of longprofile.signal is pinned (and every name is documented in its index)."""

import longprofile.signal as signal

EXPECTED = {
    "derivative", "derivative_ml", "derivative_polyfit", "derivative_backward", "derivative_kalman",
    "DERIVATIVE_METHODS", "DerivativeResult", "DerivativeMethod", "check_derivative_options", "StreamingDerivative", "estimate_noise_std",
    "kalman_differentiator_model", "plot_derivative", "ml_coefficients", "ml_coefficients_float",
    "ml_model_variance", "polyfit_coefficients", "polyfit_coefficients_float", "backward_difference_coefficients",
    "backward_difference_coefficients_float", "power_sum", "variance_gain", "static_gain", "frequency_response",
    "polynomial_bias", "model_check", "ModelCheck",
}


def test_public_names_are_pinned_and_indexed():
    assert set(signal.__all__) == EXPECTED
    for name in EXPECTED:
        assert getattr(signal, name) is not None
        assert f"\n{name} " in signal.__doc__, f"{name} missing from the package docstring index"
        obj = getattr(signal, name)
        if callable(obj):
            assert obj.__doc__, f"{name} has no docstring"
