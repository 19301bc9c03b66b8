"""Reports: HTML pages, figures and CSV tables rendered from library results (no numerical code here).

write_road_report -- road roughness report (profile, IRI per segment, localised roughness, PSD + ISO 8608).
plot_iri -- PNG bar chart of the IRI per segment with condition limits.
IRI_CONDITION_LIMITS -- default good/poor IRI limits, m/km (FHWA).
"""

from ._road import IRI_CONDITION_LIMITS, plot_iri, write_road_report

__all__ = ["write_road_report", "plot_iri", "IRI_CONDITION_LIMITS"]
