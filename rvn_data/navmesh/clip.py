"""Recast's `dividePoly`: clip a convex polygon by an axis-aligned plane (rasterisation)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def divide_poly(inp, n, out1, out2, offset, axis):
    """Split polygon `inp[:n]` by the plane v[axis] = offset: out1 (<=), out2 (>=); points on
    the plane go to both. Computed in the arrays' precision (float32: as Recast does)."""
    d = np.empty(n, inp.dtype)
    for i in range(n):
        d[i] = offset - inp[i, axis]
    m = 0
    k = 0
    j = n - 1
    for i in range(n):
        ina = d[i] >= 0.0
        inb = d[j] >= 0.0
        if ina != inb:
            s = d[j] / (d[j] - d[i])
            for c in range(3):
                v = inp[j, c] + (inp[i, c] - inp[j, c]) * s
                out1[m, c] = v
                out2[k, c] = v
            m += 1
            k += 1
            if d[i] > 0.0:
                out1[m, :] = inp[i, :]
                m += 1
            elif d[i] < 0.0:
                out2[k, :] = inp[i, :]
                k += 1
        else:
            if d[i] >= 0.0:
                out1[m, :] = inp[i, :]
                m += 1
            if d[i] <= 0.0:
                out2[k, :] = inp[i, :]
                k += 1
        j = i
    return m, k
