"""The road namespace: every name of today's ``__all__`` importable, loaded lazily (PEP 562), ``dir()`` complete."""

import subprocess
import sys

import pytest

import longprofile.road as road

#: ``longprofile.road.__all__`` before the split into subpackages (issue 12): none may disappear.
NAMES_BEFORE_ISSUE_12 = {
    "Profile", "iso8608_profile", "iri", "IRIResult", "iri_report", "IRIReport", "rectified_slope", "RectifiedSlope",
    "golden_car_matrices", "GOLDEN_CAR", "localized_roughness", "LocalizedRoughness", "RoughnessDefect",
    "waveband_energy", "WavebandEnergy", "APL_BANDS", "profile_psd", "ProfilePSD", "fit_iso8608", "ISO8608Fit",
    "iso8608_gd", "iso8608_class", "ISO8608_CLASSES", "ISO8608_BAND", "analyse_roughness", "RoughnessAnalysis",
    "apl", "apl_model", "apl_response", "double_filter", "reconstruct_profile", "Reconstruction", "ride_number",
    "RideNumberResult", "rolling_straightedge", "StraightedgeResult", "StraightedgeDefect", "profilograph_trace",
    "ProfilographTrace", "profilograph_index", "ProfileIndexResult", "joint_faulting", "FaultingResult",
    "find_joints", "step_statistic", "compare_profiles", "ProfileComparison", "certify_profiler",
    "CertificationResult", "R56_THRESHOLDS", "resample_profile", "smoothness_acceptance", "AcceptanceResult",
    "AcceptanceSpec", "read_spec", "default_spec", "simulate_grinding", "GrindingResult",
}


def test_every_name_kept_and_listed():
    assert NAMES_BEFORE_ISSUE_12 <= set(road.__all__)
    assert set(road.__all__) <= set(dir(road))
    for name in road.__all__:
        assert getattr(road, name) is not None
    assert road.Profile is __import__("longprofile.core", fromlist=["Profile"]).Profile
    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        road.not_a_name  # noqa: B018


def test_subpackages_export_what_road_reexports():
    from longprofile.road import apl, indices, smoothness

    for sub in (apl, indices, smoothness):
        for name in sub.__all__:
            if name in road.__all__:
                assert getattr(road, name) is getattr(sub, name), name


def test_indices_do_not_load_the_trailer_or_matplotlib():
    code = ("import sys\nfrom longprofile.road import iri, iri_report, Profile\n"
            "print('longprofile.road.apl' in sys.modules, 'longprofile.road.smoothness' in sys.modules, "
            "'matplotlib' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["False", "False", "False"]
