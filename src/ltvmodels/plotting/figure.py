"""New figures without pyplot, and writing them to image files.

New figures are :class:`matplotlib.figure.Figure` objects created directly
(not through :mod:`matplotlib.pyplot`), so nothing needs a display or a GUI
backend. matplotlib is imported inside the functions, so importing this
package does not load it. The helpers here are shared by every figure of the
package (the plotting functions, the applications' figures and the command
line).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import OutputPathError

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "ESTIMATE_COLOR",
    "new_figure",
    "new_axes",
    "axes_in",
    "output_file",
    "image_file",
    "save_figure",
]

ESTIMATE_COLOR = "C0"
"""Colour of estimated quantities in every figure."""


def new_figure(figsize: tuple[float, float]) -> Figure:
    """A new Figure of the given size (inches) with constrained layout, without pyplot."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def new_axes(figsize: tuple[float, float]) -> Axes:
    """The single Axes of a new :func:`new_figure`."""
    return new_figure(figsize).add_subplot()


def axes_in(fig: Any, ax: Any) -> Axes | None:
    """The axes a one-panel figure draws into: ``ax``; or the single axes of ``fig``, which
    is cleared first; or None (the figure function makes a new figure).

    Raises
    ------
    TypeError
        Both ``fig`` and ``ax``.
    """
    if fig is None:
        return ax
    if ax is not None:
        raise TypeError(
            "fig, ax: expected one of them, received both; pass ax to draw into one axes "
            "of a figure, or fig to fill a whole figure"
        )
    fig.clear()
    return fig.add_subplot()


def output_file(out: Any, option: str = "out") -> Path:
    """Check, before any work is done, that a file (of any type) can be written at ``out``.

    Raises
    ------
    OutputPathError
        Not a path, a directory, a missing or read-only directory, or a
        read-only file; the message starts with ``option``.
    """
    if not isinstance(out, (str, os.PathLike)) or str(out) == "":
        raise OutputPathError(f"{option}: expected a file path, received {out!r}")
    path = Path(out)
    if path.is_dir():
        raise OutputPathError(f"{option}: {str(path)!r} is a directory; expected a file path")
    parent = path.parent
    if not parent.is_dir():
        raise OutputPathError(
            f"{option}: cannot write {str(path)!r}: directory {str(parent)!r} does not exist"
        )
    if not os.access(parent, os.W_OK):
        raise OutputPathError(
            f"{option}: cannot write {str(path)!r}: directory {str(parent)!r} is not writable"
        )
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputPathError(f"{option}: cannot write {str(path)!r}: file is not writable")
    return path


def image_file(out: Any, option: str = "out") -> tuple[Path, str]:
    """Check an image path before any work is done; returns (path, format).

    The format comes from the suffix (png without one) and must be one that
    matplotlib writes.

    Raises
    ------
    OutputPathError
        As :func:`output_file`, or an unsupported format.
    """
    from matplotlib.backend_bases import FigureCanvasBase

    path = output_file(out, option)
    supported = FigureCanvasBase.get_supported_filetypes()
    suffix = path.suffix.lower().lstrip(".")
    if not suffix:
        return path, "png"
    if suffix not in supported:
        raise OutputPathError(
            f"{option}: unsupported image format {path.suffix!r} in {str(path)!r} "
            f"(expected one of: {', '.join('.' + s for s in sorted(supported))})"
        )
    return path, suffix


def save_figure(fig: Figure, path: Path, fmt: str, option: str = "out", dpi: int = 150) -> None:
    """``fig.savefig`` with write errors as :class:`~ltvmodels.errors.OutputPathError`."""
    try:
        fig.savefig(path, format=fmt, dpi=dpi)
    except OSError as exc:
        reason = exc.strerror or exc
        raise OutputPathError(f"{option}: cannot write {str(path)!r}: {reason}") from exc
