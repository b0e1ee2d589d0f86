"""How a pool worker hands its results to :func:`ltvmodels.fit_many`: a file, mapped, not copied.

A task's results (its units' summary records, and their models when they are
kept) are written by the worker to a new file, and only the file's path goes
back through loky's pipe. Three reasons:

* **no half messages**: a path is a message short enough for one atomic pipe
  write, so a worker killed at any moment never leaves half a message in the
  pipe (loky's reader would wait for the rest of it for good). The file
  appears whole or not at all: it is written under a temporary name, then
  renamed.
* **no copies**: the results' NumPy arrays are not pickled. The file holds
  their bytes, then a pickle stream of everything else (in which each array
  is a reference), then an index. This process maps the file (copy-on-write)
  and unpickles the stream with the references resolved to views of the
  mapping, so that 10⁴ models of 60 kB come back without a copy or a parse
  of their 600 MB: their arrays are writable (a write copies the page it
  touches, privately), and the mapping lives as long as one of them does.
  The file itself is removed once mapped.
* **arrays by kind, not one by one**: the arrays of a task's models come in a
  few kinds (dtype and shape), the same for every unit. Each kind's arrays lie
  one after another in the file and are read as one stacked array, whose rows
  the models get. Pickled one by one, with their arrays inside, the models of
  a jump-linear fit (0.3 ms) took 38 µs each to pickle and 19 µs to unpickle;
  this way, a unit's whole result takes about 20 µs to pickle (50 µs with the
  file written) and 13 µs to read.

The directory is in memory (``/dev/shm``) where the system has it.
"""

from __future__ import annotations

import gc
import io
import mmap
import os
import pickle
import tempfile
import threading
import uuid
from typing import Any

import numpy as np

__all__ = ["new_directory", "write", "read"]

ALIGNMENT = 64
INDEX_LENGTH_BYTES = 8
WRITE_PIECES = 1024  # buffers per os.writev (IOV_MAX on Linux)
NUMBER_KINDS = "biufc"  # dtype kinds of the arrays that are stacked


def new_directory() -> str:
    """A new private directory for the result files of a pool run (remove it after)."""
    shared_memory = "/dev/shm"
    memory = shared_memory if os.access(shared_memory, os.W_OK) else None
    return tempfile.mkdtemp(prefix="ltvmodels-pool-", dir=memory)


class _ArrayPickler(pickle.Pickler):
    """Pickles every plain C-contiguous array as a row of its kind's stack; collects the arrays."""

    def __init__(self, file: io.BytesIO) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.kinds: dict[tuple[str, tuple[int, ...]], list[np.ndarray]] = {}

    def reducer_override(self, obj: Any) -> Any:
        # Called for objects other than numbers, strings and built-in containers, so
        # not for most of what a record holds. Exactly ndarray of numbers: subclasses,
        # arrays of objects, text or dates (no buffer) and views with gaps are pickled
        # as usual.
        if (
            type(obj) is not np.ndarray
            or obj.dtype.kind not in NUMBER_KINDS
            or not obj.flags.c_contiguous
        ):
            return NotImplemented
        rows = self.kinds.setdefault((obj.dtype.str, obj.shape), [])
        rows.append(obj)
        return _stacked_row, (obj.dtype.str, obj.shape, len(rows) - 1)


# The stacked arrays of the file being read, for _stacked_row (one per thread).
_reading = threading.local()


def _stacked_row(dtype: str, shape: tuple[int, ...], row: int) -> np.ndarray:
    """While :func:`read` unpickles: the array ``row`` of the kind ``(dtype, shape)``."""
    return _reading.stacks[dtype, shape][row, ...]


def write(results: Any, directory: str) -> str:
    """Write ``results`` to a new file in ``directory``; returns its path."""
    stream = io.BytesIO()
    pickler = _ArrayPickler(stream)
    pickler.dump(results)
    pieces: list[Any] = []  # what the file holds, in order
    regions, size = [], 0
    for (dtype, shape), arrays in pickler.kinds.items():
        regions.append((dtype, shape, len(arrays), size))
        pieces += [array for array in arrays if array.nbytes]
        size += sum(array.nbytes for array in arrays)
        padding = -size % ALIGNMENT
        if padding:
            pieces.append(bytes(padding))
            size += padding
    stream_bytes = stream.getbuffer()
    index = pickle.dumps((regions, (size, size + stream_bytes.nbytes)), protocol=5)
    pieces += [stream_bytes, index, len(index).to_bytes(INDEX_LENGTH_BYTES, "little")]
    path = os.path.join(directory, f"{os.getpid()}-{uuid.uuid4().hex}.results")
    descriptor = os.open(path + ".part", os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:  # a thousand pieces a system call: the arrays of a task are tens of thousands
        for start in range(0, len(pieces), WRITE_PIECES):
            _write_all(descriptor, pieces[start : start + WRITE_PIECES])
    finally:
        os.close(descriptor)
    os.replace(path + ".part", path)
    return path


def _write_all(descriptor: int, pieces: list) -> None:
    """Write the buffers ``pieces`` in order (``os.writev`` may write part of them)."""
    views = [memoryview(piece).cast("B") for piece in pieces]
    while views:
        written = os.writev(descriptor, views)
        while views and written >= len(views[0]):
            written -= len(views.pop(0))
        if views and written:
            views[0] = views[0][written:]


def read(path: str) -> Any:
    """The results written to ``path`` by :func:`write`, their arrays mapped (see above).

    The file is removed.
    """
    with open(path, "rb") as file:
        mapping = mmap.mmap(file.fileno(), 0, access=mmap.ACCESS_COPY)
    os.remove(path)  # the mapping keeps the data while it lives
    view = memoryview(mapping)
    end = len(view) - INDEX_LENGTH_BYTES
    index_length = int.from_bytes(view[end:], "little")
    regions, (stream_start, stream_end) = pickle.loads(view[end - index_length : end])
    stacks = {}
    for dtype, shape, count, offset in regions:
        length = count * int(np.prod(shape))
        stack = np.frombuffer(view, dtype, length, offset) if length else np.empty(0, dtype)
        stacks[dtype, shape] = stack.reshape((count, *shape))
    _reading.stacks = stacks
    collecting = gc.isenabled()
    # Unpickling a task's models makes tens of thousands of objects, none of them
    # garbage: with the collector on, its passes over every model kept so far
    # doubled the time of this call (measured: 0.029 against 0.013 ms a unit).
    gc.disable()
    try:
        return pickle.loads(view[stream_start:stream_end])
    finally:
        del _reading.stacks
        if collecting:
            gc.enable()
