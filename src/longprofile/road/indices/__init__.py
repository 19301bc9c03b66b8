"""Road roughness indices and spectra (ASTM E1926 / WTP-46, ISO 8608, E1489, CT 526, AASHTO R 36).

iri -- IRI per segment and whole section, MRI and HRI for two tracks (IRIResult).
iri_report -- IRI as agencies report it: fixed, continuous or overlapping intervals, SI or US units (IRIReport).
GapSummary, MIN_VALID_FRACTION -- gaps="restart" (iri, iri_report, analyse_roughness): IRI over the measured parts.
iri_plausibility, sampling_note -- a sentence when a section IRI is outside any road's range, or the stations are coarse.
dropout_runs, dropout_note -- runs of one exact elevation over 2 m (a dropout written as a value), and their sentence.
iri_notes -- the warnings of `road iri` about an IRI and its profile (all of the above that apply).
rectified_slope -- golden-car rectified slope per step (building block of the IRI).
golden_car_matrices -- exact discrete golden car (WTP-46 ST, PR) for a step or per-step array.
localized_roughness -- continuous short-interval IRI and defects above a threshold.
waveband_energy -- mean-square elevation per segment in wavelength bands (APL_BANDS built in).
profile_psd -- Welch displacement PSD in cycles/m; fit_iso8608 -- Gd(n0), waviness and class A..H.
iso8608_gd, iso8608_class, ISO8608_CLASSES -- the ISO 8608 spectrum and class table.
iso8608_profile -- random road profile of an ISO 8608 class (A..H), seedable.
analyse_roughness -- every analysis of a roughness report in one call (RoughnessAnalysis).
ride_number -- Ride Number (ASTM E1489) from a quarter-car Profile Index (RideNumberResult).
rolling_straightedge -- rolling straightedge deviation and defects (StraightedgeResult).
profilograph_trace, profilograph_index -- California profilograph simulation and Profile Index (CT 526).
joint_faulting, find_joints, step_statistic -- joint faulting from profile (AASHTO R 36 practice).
ride_number_report, straightedge_report, profile_index_report, faulting_report -- those four as agencies report
    them (per segment, defects, joints), SI or US units (IndexReport: what the `road ride-number`, `road
    straightedge`, `road profile-index` and `road faulting` commands write); INDEX_DEFAULTS, INDEX_VALUE_RANGES.
"""

from ..._lazy import lazy_namespace

_EXPORTS = {
    "._dropouts": (
        "MIN_DROPOUT_RUN_M", "dropout_note", "dropout_runs",
    ),
    "._gaps": (
        "GapSummary", "MIN_VALID_FRACTION",
    ),
    "._faulting": (
        "FaultingResult", "find_joints", "joint_faulting", "step_statistic",
    ),
    "._iri": (
        "GOLDEN_CAR", "IRIReport", "IRIResult", "RectifiedSlope", "golden_car_matrices", "iri", "iri_notes",
        "iri_plausibility", "iri_report", "rectified_slope", "sampling_note",
    ),
    "._iso8608": (
        "ISO8608_BAND", "ISO8608_CLASSES", "ISO8608Fit", "ProfilePSD", "fit_iso8608", "iso8608_class", "iso8608_gd",
        "iso8608_profile", "profile_psd",
    ),
    "._profilograph": (
        "ProfileIndexResult", "ProfilographTrace", "profilograph_index", "profilograph_trace",
    ),
    "._proval": (
        "INDEX_DEFAULTS", "INDEX_VALUE_RANGES", "IndexReport", "faulting_report", "profile_index_report",
        "ride_number_report", "straightedge_report",
    ),
    "._ride_number": (
        "RideNumberResult", "ride_number",
    ),
    "._roughness": (
        "APL_BANDS", "LocalizedRoughness", "RoughnessDefect", "WavebandEnergy", "localized_roughness",
        "waveband_energy",
    ),
    "._straightedge": (
        "StraightedgeDefect", "StraightedgeResult", "rolling_straightedge",
    ),
    "._summary": (
        "RoughnessAnalysis", "analyse_roughness",
    ),
}

__all__ = ["iso8608_profile",
    "iri", "IRIResult", "iri_report", "IRIReport", "GapSummary", "MIN_VALID_FRACTION", "rectified_slope",
    "RectifiedSlope", "golden_car_matrices",
    "GOLDEN_CAR", "iri_plausibility", "iri_notes", "sampling_note", "dropout_runs", "dropout_note", "MIN_DROPOUT_RUN_M",
    "localized_roughness", "LocalizedRoughness", "RoughnessDefect", "waveband_energy", "WavebandEnergy",
    "APL_BANDS", "profile_psd", "ProfilePSD", "fit_iso8608", "ISO8608Fit", "iso8608_gd", "iso8608_class",
    "ISO8608_CLASSES", "ISO8608_BAND", "analyse_roughness", "RoughnessAnalysis",
    "ride_number", "RideNumberResult", "rolling_straightedge", "StraightedgeResult", "StraightedgeDefect",
    "profilograph_trace", "ProfilographTrace", "profilograph_index", "ProfileIndexResult", "joint_faulting",
    "FaultingResult", "find_joints", "step_statistic", "ride_number_report", "straightedge_report",
    "profile_index_report", "faulting_report", "IndexReport", "INDEX_DEFAULTS", "INDEX_VALUE_RANGES"]

__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
