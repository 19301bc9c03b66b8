"""Compiled cascade of second-order sections (transposed direct form II), the loop of :mod:`._sos`.

The recursion of each section s, per sample, in exactly the operation order of scipy's ``_sosfilt`` loop (the
reference; scipy/signal/_sosfilt.pyx), so that the outputs are bit for bit those of ``scipy.signal.sosfilt``::

    y      = b0 * x + z0
    z0     = (b1 * x - a1 * y) + z1
    z1     = b2 * x - a2 * y
    x      = y                  (input of the next section)

No fastmath: LLVM then neither reassociates the sums nor contracts a product and a sum into one fused
multiply-add, which would change the last bits.
"""

from __future__ import annotations

from .._jit import njit

__all__ = ["sos_cascade"]


@njit(cache=True, nogil=True)
def sos_cascade(sos, x, zi):  # pragma: no cover - compiled
    """Filter the K rows of ``x`` (K, T) in place by the sections ``sos`` (S, 6); ``zi`` (K, S, 2) is the state,
    updated in place to the final state. Row by row, sample by sample, section by section (scipy's loop order)."""
    n_k, n_t = x.shape
    n_s = sos.shape[0]
    for k in range(n_k):
        for t in range(n_t):
            cur = x[k, t]
            for s in range(n_s):
                new = sos[s, 0] * cur + zi[k, s, 0]
                zi[k, s, 0] = sos[s, 1] * cur - sos[s, 4] * new + zi[k, s, 1]
                zi[k, s, 1] = sos[s, 2] * cur - sos[s, 5] * new
                cur = new
            x[k, t] = cur
