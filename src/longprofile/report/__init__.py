"""Reports: HTML pages, figures and CSV tables rendered from library results (no numerical code here).

write_road_report -- road roughness report (profile, IRI per segment, localised roughness, PSD + ISO 8608).
road_report_tables, road_report_figures -- its CSV tables and figures, by file name (the page is a Jinja2 template).
plot_iri -- PNG bar chart of the IRI per segment with condition limits.
plot_iri_report -- an IRIReport drawn in its units: bars per segment, or continuous IRI along the road.
IRI_CONDITION_LIMITS -- default good/poor IRI limits, m/km (FHWA).
plot_profile -- figure of a profile's tracks along the road (envelope for long profiles).
write_network_report -- network report over a batch results folder (routes, IRI histogram, worst segments, failures).
write_acceptance_report -- smoothness acceptance page: lots, localized roughness map, grind list, histogram.
plot_index_report -- Ride Number, straightedge, Profile Index or faulting (an IndexReport) in its units.
plot_certification -- cross-correlation against offset of profiler runs vs the reference (R 56 practice).
write_compare_report -- `road compare` output: runs.csv, pairs.csv, summary.json (and correlation.png).
report_folder, REPORT_FILES -- the one output-folder check (inputs never overwritten), and the files each report writes.
plot_recording, plot_reconstructions, plot_identification -- APL figures: recording, reconstructions, identification.
warm_reconstructions -- plot_reconstructions drawn once on synthetic data (a figure helper's warm-up).
plot_frequency_response -- APL instrument models: magnitude, phase, group delay, the |H| ~ 1 band.
plot_settlement, plot_true_settlement, write_rail_report -- rail settlement figures and HTML report (paper 004).
plot_derivative, plot_derivative_comparison -- a derivative estimate with its band; estimators compared (paper 002).
plot_slope_estimate, plot_drive, plot_sensitivity, plot_speed_measurement -- vehicle slope figures (paper 001).
plot_vertical_estimate, plot_vertical_simulation, plot_thesis_tables -- vertical vehicle state figures (thesis 003).
plot_kalman_smoothing -- the state-space demo: Kalman filter vs RTS smoother across a data gap.
figure_renderer, use_renderer, current_renderer, save_plot, draw -- figures drawn in a helper process started with the
    command (matplotlib's import and drawing off its critical path), else inline.
"""

from .._lazy import lazy_namespace

# PEP 562: a submodule (and matplotlib, and the domain it draws) is imported when one of its names is first used,
# so `road acceptance` does not load the derivative kernels of `_signal` (0.4 s) or the vehicle figures.
_EXPORTS = {
    "._acceptance": ("plot_certification", "write_acceptance_report",),
    "._apl": ("plot_frequency_response", "plot_identification", "plot_reconstructions", "plot_recording",
              "warm_reconstructions",),
    "._compare": ("write_compare_report",),
    "._html": ("REPORT_FILES", "report_folder",),
    "._network": ("write_network_report",),
    "._profile_plot": ("plot_profile",),
    "._proval": ("plot_index_report",),
    "._render": ("current_renderer", "draw", "figure_renderer", "save_plot", "use_renderer",),
    "._rail": ("plot_settlement", "plot_true_settlement", "write_rail_report",),
    "._road": ("IRI_CONDITION_LIMITS", "plot_iri", "plot_iri_report", "road_report_figures", "road_report_tables",
               "write_road_report",),
    "._signal": ("plot_derivative", "plot_derivative_comparison",),
    "._statespace": ("plot_kalman_smoothing",),
    "._vehicle_planar": ("plot_drive", "plot_sensitivity", "plot_slope_estimate", "plot_speed_measurement",),
    "._vehicle_vertical": ("plot_thesis_tables", "plot_vertical_estimate", "plot_vertical_simulation",),
}

__all__ = ["write_road_report", "plot_iri", "plot_iri_report", "IRI_CONDITION_LIMITS", "plot_profile"]
__all__ += ["write_network_report", "plot_index_report"]
__all__ += ["write_acceptance_report", "plot_certification", "write_compare_report"]
__all__ += ["report_folder", "REPORT_FILES"]
__all__ += ["plot_recording", "plot_reconstructions", "plot_identification", "plot_frequency_response",
            "warm_reconstructions"]
__all__ += ["plot_slope_estimate", "plot_drive", "plot_sensitivity", "plot_speed_measurement"]
__all__ += ["plot_vertical_estimate", "plot_vertical_simulation", "plot_thesis_tables"]
__all__ += ["plot_settlement", "plot_true_settlement", "write_rail_report", "plot_derivative", "plot_derivative_comparison"]
__all__ += ["road_report_tables", "road_report_figures"]
__all__ += ["plot_kalman_smoothing", "figure_renderer", "use_renderer", "current_renderer", "save_plot", "draw"]

__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
