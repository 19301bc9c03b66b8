"""IRI speed: longprofile.road.iri vs the plain step-by-step WTP-46 recursion in NumPy.

The peer is what most open IRI implementations do: a Python loop over samples with a 4x4 NumPy
mat-vec per step (WTP-46 program, p. 36). Both use the same ST/PR (matrix exponential for dx = 0.25 m),
the same 11 m lead-in initialisation and 100 m segments; no moving average is needed at 0.25 m.

Full run: our IRI on 2e7 samples (5000 km at 0.25 m). The peer is timed on the first 2e5 samples and its
time extrapolated linearly to 2e7 (its cost is exactly linear in the number of steps); the identity of the
results is checked on the segments that both computed (max abs difference of the segment IRIs, m/km).
Quick mode: 2e4 samples, peer on all of them.

Run: ``.venv/bin/python -m benchmarks road_iri`` (full) or ``--quick``.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks._common import BenchRow, best_time

AREA = "road_iri"


def wtp46_numpy_loop(distance: np.ndarray, elevation: np.ndarray, segment_length: float) -> np.ndarray:
    """Peer: the WTP-46 IRI recursion written as a plain per-sample loop (regular spacing, no smoothing)."""
    from scipy.linalg import expm

    k1, k2, c, mu, v = 653.0, 63.3, 6.0, 0.15, 80.0 / 3.6
    a = np.array([[0, 1, 0, 0], [-k2, -c, k2, c], [0, 0, 0, 1], [k2 / mu, c / mu, -(k1 + k2) / mu, -c / mu]])
    b = np.array([0, 0, 0, k1 / mu])
    dx = distance[1] - distance[0]
    st = expm(a * dx / v)
    pr = np.linalg.solve(a, (st - np.eye(4)) @ b)
    i11 = int(round(11.0 / dx))
    s0 = (elevation[i11] - elevation[0]) / (i11 * dx)
    z = np.array([s0, 0.0, s0, 0.0])
    n = elevation.size
    rs = np.empty(n - 1)
    for i in range(1, n):
        slope = (elevation[i] - elevation[i - 1]) / dx
        z = st @ z + pr * slope
        rs[i - 1] = abs(z[0] - z[2])
    per_segment = int(round(segment_length / dx))
    n_seg = (n - 1) // per_segment
    return 1000.0 * rs[: n_seg * per_segment].reshape(n_seg, per_segment).mean(axis=1)


def run(quick: bool) -> list[BenchRow]:
    from longprofile.road import Profile, iri, iso8608_profile

    dx, seg = 0.25, 100.0
    n_total = 20_000 if quick else 20_000_000
    n_peer = n_total if quick else 200_000
    prof = iso8608_profile((n_total - 1) * dx, dx, "C", rng=0)
    x, z = prof.distance, prof.elevation[:, 0]

    iri(Profile(distance=x[:1000], elevation=z[:1000]), segment_length=seg)  # compile / warm the kernels
    ours_result = {}

    def ours():
        ours_result["r"] = iri(prof, segment_length=seg)

    t_ours = best_time(ours, repeat=1 if not quick else 3)
    t0 = time.perf_counter()
    peer = wtp46_numpy_loop(x[:n_peer], z[:n_peer], seg)
    t_peer_subset = time.perf_counter() - t0
    t_peer = t_peer_subset * (n_total - 1) / (n_peer - 1)
    ours_iri = ours_result["r"].iri[: peer.size, 0]
    max_diff = float(np.max(np.abs(ours_iri - peer)))
    extrapolated = "" if n_peer == n_total else f" (peer timed on {n_peer:.0e} samples, extrapolated linearly)"
    return [
        BenchRow(AREA, f"IRI speed-up vs NumPy WTP-46 loop, {n_total:.0e} samples", t_peer / t_ours, "x",
                 target=100.0, detail=f"ours {t_ours:.3f} s, peer {t_peer:.1f} s{extrapolated}"),
        BenchRow(AREA, f"IRI throughput, {n_total:.0e} samples", n_total / t_ours, "samples/s",
                 detail="profile -> 100 m segment IRI, one track, dx 0.25 m"),
        BenchRow(AREA, "max |IRI ours - peer| over common segments", max_diff, "m/km", target=1e-9,
                 higher_is_better=False, detail=f"{peer.size} segments of {seg:g} m compared"),
    ]
