"""Sizes that users ask for, checked against the memory they would take before numpy allocates.

A size argument (e.g. ``steps`` of :meth:`ltvmodels.LTVModel.from_arrays`) can
ask for more memory than any machine has: numpy would then fail with a
``MemoryError`` about an array the user never named, or, where the system
overcommits memory, the process would be killed while filling it. A size whose
arrays would exceed the machine's physical memory is refused here, with an
error that names the argument, the memory needed and what to do.
"""

from __future__ import annotations

import os

__all__ = ["UNKNOWN_MEMORY", "physical_memory", "affordable_count", "size_text"]

UNKNOWN_MEMORY = 2**40
"""The bound (1 TiB) where the operating system does not report its physical memory
(``os.sysconf`` is POSIX only): generous, so it only refuses sizes no machine holds."""


def physical_memory() -> int:
    """The machine's physical memory in bytes (:data:`UNKNOWN_MEMORY` where unknown)."""
    try:
        pages = os.sysconf("SC_PHYS_PAGES")
        page_size = os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # no sysconf (Windows), or no such names
        return UNKNOWN_MEMORY
    if pages <= 0 or page_size <= 0:  # -1: the system does not know
        return UNKNOWN_MEMORY
    return pages * page_size


def affordable_count(count: int, name: str, *, item_bytes: int, what: str, remedy: str) -> int:
    """``count`` items of ``item_bytes`` bytes each, if they fit the physical memory.

    Parameters
    ----------
    count : int
        The validated size (>= 0) the user asked for.
    name : str
        The argument it came from (the start of the message).
    item_bytes : int
        Bytes each counted item takes (e.g. a time step's coefficients).
    what : str
        What the memory would hold, for the message ("the coefficients of 10 steps").
    remedy : str
        What to do instead, for the message.

    Returns
    -------
    int
        ``count``.

    Raises
    ------
    ValueError
        ``count * item_bytes`` exceeds :func:`physical_memory`.
    """
    needed = count * item_bytes
    available = physical_memory()
    if needed > available:
        raise ValueError(
            f"{name}: expected at most {available // max(item_bytes, 1)} (what fits in this "
            f"machine's {size_text(available)} of memory), received {count}: {what} would "
            f"need {size_text(needed)}; {remedy}"
        )
    return count


def size_text(n_bytes: int) -> str:
    """A number of bytes as people read it: "512 B", "1.5 GiB", "29.1 TiB"."""
    units = ("B", "KiB", "MiB", "GiB", "TiB", "PiB")
    value, unit = float(n_bytes), 0
    while value >= 1024 and unit < len(units) - 1:
        value /= 1024
        unit += 1
    return f"{n_bytes} B" if unit == 0 else f"{value:.1f} {units[unit]}"
