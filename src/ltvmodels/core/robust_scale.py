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

__all__ = ["column_center_spread", "median_in_place"]


# Above this many entries a median is first bracketed by two order statistics of a
# sample of about SAMPLE_SIZE entries (every stride-th): one pass then counts the
# entries below the bracket and keeps those within it, and the selection runs on
# those few (about 5 % of 1e5). At T = 1e5 that took a median from 1.1 to 0.2 ms.
BRACKET_MIN = 4096
SAMPLE_SIZE = 2048
# The bracket's half-width in sample ranks, in standard deviations of the sample
# rank of the median (√m / 2 for m sampled entries): a miss only costs the plain
# selection over all entries.
BRACKET_WIDTH = 4.0


@numba.njit(cache=True)
def median_in_place(a):  # pragma: no cover - compiled
    """The median of ``a``, which it overwrites (its entries are reordered, or, for a
    large ``a``, those near the median moved to the front).

    Written out rather than numba's np.median, whose compilation (its partition and
    selection helpers) took 1.2 s of the first fit in a fresh process; this takes
    about 0.3 s. The same value as numpy's median (the mean of the two middle
    entries of an even count).
    """
    size = a.size
    k = size // 2
    if size >= BRACKET_MIN:
        # ranks k − 1 (even count) and k must lie within the bracket [low, high]
        stride = size // SAMPLE_SIZE
        sample = a[::stride].copy()
        m = sample.size
        width = int(BRACKET_WIDTH * 0.5 * np.sqrt(m)) + 1
        low = _select_in_place(sample, max(m // 2 - width, 0))
        high = _select_in_place(sample, min(m // 2 + width, m - 1))
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
            return _middle(a[:within], k - below, size % 2 == 1)
    return _middle(a, k, size % 2 == 1)


@numba.njit(cache=True)
def _middle(a, k, odd):  # pragma: no cover - compiled
    """The k-th smallest entry of ``a`` (reordered) if ``odd``, else its mean with the
    (k − 1)-th: the median of the entries of which ``a`` holds the middle ones."""
    upper = _select_in_place(a, k)
    if odd:
        return upper
    lower = a[0]  # a[:k] <= a[k]: the largest of them is the lower middle
    for index in range(1, k):
        lower = max(lower, a[index])
    return 0.5 * (lower + upper)


@numba.njit(cache=True)
def _select_in_place(a, k):  # pragma: no cover - compiled
    """The k-th smallest entry of ``a`` (0-based), by Hoare's selection: ``a`` is
    reordered so that a[:k] <= a[k] <= a[k + 1:]."""
    lo, hi = 0, a.size - 1
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
