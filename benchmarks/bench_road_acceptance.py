"""Smoothness acceptance report speed (issue 16): lots, localized roughness, grinding simulation and the HTML
report of a two-track profile; and the cross-correlation comparison of a run with a reference.

Full run: 10 km, two tracks, 25 mm step (400,001 samples per track), US spec (0.1 mi lots, 25 ft window,
threshold, pay schedule, one exclusion), a few bumps to grind. Target: the whole report (computation + HTML and
figures) <= 2 s, in a warm process and end to end (a fresh ``longprofile road acceptance`` process on the ERD file:
interpreter, imports, compiled-cache load, reading, computing and writing). Reading the file is timed separately
(ERD reader, reported only).
Quick mode: 1 km.

Run: ``.venv/bin/python -m benchmarks road_acceptance`` (full) or ``--quick``.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks._common import BenchRow, best_time, cli_wall_time

AREA = "road_acceptance"


def _profile(length_m: float):
    from longprofile.road import Profile, iso8608_profile

    dx = 0.025
    a = iso8608_profile(length_m, dx, "A", rng=11)
    b = iso8608_profile(length_m, dx, "A", rng=12)
    x = a.distance
    bumps = sum(6e-3 * np.exp(-((x - s) / 0.4) ** 2) for s in np.linspace(0.1, 0.9, 5) * length_m)
    z = np.column_stack([a.elevation[:, 0] * 0.3 + bumps, b.elevation[:, 0] * 0.3 + bumps])
    return Profile(distance=x, elevation=z, tracks=("left", "right"), name="bench")


def _toml(spec: dict) -> str:
    """The spec as a TOML file (top-level scalars, then one table per dict; lists of numbers)."""
    top = [f"{k} = {v!r}".replace("'", '"') for k, v in spec.items() if not isinstance(v, dict)]
    tables = [f"[{k}]\n" + "\n".join(f"{kk} = {vv!r}" for kk, vv in v.items()) for k, v in spec.items()
              if isinstance(v, dict)]
    return "\n".join(top) + "\n\n" + "\n\n".join(tables) + "\n"


def run(quick: bool) -> list[BenchRow]:
    from longprofile.io import read_profile, write_profile
    from longprofile.report._acceptance import write_acceptance_report
    from longprofile.road import iri_report
    from longprofile.road.smoothness._acceptance import smoothness_acceptance, spec_from_dict
    from longprofile.road.smoothness._compare import compare_profiles
    from longprofile.road.smoothness._grinding import simulate_grinding

    length = 1000.0 if quick else 10000.0
    prof = _profile(length)
    base = iri_report(prof, mode="continuous", step=0.3048).iri
    threshold_us = float(np.percentile(base.mean(axis=1), 99.0)) * 63.36
    ft = length / 0.3048
    spec_dict = {"units": "us", "lot": {"length": 528.0}, "localized": {"threshold": round(threshold_us, 1)},
                 "exclusions": {"zones": [[0.30 * ft, 0.30 * ft + 100.0]]},
                 "pay": {"schedule": [[40, 1.05], [60, 1.0], [90, 0.95], [400, 0.9]]}}
    spec = spec_from_dict(spec_dict)
    smoothness_acceptance(_profile(200.0), spec_from_dict({"units": "us", "lot": {"length": 100.0}}))  # warm
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        def report():
            res = smoothness_acceptance(prof, spec)
            g = simulate_grinding(prof, spec, acceptance=res)
            out["files"] = write_acceptance_report(res, Path(tmp) / "report", grinding=g)
            out["g"] = g

        t_report = best_time(report, repeat=2)
        c0 = time.process_time()
        report()
        cpu_report = time.process_time() - c0  # CPU used by this process only (other jobs share the machine)
        erd = write_profile(prof, Path(tmp) / "bench.erd")
        t0 = time.perf_counter()
        read_profile(erd)
        t_read = time.perf_counter() - t0
        (Path(tmp) / "spec.toml").write_text(_toml(spec_dict))
        t_cli, load = cli_wall_time(["road", "acceptance", str(erd), "--spec", str(Path(tmp) / "spec.toml")],
                                    [Path(tmp) / f"cli{k}" for k in range(4)], repeat=1 if quick else 3,
                                    warm=not quick)
        # the same spec with the worst track as index (index = "iri"): more must-grind areas than the MRI's
        (Path(tmp) / "spec_iri.toml").write_text(_toml({**spec_dict, "lot": {**spec_dict["lot"], "index": "iri"}}))
        areas_iri = simulate_grinding(prof, spec_from_dict({**spec_dict, "lot": {**spec_dict["lot"], "index": "iri"}})
                                      ).metadata["areas"]
        t_cli_iri, load_iri = cli_wall_time(["road", "acceptance", str(erd), "--spec", str(Path(tmp) / "spec_iri.toml")],
                                            [Path(tmp) / f"cli_iri{k}" for k in range(4)], repeat=1 if quick else 3,
                                            warm=False)
    g = out["g"]
    n = prof.n_samples
    x, z = prof.distance, prof.elevation
    from longprofile.road import Profile

    k = 40
    ref = Profile(distance=x[:n - k], elevation=z[:n - k, 0])
    rng = np.random.default_rng(0)
    run_p = Profile(distance=x[:n - k], elevation=z[k:, 0] + rng.normal(0, 1e-4, n - k))
    compare_profiles(Profile(distance=x[:20000], elevation=z[:20000, 0]),
                     Profile(distance=x[:20000], elevation=z[:20000, 0]))
    res_c = {}
    t_cmp = best_time(lambda: res_c.setdefault("c", compare_profiles(ref, run_p)), repeat=1 if not quick else 2)
    c = res_c["c"]
    km = length / 1000.0
    return [
        BenchRow(AREA, f"acceptance report, {km:g} km two-track profile (compute + HTML)", t_report, "s",
                 target=2.0 if not quick else None, higher_is_better=False,
                 detail=f"{n} samples/track at 25 mm; {g.metadata['areas']} grind area(s); "
                        f"{len(out['files'])} files written"),
        BenchRow(AREA, f"longprofile road acceptance, {km:g} km two-track ERD, end to end", t_cli, "s",
                 target=2.0 if not quick else None, higher_is_better=False,
                 detail=f"fresh process (interpreter, imports, compiled-cache load, read, compute, HTML, figures, "
                        f"CSVs, ground profile), same spec; best of {1 if quick else 3}; load before {load:.2f}"),
        BenchRow(AREA, f"longprofile road acceptance, {km:g} km two-track ERD, index = \"iri\", end to end", t_cli_iri,
                 "s", target=2.0 if not quick else None, higher_is_better=False,
                 detail=f"as above with the worst track as index: {areas_iri} grind areas (MRI: {g.metadata['areas']}); "
                        f"best of {1 if quick else 3}; load before {load_iri:.2f}"),
        BenchRow(AREA, f"acceptance report, {km:g} km two-track profile, CPU time of this process", cpu_report,
                 "s", detail="process_time; on a loaded shared machine the wall time adds the wait for a core"),
        BenchRow(AREA, f"read the {km:g} km two-track ERD file", t_read, "s", detail="reported only (ERD reader)"),
        BenchRow(AREA, f"cross-correlation run vs reference, {km:g} km, +-5 m offset search", t_cmp, "s",
                 detail=f"offset found {c.offset:+.3f} m (injected {k * 0.025:+.3f} m), rho {c.correlation:.4f}"),
        BenchRow(AREA, "|offset found - injected|", abs(c.offset - k * 0.025), "m", target=0.025,
                 higher_is_better=False, detail="must be within one sample (25 mm)"),
    ]
