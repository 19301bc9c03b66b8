"""Profile comparison, profiler certification, smoothness acceptance and grinding (ProVAL features;
definitions and sources in docs/road-acceptance.md).

compare_profiles, certify_profiler -- Karamihas cross-correlation with offset search; R 56 certification.
resample_profile -- explicit linear resampling onto a regular grid.
smoothness_acceptance, read_spec, default_spec -- lots, localized roughness, exclusions, pay (AcceptanceResult).
simulate_grinding -- must-grind areas and the shallowest grind below a localized-roughness threshold.
"""

from ..._lazy import lazy_namespace

_EXPORTS = {
    "._acceptance": (
        "AcceptanceResult", "AcceptanceSpec", "default_spec", "read_spec", "smoothness_acceptance",
    ),
    "._compare": (
        "R56_THRESHOLDS", "MIN_REFERENCE_COVERAGE", "CertificationResult", "ProfileComparison", "certify_profiler",
        "compare_profiles", "resample_profile",
    ),
    "._grinding": (
        "GrindingResult", "simulate_grinding",
    ),
}

__all__ = ["compare_profiles", "ProfileComparison", "certify_profiler", "CertificationResult",
           "R56_THRESHOLDS", "MIN_REFERENCE_COVERAGE", "resample_profile", "smoothness_acceptance", "AcceptanceResult", "AcceptanceSpec",
           "read_spec", "default_spec", "simulate_grinding", "GrindingResult"]

__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
