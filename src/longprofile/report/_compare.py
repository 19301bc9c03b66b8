"""Profile comparison / profiler certification output (``road compare``): runs.csv, pairs.csv, summary.json."""

from __future__ import annotations

import json
import math
from pathlib import Path

from ._html import REPORT_FILES, report_folder, write_csv, write_text

__all__ = ["write_compare_report"]


def write_compare_report(result, outdir, *, reference=None, runs=(), plot: bool = False, inputs=None,
                         overwrite: bool = True) -> list[Path]:
    """Write the tables of :func:`longprofile.road.certify_profiler` into ``outdir``, each file atomically.

    Parameters
    ----------
    result : CertificationResult
    outdir : path-like
        Output folder (created): ``runs.csv``, ``pairs.csv``, ``summary.json`` and, with ``plot``,
        ``correlation.png`` (:func:`plot_certification`).
    reference, runs : path-like, sequence of path-like
        The reference and run files compared, recorded in ``summary.json``.
    plot : bool, default False
    inputs : sequence of path-like, optional
        Files never overwritten (default: ``reference`` and ``runs``).
    overwrite : bool, default True
        False refuses an existing, non-empty ``outdir`` (:class:`~longprofile.errors.OutputError`).

    Returns
    -------
    list of Path
        Files written.
    """
    runs = list(runs)
    if inputs is None:
        inputs = [reference, *runs]
    out = report_folder(outdir, inputs, writes=REPORT_FILES["compare"], overwrite=overwrite)
    written = [write_csv(result.runs, out / "runs.csv"), write_csv(result.pairs, out / "pairs.csv")]
    summary = {"reference": None if reference is None else str(reference), "runs": [str(r) for r in runs],
               "passed": result.passed, "repeatability": result.repeatability, "accuracy": result.accuracy,
               "reference_iri_m_per_km": result.reference_iri, "thresholds": result.thresholds,
               "warnings": list(getattr(result, "warnings", ())), "metadata": result.metadata}
    written.append(write_text(out / "summary.json", json.dumps(_finite(summary), indent=2, default=float,
                                                                allow_nan=False)))
    if plot:
        from ._acceptance import plot_certification
        from ._render import draw

        # by the command's figure helper when one runs (report/_render.py)
        written.append(draw(plot_certification, result, result.comparisons, out / "correlation.png"))
    return written


def _finite(obj):
    """``obj`` with every non-finite float as None: strict JSON (a bare ``NaN``, e.g. the repeatability of a single
    run, is refused by JavaScript's parser)."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj
