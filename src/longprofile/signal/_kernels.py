"""Compiled kernel of the recursive (running-moment) polynomial differentiator (private).

The kernel trusts its inputs; :mod:`._derivative` and :mod:`._streaming` validate.

For a tap sequence h[n] = sum_{j=0}^{d} c_j n^j (n = 1..N) plus a free h[0],

    y[k] = h[0] x[k] + sum_j c_j S_j[k],     S_j[k] = sum_{n=1}^{N} n^j x[k-n],

and the moments obey the O(d^2) recursion (binomial expansion of (m+1)^j)

    S_j[k+1] = sum_{i=0}^{j} C(j, i) (S_i[k] + [i = 0] x[k] - N^i x[k-N]).

The recursion is only marginally stable (round-off grows polynomially), so the
moments are recomputed exactly from the ring buffer every ``refresh`` samples
and whenever a NaN leaves the window. Samples are stored relative to a
reference value (the first finite sample) so a large offset costs no precision.
"""

from __future__ import annotations

import numpy as np

from .._jit import njit

__all__ = ["moment_filter_kernel", "moving_mean_square_kernel"]


@njit(cache=True, nogil=True)
def _recompute(ring_b, pos, s, degree, window):
    # ring_b[(pos - n) mod N] holds x[k+1-n] for n = 1..N (k = last sample processed)
    for j in range(degree + 1):
        s[j] = 0.0
    for n in range(1, window + 1):
        idx = pos - n
        if idx < 0:
            idx += window
        v = ring_b[idx]
        p = 1.0
        fn = float(n)
        for j in range(degree + 1):
            s[j] += p * v
            p *= fn


@njit(cache=True, nogil=True)
def _recompute_small(ring_b, pos, window):
    """Exact moments S_0..S_3 from the ring (two contiguous runs, no modulo)."""
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    # n = 1..pos: idx = pos - n (pos-1 down to 0); n = pos+1..N: idx = window + pos - n
    for n in range(1, window + 1):
        idx = pos - n if n <= pos else window + pos - n
        v = ring_b[idx]
        fn = float(n)
        w = v * fn
        s0 += v
        s1 += w
        w *= fn
        s2 += w
        s3 += w * fn
    return s0, s1, s2, s3


@njit(cache=True, nogil=True)
def _load_state(b, pos, n_seen, last_nan, since, ref, ref_set):
    """Per-series recursion state of series b: (ring position, samples seen, last NaN, since refresh, ref, ref set)."""
    return pos[b], n_seen[b], last_nan[b], since[b], ref[b], ref_set[b]


@njit(cache=True, nogil=True)
def _save_state(b, pos, n_seen, last_nan, since, ref, ref_set, p, g, lnan, since_b, rb, rset):
    """Store the per-series recursion state of series b (inverse of :func:`_load_state`)."""
    pos[b] = p
    n_seen[b] = g
    last_nan[b] = lnan
    since[b] = since_b
    ref[b] = rb
    ref_set[b] = rset


@njit(cache=True, nogil=True)
def _small_kernel(x, window, degree, c, h0, gain, const, npow, refresh,
                  ring, pos, sums, n_seen, last_nan, since, ref, ref_set, out):
    """Degree <= 3 and at most 3 outputs: moments and coefficients kept in scalars (registers).

    c is padded to 4 columns; with fewer than 3 outputs the last one is recomputed
    into the same row (harmless duplicate writes).
    """
    n_series, n_steps = x.shape
    n_out = c.shape[0]
    k1 = min(1, n_out - 1)
    k2 = min(2, n_out - 1)
    nan = np.nan
    n1 = npow[1]
    n2 = npow[2] if degree >= 2 else 0.0
    n3 = npow[3] if degree >= 3 else 0.0
    c00, c01, c02, c03, h00 = c[0, 0], c[0, 1], c[0, 2], c[0, 3], h0[0]
    c10, c11, c12, c13, h01 = c[k1, 0], c[k1, 1], c[k1, 2], c[k1, 3], h0[k1]
    c20, c21, c22, c23, h02 = c[k2, 0], c[k2, 1], c[k2, 2], c[k2, 3], h0[k2]
    for b in range(n_series):
        xb = x[b]
        o0 = out[0, b]
        o1 = out[k1, b]
        o2 = out[k2, b]
        ring_b = ring[b]
        p, g, lnan, since_b, rb, rset = _load_state(b, pos, n_seen, last_nan, since, ref, ref_set)
        e0 = gain[0] * rb + const[0, b]
        e1 = gain[k1] * rb + const[k1, b]
        e2 = gain[k2] * rb + const[k2, b]
        s0 = sums[b, 0]
        s1 = sums[b, 1]
        s2 = sums[b, 2] if degree >= 2 else 0.0
        s3 = sums[b, 3] if degree >= 3 else 0.0
        for t in range(n_steps):
            xk = xb[t]
            if rset == 0 and not np.isnan(xk):
                rb = xk
                rset = 1
                e0 = gain[0] * rb + const[0, b]
                e1 = gain[k1] * rb + const[k1, b]
                e2 = gain[k2] * rb + const[k2, b]
            v = xk - rb
            if np.isnan(v):
                lnan = g
            if g >= window and g - lnan > window:
                o0[t] = h00 * v + c00 * s0 + c01 * s1 + c02 * s2 + c03 * s3 + e0
                o1[t] = h01 * v + c10 * s0 + c11 * s1 + c12 * s2 + c13 * s3 + e1
                o2[t] = h02 * v + c20 * s0 + c21 * s1 + c22 * s2 + c23 * s3 + e2
            else:
                o0[t] = nan
                o1[t] = nan
                o2[t] = nan
            old = ring_b[p]
            ring_b[p] = v
            a0 = s0 + v - old
            a1 = s1 - n1 * old
            a2 = s2 - n2 * old
            a3 = s3 - n3 * old
            s3 = a3 + 3.0 * a2 + 3.0 * a1 + a0
            s2 = a2 + 2.0 * a1 + a0
            s1 = a1 + a0
            s0 = a0
            p += 1
            if p == window:
                p = 0
            g += 1
            since_b += 1
            if since_b >= refresh or lnan == g - 1 - window:
                s0, s1, s2, s3 = _recompute_small(ring_b, p, window)
                if degree < 3:
                    s3 = 0.0
                if degree < 2:
                    s2 = 0.0
                since_b = 0
        _save_state(b, pos, n_seen, last_nan, since, ref, ref_set, p, g, lnan, since_b, rb, rset)
        sums[b, 0] = s0
        sums[b, 1] = s1
        if degree >= 2:
            sums[b, 2] = s2
        if degree >= 3:
            sums[b, 3] = s3


def moment_filter_kernel(x, window, degree, c, h0, gain, const, binom, npow, refresh,
                         ring, pos, sums, n_seen, last_nan, since, ref, ref_set, out):
    """Run the recursive filter on x (B, T), updating the per-series state in place.

    Output o at a valid sample is h0[o] v + sum_j c[o, j] S_j + gain[o] ref + const[o, b]
    (v = x - ref), NaN otherwise; written to out (n_out, B, T). State per
    series b: ring (B, N), pos, sums (B, d+1), n_seen, last_nan, since
    (int64), ref (float), ref_set (int64).
    """
    if degree <= 3 and c.shape[0] <= 3:
        c4 = np.zeros((c.shape[0], 4))
        c4[:, :degree + 1] = c
        _small_kernel(x, window, degree, c4, h0, gain, const, npow, refresh,
                      ring, pos, sums, n_seen, last_nan, since, ref, ref_set, out)
    else:
        _generic_kernel(x, window, degree, c, h0, gain, const, binom, npow, refresh,
                        ring, pos, sums, n_seen, last_nan, since, ref, ref_set, out)


@njit(cache=True, nogil=True)
def _generic_kernel(x, window, degree, c, h0, gain, const, binom, npow, refresh,
                         ring, pos, sums, n_seen, last_nan, since, ref, ref_set, out):
    """Any degree: moments in a small array (see moment_filter_kernel)."""
    n_series, n_steps = x.shape
    n_out = c.shape[0]
    s = np.zeros(degree + 1)
    tmp = np.zeros(degree + 1)
    nan = np.nan
    for b in range(n_series):
        ring_b = ring[b]
        p, g, lnan, since_b, rb, rset = _load_state(b, pos, n_seen, last_nan, since, ref, ref_set)
        for j in range(degree + 1):
            s[j] = sums[b, j]
        for t in range(n_steps):
            xk = x[b, t]
            if rset == 0 and not np.isnan(xk):
                rb = xk
                rset = 1
            v = xk - rb
            if np.isnan(v):
                lnan = g
            if g >= window and g - lnan > window:
                if degree == 2:
                    for o in range(n_out):
                        out[o, b, t] = (h0[o] * v + c[o, 0] * s[0] + c[o, 1] * s[1] + c[o, 2] * s[2]
                                        + gain[o] * rb + const[o, b])
                else:
                    for o in range(n_out):
                        acc = h0[o] * v + gain[o] * rb + const[o, b]
                        for j in range(degree + 1):
                            acc += c[o, j] * s[j]
                        out[o, b, t] = acc
            else:
                for o in range(n_out):
                    out[o, b, t] = nan
            old = ring_b[p]
            if degree == 1:
                a0 = s[0] + v - old
                a1 = s[1] - npow[1] * old
                s[1] = a1 + a0
                s[0] = a0
            elif degree == 2:
                a0 = s[0] + v - old
                a1 = s[1] - npow[1] * old
                a2 = s[2] - npow[2] * old
                s[2] = a2 + 2.0 * a1 + a0
                s[1] = a1 + a0
                s[0] = a0
            elif degree == 3:
                a0 = s[0] + v - old
                a1 = s[1] - npow[1] * old
                a2 = s[2] - npow[2] * old
                a3 = s[3] - npow[3] * old
                s[3] = a3 + 3.0 * a2 + 3.0 * a1 + a0
                s[2] = a2 + 2.0 * a1 + a0
                s[1] = a1 + a0
                s[0] = a0
            else:
                for i in range(degree + 1):
                    tmp[i] = s[i] - npow[i] * old
                tmp[0] += v
                for j in range(degree + 1):
                    acc = 0.0
                    for i in range(j + 1):
                        acc += binom[j, i] * tmp[i]
                    s[j] = acc
            ring_b[p] = v
            p += 1
            if p == window:
                p = 0
            g += 1
            since_b += 1
            if since_b >= refresh or lnan == g - 1 - window:
                _recompute(ring_b, p, s, degree, window)
                since_b = 0
        _save_state(b, pos, n_seen, last_nan, since, ref, ref_set, p, g, lnan, since_b, rb, rset)
        for j in range(degree + 1):
            sums[b, j] = s[j]


@njit(cache=True, nogil=True)
def moving_mean_square_kernel(v, before, after, out):
    """Mean of the squares of the finite values of each row of v (B, T) over the window [k - before, k + after),
    clipped at the ends.

    Written to out (B, T), NaN where the window holds no finite value. A running sum and count (O(1) per sample),
    recomputed exactly every 16 (``before + after``) samples so round-off cannot accumulate.
    """
    n_series, n_steps = v.shape
    period = 16 * max(before + after, 1)  # an exact recompute every 16 window lengths bounds the round-off
    for r in range(n_series):
        row = v[r]
        total = 0.0
        count = 0
        lo = 0
        hi = 0
        since = 0
        for k in range(n_steps):
            new_hi = min(k + after, n_steps)
            new_lo = max(k - before, 0)
            while hi < new_hi:
                x = row[hi] * row[hi]
                if not np.isnan(x):
                    total += x
                    count += 1
                hi += 1
            while lo < new_lo:
                x = row[lo] * row[lo]
                if not np.isnan(x):
                    total -= x
                    count -= 1
                lo += 1
            since += 1
            if since >= period:
                total = 0.0
                count = 0
                for j in range(lo, hi):
                    x = row[j] * row[j]
                    if not np.isnan(x):
                        total += x
                        count += 1
                since = 0
            out[r, k] = total / count if count > 0 else np.nan
