"""``Packed``: an object pickled once into one buffer, rebuilt when asked.

A model that crosses from a worker process to :func:`ltvmodels.fit_many`
travels packed: a short pickle stream, and its arrays' memory, which pickle
protocol 5 hands over out of band (no copy), so that the receiving process
keeps a few buffers per model instead of rebuilding its objects and arrays.
:class:`~ltvmodels.ModelSet` unpacks a model the first time it is asked for;
its arrays are then views of those buffers (no copy either).
"""

from __future__ import annotations

import pickle
from typing import Any

__all__ = ["Packed"]


class Packed:
    """One object, pickled with protocol 5: its stream and its arrays' buffers (see above)."""

    __slots__ = ("stream", "arrays")

    def __init__(self, stream: bytes, arrays: list) -> None:
        self.stream = stream
        self.arrays = arrays

    @classmethod
    def pack(cls, value: Any) -> Packed:
        """Pickle ``value``; its arrays stay where they are (no copy) until sent."""
        arrays: list[pickle.PickleBuffer] = []
        stream = pickle.dumps(value, protocol=5, buffer_callback=arrays.append)
        return cls(stream, [array.raw() for array in arrays])

    def unpack(self) -> Any:
        """The object, its arrays views of the buffers."""
        return pickle.loads(self.stream, buffers=self.arrays)

    def __reduce_ex__(self, protocol: Any) -> tuple:
        if protocol >= 5:
            arrays: list[Any] = [pickle.PickleBuffer(array) for array in self.arrays]
        else:
            arrays = [bytes(array) for array in self.arrays]
        return (Packed, (self.stream, arrays))
