"""Road profiles: the APL trailer model and reconstruction (paper 000), roughness indices and spectra.

Profile -- a longitudinal profile (stations in m, elevations in m, one column per track).
iso8608_profile -- random road profile of an ISO 8608 class (A..H), seedable.

Roughness indices and spectra (ASTM E1926 / WTP-46, ISO 8608)
iri -- IRI per segment and whole section, MRI and HRI for two tracks (IRIResult).
iri_report -- IRI as agencies report it: fixed, continuous or overlapping intervals, SI or US units (IRIReport).
GapSummary, MIN_VALID_FRACTION -- gaps="restart": the IRI over the measured parts of a profile with gaps.
rectified_slope -- golden-car rectified slope per step (building block of the IRI).
golden_car_matrices -- exact discrete golden car (WTP-46 ST, PR) for a step or per-step array.
iri_plausibility, sampling_note, dropout_runs, dropout_note -- what a road command warns of or refuses in a profile.
iri_notes -- the warnings of `road iri` about an IRI and its profile (all of the above that apply).
localized_roughness -- continuous short-interval IRI and defects above a threshold.
waveband_energy -- mean-square elevation per segment in wavelength bands (APL_BANDS built in).
profile_psd -- Welch displacement PSD in cycles/m; fit_iso8608 -- Gd(n0), waviness and class A..H.
iso8608_gd, iso8608_class, ISO8608_CLASSES -- the ISO 8608 spectrum and class table.
analyse_roughness -- every analysis of a roughness report in one call (RoughnessAnalysis).

APL trailer (paper 000; full index in longprofile.road.apl)
apl -- submodule: instrument model, apl_response, double_filter, reconstruct_profile, synthetic profiles.
apl_model, apl_response, double_filter, reconstruct_profile, Reconstruction -- the main entry points.

Other indices, comparison and acceptance (ProVAL features; definitions and sources in docs/road-acceptance.md)
ride_number -- Ride Number (ASTM E1489) from a quarter-car Profile Index (RideNumberResult).
rolling_straightedge -- rolling straightedge deviation and defects (StraightedgeResult).
profilograph_trace, profilograph_index -- California profilograph simulation and Profile Index (CT 526).
joint_faulting, find_joints, step_statistic -- joint faulting from profile (AASHTO R 36 practice).
ride_number_report, straightedge_report, profile_index_report, faulting_report -- those four as agencies report
    them, SI or US units (IndexReport; the `road ride-number`, `straightedge`, `profile-index`, `faulting` commands).
compare_profiles, certify_profiler -- Karamihas cross-correlation with offset search; R 56 certification.
resample_profile -- explicit linear resampling onto a regular grid.
smoothness_acceptance, read_spec, default_spec -- lots, localized roughness, exclusions, pay (AcceptanceResult).
simulate_grinding -- must-grind areas and the shallowest grind below a localized-roughness threshold.

Subpackages: ``road.apl`` (the trailer), ``road.indices`` (IRI and the other indices), ``road.smoothness``
(comparison, certification, acceptance, grinding). Every name above is importable from ``road`` and loaded on
first use (PEP 562), so that e.g. ``road.iri`` does not import the APL deconvolution or scipy.signal.
"""

from .._lazy import lazy_namespace
from ..core import Profile

__all__ = ["Profile", "iso8608_profile",
    "iri", "IRIResult", "iri_report", "IRIReport", "GapSummary", "MIN_VALID_FRACTION", "rectified_slope",
    "RectifiedSlope", "golden_car_matrices",
    "GOLDEN_CAR", "iri_plausibility", "iri_notes", "sampling_note", "dropout_runs", "dropout_note", "MIN_DROPOUT_RUN_M",
    "localized_roughness", "LocalizedRoughness", "RoughnessDefect", "waveband_energy", "WavebandEnergy",
    "APL_BANDS", "profile_psd", "ProfilePSD", "fit_iso8608", "ISO8608Fit", "iso8608_gd", "iso8608_class",
    "ISO8608_CLASSES", "ISO8608_BAND", "analyse_roughness", "RoughnessAnalysis",
    "apl", "apl_model", "apl_response", "double_filter", "reconstruct_profile", "Reconstruction"]
__all__ += ["ride_number", "RideNumberResult", "rolling_straightedge", "StraightedgeResult", "StraightedgeDefect",
            "profilograph_trace", "ProfilographTrace", "profilograph_index", "ProfileIndexResult", "joint_faulting",
            "FaultingResult", "find_joints", "step_statistic", "compare_profiles", "ProfileComparison", "certify_profiler", "CertificationResult",
            "R56_THRESHOLDS", "resample_profile", "smoothness_acceptance", "AcceptanceResult", "AcceptanceSpec",
            "read_spec", "default_spec", "simulate_grinding", "GrindingResult"]
__all__ += ["ride_number_report", "straightedge_report", "profile_index_report", "faulting_report", "IndexReport"]

_SUBPACKAGES = ("apl", "indices", "smoothness")
_APL_NAMES = ("apl_model", "apl_response", "double_filter", "reconstruct_profile", "Reconstruction")
_SMOOTHNESS_NAMES = ("compare_profiles", "ProfileComparison", "certify_profiler", "CertificationResult",
                     "R56_THRESHOLDS", "resample_profile", "smoothness_acceptance", "AcceptanceResult",
                     "AcceptanceSpec", "read_spec", "default_spec", "simulate_grinding", "GrindingResult")
#: public name -> subpackage that defines it (PEP 562: loaded on first access, so that ``road iri`` does not
#: import the APL deconvolution, the engine's EKF or scipy.signal).
_LAZY = {name: "apl" for name in _APL_NAMES}
_LAZY.update({name: "smoothness" for name in _SMOOTHNESS_NAMES})
_LAZY.update({name: "indices" for name in __all__ if name not in _LAZY and name not in ("Profile", "apl")})

_BY_SUBPACKAGE: dict[str, list[str]] = {}
for _name, _sub in _LAZY.items():
    _BY_SUBPACKAGE.setdefault(f".{_sub}", []).append(_name)
__getattr__, __dir__ = lazy_namespace(__name__, _BY_SUBPACKAGE, __all__, submodules=_SUBPACKAGES)
del _name, _sub
