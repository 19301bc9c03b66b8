"""Reports: HTML pages, figures and CSV tables rendered from library results (no numerical code here).

write_road_report -- road roughness report (profile, IRI per segment, localised roughness, PSD + ISO 8608).
plot_iri -- PNG bar chart of the IRI per segment with condition limits.
plot_iri_report -- an IRIReport drawn in its units: bars per segment, or continuous IRI along the road.
IRI_CONDITION_LIMITS -- default good/poor IRI limits, m/km (FHWA).
plot_profile -- figure of a profile's tracks along the road (envelope for long profiles).
write_network_report -- network report over a batch results folder (routes, IRI histogram, worst segments, failures).
write_acceptance_report -- smoothness acceptance page: lots, localized roughness map, grind list, histogram.
plot_certification -- cross-correlation against offset of profiler runs vs the reference (R 56 practice).
"""

from ._road import IRI_CONDITION_LIMITS, plot_iri, plot_iri_report, write_road_report
from ._profile_plot import plot_profile
from ._network import write_network_report
from ._acceptance import plot_certification, write_acceptance_report

__all__ = ["write_road_report", "plot_iri", "plot_iri_report", "IRI_CONDITION_LIMITS", "plot_profile"]
__all__ += ["write_network_report"]
__all__ += ["write_acceptance_report", "plot_certification"]
