"""Demo step: the roughness report of the profile reconstructed by the APL demo (runs after it)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..errors import InputError

__all__ = ["run_demo"]


def run_demo(outdir) -> list[Path]:
    """Write ``outdir/road/report/`` for the Kalman-smoother reconstruction, with the true profile beside it.

    Reads ``outdir/road/reconstructed_profile.csv`` (columns ``distance_m, true_m, smoother_m, smoother_std_m,
    filter_m, double_m``) written by the APL demo step, which must run first.
    """
    from ..io import read_profile
    from ..report import write_road_report
    from ..road import analyse_roughness, iri

    outdir = Path(outdir)
    src = outdir / "road" / "reconstructed_profile.csv"
    if not src.exists():
        raise InputError(f"{src} is missing: the IRI report needs the APL demo's reconstructed profile. Run the "
                         "APL demo step first (longprofile demo runs it before this one).")
    allp = read_profile(src)
    length = allp.distance[-1] - allp.distance[0]
    segment = 100.0 if length >= 300.0 else 20.0
    smoother = read_profile(src, tracks="smoother")
    true = read_profile(src, tracks="true")
    analysis = analyse_roughness(smoother, segment_length=segment)
    reference = analyse_roughness(true, segment_length=segment)
    report_dir = outdir / "road" / "report"
    files = write_road_report(analysis, report_dir, reference=reference, reference_label="true profile",
                              title="IRI of the APL reconstruction (Kalman smoother) vs the true profile")
    rows = []
    for t in allp.tracks:
        r = iri(read_profile(src, tracks=t), segment_length=segment)
        rows.append({"profile": t, "section_iri_m_per_km": float(r.section_iri[0])})
    table = pd.DataFrame(rows)
    true_iri = float(table.loc[table.profile == "true", "section_iri_m_per_km"].iloc[0]) if "true" in allp.tracks \
        else float("nan")
    table["error_vs_true_percent"] = 100.0 * (table["section_iri_m_per_km"] / true_iri - 1.0)
    comp = report_dir / "iri_by_reconstruction.csv"
    table.to_csv(comp, index=False)
    files.append(comp)
    return files
