"""Medians and median absolute deviations of the outputs' columns, compiled.

The robust losses' bookkeeping needs, per output, the median and the MAD of
its observed entries (the default Huber threshold, the outliers, the outputs
drawn in before a robust fit). numpy's ``median`` along axis 0 of the strided
(rows, n) columns partitions copies twice per call: at T = 1e5 those calls were
a tenth of a Huber fit. Here each column is copied once into one buffer and
selected in place.
"""

from __future__ import annotations

import numba
import numpy as np

from .precompiled import attach

__all__ = ["MAD_TO_STD", "column_center_spread", "median_in_place"]

MAD_TO_STD = 1.4826  # σ / MAD of Gaussian noise


# Above this many entries a median is first bracketed by two order statistics of a
# sample of 2048 to 4095 entries (every stride-th): one pass then counts the entries
# below the bracket and keeps those within it, and the selection runs on those few
# (about 5 % of 1e5). At T = 1e5 that took a median from 1.1 to 0.2 ms.
BRACKET_MIN = 4096
SAMPLE_SIZE = 2048
# The bracket's half-width in sample ranks: 3–4.4 standard deviations of the sample
# rank of the median (√m / 2 for m sampled entries). A miss only costs the plain
# selection over all entries.
BRACKET_HALF_WIDTH = 100


@numba.njit(cache=True)
def median_in_place(a):  # pragma: no cover - compiled
    """The median of ``a``, which it overwrites (reordered, or, for a large ``a``, the
    entries near the median moved to the front): the same value as numpy's median
    (the mean of the two middle entries of an even count).

    Written out rather than numba's np.median, whose compilation (its partition and
    selection helpers) took 1.2 s of the first fit in a fresh process; this takes
    about 0.4 s (no allocation, no slicing: each adds to the compilation).
    """
    size = a.size
    k = size // 2
    count, rank = size, k  # the median is entry ``rank`` of the first ``count``
    if size >= BRACKET_MIN:
        # the sample to the front, then ranks k − 1 (even count) and k must lie
        # within the bracket [low, high]
        stride = size // SAMPLE_SIZE
        m = (size + stride - 1) // stride
        for index in range(m):
            a[index], a[index * stride] = a[index * stride], a[index]
        low = _select(a, 0, m - 1, m // 2 - BRACKET_HALF_WIDTH)
        high = _select(a, 0, m - 1, m // 2 + BRACKET_HALF_WIDTH)
        # without branches (an entry's side is a coin toss near the median)
        below, within = 0, 0
        for index in range(size):
            below += a[index] < low
            within += a[index] <= high
        within -= below
        if below <= k - 1 + size % 2 and k < below + within:
            kept = 0
            for index in range(size):  # the bracket's entries to the front, in place
                value = a[index]
                a[kept] = value
                kept += (value >= low) & (value <= high)
            count, rank = within, k - below
    upper = _select(a, 0, count - 1, rank)
    if size % 2:
        return upper
    lower = a[0]  # a[:rank] <= a[rank]: the largest of them is the lower middle
    for index in range(1, rank):
        lower = max(lower, a[index])
    return 0.5 * (lower + upper)


@numba.njit(cache=True)
def _select(a, lo, hi, k):  # pragma: no cover - compiled
    """The k-th smallest entry of a[lo : hi + 1] (k counted from 0 in ``a``), by Hoare's
    selection: that range is reordered so that a[lo:k] <= a[k] <= a[k + 1 : hi + 1]."""
    while lo < hi:
        pivot = a[(lo + hi) // 2]
        i, j = lo, hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                a[i], a[j] = a[j], a[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:  # a[j + 1 : i] equal the pivot
            break
    return a[k]


@numba.njit(cache=True)
def column_center_spread(values, observed, center, mad, rms):  # pragma: no cover - compiled
    """Per output i of ``values`` (N, q, n), over its entries where ``observed`` (N, q):
    the median into ``center[i]``, the median of |v − center[i]| (the MAD, unscaled)
    into ``mad[i]`` and √(mean v²) into ``rms[i]``; all three NaN where no entry
    is observed (like numpy's median of nothing)."""
    N, q, n = values.shape
    buffer = np.empty(N * q)
    for i in range(n):
        count, total = 0, 0.0
        for t in range(N):
            for j in range(q):
                if observed[t, j]:
                    v = values[t, j, i]
                    buffer[count] = v
                    total += v * v
                    count += 1
        if count == 0:
            center[i], mad[i], rms[i] = np.nan, np.nan, np.nan
            continue
        rms[i] = np.sqrt(total / count)
        middle = median_in_place(buffer[:count])
        center[i] = middle
        count = 0
        for t in range(N):
            for j in range(q):
                if observed[t, j]:
                    buffer[count] = abs(values[t, j, i] - middle)
                    count += 1
        mad[i] = median_in_place(buffer[:count])


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
