"""How a pool worker hands its results to :func:`ltvmodels.fit_many`: a file, mapped, not copied.

A task's results (its units' summary records, and their models when they are
kept) are written by the worker to a new file, and only the file's path goes
back through loky's pipe. Two reasons:

* **no half messages**: a path is a message short enough for one atomic pipe
  write, so a worker killed at any moment never leaves half a message in the
  pipe (loky's reader would wait for the rest of it for good). The file
  appears whole or not at all: it is written under a temporary name, then
  renamed.
* **no copies**: the results are pickled with protocol 5, their NumPy arrays
  out of band. The file holds the arrays' bytes (each at a 64-byte boundary),
  then the pickle stream, then an index. This process maps the file
  (copy-on-write) and unpickles the stream with the mapped regions as the
  arrays' buffers, so that 10⁴ models of 60 kB come back without a copy or a
  parse of their 600 MB: their arrays are views of the mapping, writable
  (a write copies the page it touches, privately), and the mapping lives as
  long as one of them does. The file itself is removed once mapped.

The directory is in memory (``/dev/shm``) where the system has it.
"""

from __future__ import annotations

import mmap
import os
import pickle
import tempfile
import uuid
from typing import Any

__all__ = ["new_directory", "write", "read"]

ALIGNMENT = 64
INDEX_LENGTH_BYTES = 8
WRITE_PIECES = 1024  # buffers per os.writev (IOV_MAX on Linux)


def new_directory() -> str:
    """A new private directory for the result files of a pool run (remove it after)."""
    shared_memory = "/dev/shm"
    memory = shared_memory if os.access(shared_memory, os.W_OK) else None
    return tempfile.mkdtemp(prefix="ltvmodels-pool-", dir=memory)


def write(results: Any, directory: str) -> str:
    """Write ``results`` to a new file in ``directory``; returns its path."""
    buffers: list[pickle.PickleBuffer] = []
    stream = pickle.dumps(results, protocol=5, buffer_callback=buffers.append)
    path = os.path.join(directory, f"{os.getpid()}-{uuid.uuid4().hex}.results")
    pieces: list[Any] = []  # what the file holds, in order
    regions, size = [], 0
    for buffer in buffers:
        raw = buffer.raw()
        regions.append((size, size + raw.nbytes))
        padding = -(size + raw.nbytes) % ALIGNMENT
        pieces += [raw, bytes(padding)] if padding else [raw]
        size += raw.nbytes + padding
    index = pickle.dumps((regions, (size, size + len(stream))), protocol=5)
    pieces += [stream, index, len(index).to_bytes(INDEX_LENGTH_BYTES, "little")]
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
    buffers = [view[start:stop] for start, stop in regions]
    return pickle.loads(view[stream_start:stream_end], buffers=buffers)
