"""The APL trailer (paper 000, Piasco & Legeay): instrument model, response, double filter, deconvolution.

Instrument
----------
apl_model                  -- eq. (1) for any speed and spacing (Table 1 built in, corrected gain).
paper_identified_model     -- the identified models of §4.2.1-4.2.4 and the §4.3 roots, by name.
apl_model_from_polynomials -- an instrument from B/A coefficients (e.g. an identified OE model).
apl_model_from_dict        -- rebuild a model saved with APLModel.to_dict (``road identify`` JSON).
load_model, save_model     -- read (checked against a record's speed and dx) / write a ``road identify`` JSON file.
reconstruct_recording      -- ``road reconstruct`` in one call: model for (speed, dx) or a model file, spacing checked.
towing_speed               -- the speed a record is reconstructed at and its samples towed off it (the CLI's and batch's).
choose_towing_speed        -- the speed to reconstruct at, from --speed and the record's speed column (recording_speed,
                              speed_tolerance: a mismatch beyond it is refused); check_speed_samples flags the
                              samples off it, without_off_speed_std NaNs their std; trailer_at_speed re-discretises.
resample_model             -- an identified model re-discretised for another step (zero-order hold, z = exp(s dt));
                              reconstruct_recording uses it for a model file of another dx or speed.
step_transitions           -- the same step by step (A_k = exp(A_c dt_k)): a record towed at a varying speed.
identify_trailer           -- OE or ARMAX identification from bench records, as an APLModel (§4);
                              check_identification_structure validates its structure option.
APLModel, TrailerPoles, TABLE1_CONFIGURATIONS, RC_TIME_CONSTANT, PAPER_IDENTIFIED_MODELS
frequency_response, FrequencyResponse, passband
plot_frequency_response    -- deprecated alias of ``longprofile.report.plot_frequency_response``.
apl_response               -- what the trailer records on a profile; apl_filter for bare arrays.

Reconstruction
--------------
double_filter              -- the paper's zero-phase double filtering (§3, eqs. 4-5).
reconstruct_profile        -- smoother / Kalman filter / double filter / fixed-lag smoother in one call (Reconstruction).
default_fixed_lag          -- default latency of method="fixed-lag" (4 pendulum time constants, m).
apl_deconvolution_model    -- the augmented state-space model of §5.1 (eqs. 9-12) for the engine.
instrument_state_space     -- minimal cascade realisation (A, B, C, D) of an instrument.
is_detectable              -- §5.2 detectability (PBH) of an augmented model.
fit_noise_variances        -- q and r by maximum likelihood (NoiseFit).
smoother_error_std         -- stationary posterior std of the smoothed elevation in a waveband.
fixed_lag_error_std        -- the same for the fixed-lag estimate (its steady-state filter measured by an impulse).
InstrumentUncertainty      -- declared 1-sigma of the trailer's frequencies and gain, added to the printed std
                              (instrument_error_variance, perturbed_instrument, instrument_parameters; issue 13).
detrend_profile            -- remove what the APL cannot see (quadratic + zero-phase high-pass).
reconstruct_varying_speed  -- smoother / filter of a record towed at a varying speed (varying_speed_model: one
                              transition per station, station_steps; q, r by ML with the time-varying model);
                              reconstruct_time_sampled: a time-sampled record at its own time step.
reconstruct_towed          -- ``road reconstruct`` / ``batch reconstruct``: the towing speed from the file, then the
                              constant-speed or the varying-speed reconstruction (TowedReconstruction).

Synthetic profiles with truth
-----------------------------
bump_profile, crenel_profile, speed_hump_profile, sine_arcs_profile, white_noise_profile
simulate_apl_recording, APLRecording -- a noisy trailer recording of one of them, with the truth
(random ISO 8608 roads: longprofile.road.iso8608_profile)
"""

from ..._lazy import lazy_namespace

_EXPORTS = {
    "._deconvolution": (
        "FIXED_LAG_CORRELATION_LENGTH", "FIXED_LAG_TIME_CONSTANTS", "RECONSTRUCTION_METHODS", "NoiseFit",
        "Reconstruction", "apl_deconvolution_model", "default_fixed_lag", "detrend_profile", "fit_noise_variances",
        "fixed_lag_error_std", "instrument_state_space", "is_detectable", "reconstruct_profile",
        "smoother_error_std",
    ),
    "._deprecated": (
        "plot_frequency_response",
    ),
    "._double_filter": (
        "double_filter",
    ),
    "._files": (
        "load_model", "save_model",
    ),
    "._identify": (
        "IDENTIFICATION_STRUCTURES", "check_identification_structure", "identify_trailer",
    ),
    "._instrument_uncertainty": (
        "INSTRUMENT_ERROR_WINDOW_M", "InstrumentUncertainty", "instrument_error_variance", "instrument_parameters",
        "perturbed_instrument",
    ),
    "._model": (
        "PAPER_IDENTIFIED_MODELS", "RC_TIME_CONSTANT", "TABLE1_CONFIGURATIONS", "APLModel", "FrequencyResponse",
        "TrailerPoles", "apl_filter", "apl_model", "apl_model_from_dict", "apl_model_from_polynomials",
        "apl_response", "frequency_response", "paper_identified_model", "passband",
    ),
    "._resample": (
        "MAX_POLE_FRACTION", "resample_model", "step_transitions",
    ),
    "._short_waves": (
        "SHORT_WAVE_OPTIONS", "RoadSpectrumRatio", "estimate_road_spectrum_ratio",
    ),
    "._speed": (
        "DEFAULT_TOWING_SPEED", "SPEED_TOLERANCE", "SPEED_TOLERANCES", "STOP_SPEED", "SpeedCheck", "TowingSpeed",
        "check_speed_samples", "choose_towing_speed", "recording_speed", "speed_range", "speed_tolerance",
        "trailer_at_speed", "without_off_speed_std", "towing_speed",
    ),
    "._synthetic": (
        "SYNTHETIC_PROFILES", "APLRecording", "bump_profile", "crenel_profile", "simulate_apl_recording",
        "sine_arcs_profile", "speed_hump_profile", "white_noise_profile",
    ),
    "._varying_speed": (
        "STD_SPEED_STEP", "VARYING_SPEED_METHODS", "reconstruct_time_sampled", "reconstruct_varying_speed",
        "station_steps", "varying_speed_model",
    ),
    "._workflow": (
        "TowedReconstruction", "reconstruct_recording", "reconstruct_towed",
    ),
}

__all__ = [
    "APLModel", "TrailerPoles", "TABLE1_CONFIGURATIONS", "RC_TIME_CONSTANT", "PAPER_IDENTIFIED_MODELS",
    "apl_model", "apl_model_from_polynomials", "paper_identified_model", "frequency_response",
    "FrequencyResponse", "passband", "plot_frequency_response", "apl_response", "apl_filter",
    "double_filter", "reconstruct_profile", "Reconstruction", "RECONSTRUCTION_METHODS", "apl_deconvolution_model",
    "instrument_state_space", "is_detectable", "fit_noise_variances", "NoiseFit", "smoother_error_std",
    "fixed_lag_error_std",
    "detrend_profile", "bump_profile", "crenel_profile", "speed_hump_profile", "sine_arcs_profile",
    "white_noise_profile", "simulate_apl_recording", "APLRecording", "SYNTHETIC_PROFILES", "apl_model_from_dict",
    "default_fixed_lag", "FIXED_LAG_CORRELATION_LENGTH", "FIXED_LAG_TIME_CONSTANTS",
    "load_model", "save_model", "identify_trailer", "IDENTIFICATION_STRUCTURES", "check_identification_structure",
    "reconstruct_recording", "InstrumentUncertainty", "INSTRUMENT_ERROR_WINDOW_M", "instrument_error_variance",
    "instrument_parameters", "perturbed_instrument", "SHORT_WAVE_OPTIONS", "RoadSpectrumRatio",
    "estimate_road_spectrum_ratio", "DEFAULT_TOWING_SPEED", "SPEED_TOLERANCE", "SPEED_TOLERANCES", "STOP_SPEED",
    "SpeedCheck", "TowingSpeed", "check_speed_samples", "choose_towing_speed", "recording_speed", "speed_tolerance",
    "trailer_at_speed", "without_off_speed_std", "towing_speed", "speed_range", "resample_model", "MAX_POLE_FRACTION",
    "step_transitions", "STD_SPEED_STEP", "VARYING_SPEED_METHODS", "reconstruct_varying_speed", "station_steps",
    "varying_speed_model", "TowedReconstruction", "reconstruct_towed", "reconstruct_time_sampled",
]

__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
