"""What the commands share around their work: the output files and the model's data columns.

A command checks its output paths first (:func:`check_outputs`: ``--out``,
``--plot``, ``--coef-out``), so that a path that cannot be written fails
before any work is done. It draws its figure before anything is written,
since drawing may fail (:func:`figure_errors` makes that failure one line;
:func:`model_figure` draws a state-space model).
Then :func:`write_outputs` writes, always in this order, the model or the
table (``--out``), the coefficients (``--coef-out``) and the figure
(``--plot``), each named in the report's ``files`` and in a ``wrote PATH``
line. :func:`record_columns` gives a fitted model the names of its data
columns (a described copy: a fitted model is never changed).

The library's plotting is imported inside the functions: importing the
command line does not load it.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np

from ..errors import OutputPathError
from .data import write_csv
from .messages import CommandError, one_line
from .report import Report

__all__ = [
    "Outputs",
    "Table",
    "check_outputs",
    "figure_errors",
    "model_figure",
    "record_columns",
    "write_outputs",
]


@dataclass(frozen=True)
class Outputs:
    """The output files of a command, checked before any work.

    Attributes
    ----------
    out : Path or None
        ``--out``: a model file (.npz) or a CSV table, by the command.
    plot : tuple of (Path, str) or None
        ``--plot``: the image file and its format.
    coef_out : str or None
        ``--coef-out``: the CSV file of the coefficients, as given.
    """

    out: Path | None
    plot: tuple[Path, str] | None
    coef_out: str | None


class Table(NamedTuple):
    """A table that ``--out`` writes as CSV: its header, rows and optional row labels."""

    columns: list[str]
    values: np.ndarray
    row_labels: list[str] | None = None


def check_outputs(args: argparse.Namespace, out: Literal["model", "table"] | None) -> Outputs:
    """Check the output paths a command was given, before any work.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments; ``--plot`` is always read, ``--out`` when
        ``out`` is given and ``--coef-out`` where the command has it.
    out : {"model", "table"} or None
        What ``--out`` writes: a model file (its name must end in .npz), a
        CSV table, or None for a command without ``--out``.

    Returns
    -------
    Outputs
        The checked paths (None where not given).

    Raises
    ------
    OutputPathError
        A path that cannot be written, a model file not named .npz, or an
        image format that is not known.
    """
    from ..plotting.figure import image_file, output_file

    path = output_file(args.out, "out") if out is not None and args.out is not None else None
    if out == "model" and path is not None and path.suffix.lower() != ".npz":
        raise OutputPathError(
            "out: a model file is an .npz archive (read it with ltvmodels.load); expected "
            f"a name ending in .npz, received {str(path)!r}"
        )
    plot = image_file(args.plot, "plot") if args.plot is not None else None
    coef_out = getattr(args, "coef_out", None)
    if coef_out is not None:
        output_file(coef_out, "coef-out")
    _not_the_data(
        args, {"out": path, "plot": None if plot is None else plot[0], "coef-out": coef_out}
    )
    return Outputs(path, plot, coef_out)


def _not_the_data(args: argparse.Namespace, outputs: dict[str, Any]) -> None:
    """No output may overwrite an input file (DATA, MODEL): an error before any work."""
    inputs = [getattr(args, name, None) for name in ("data", "model")]
    read = {Path(p).resolve() for p in inputs if isinstance(p, (str, Path)) and str(p) != "-"}
    for option, path in outputs.items():
        if path is not None and Path(path).resolve() in read:
            raise OutputPathError(
                f"{option}: {str(path)!r} is an input of this command; writing it would "
                "overwrite the data: choose another file name"
            )


@contextlib.contextmanager
def figure_errors(limit: str | None = None) -> Iterator[None]:
    """Turn a failure to draw the ``--plot`` figure into a one-line error.

    Parameters
    ----------
    limit : str, optional
        What the figure is known not to support, when it applies (the likely
        cause), e.g. "a model with a constant term c_t".
    """
    try:
        yield
    except (ValueError, TypeError) as exc:
        hint = f" (the figures do not support {limit} yet); leave out --plot" if limit else ""
        raise CommandError(f"--plot: cannot draw the figure: {one_line(exc)}{hint}") from None


def model_figure(outputs: Outputs, model: Any, changepoints: np.ndarray, title: str) -> Any:
    """The ``--plot`` figure of a fitted state-space model (``fit``, ``segments``).

    Parameters
    ----------
    outputs : Outputs
        The checked paths; without ``--plot`` nothing is drawn.
    model : LTVModel
        The fitted model.
    changepoints : ndarray
        The change points to mark.
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure or None
        Coefficients, activation with the change points, eigenvalues; None
        without ``--plot``.
    """
    if outputs.plot is None:
        return None
    from ..plotting import plot_model

    with figure_errors("a model with a constant term c_t" if model.constant else None):
        fig = plot_model(model, changepoints=changepoints)
    fig.suptitle(title)
    return fig


def record_columns(
    model: Any,
    columns: dict[str, list[str]],
    time: np.ndarray | None = None,
    time_name: str | None = None,
) -> Any:
    """The fitted model described by the data's columns (a new model; ``model`` is unchanged).

    They let ``simulate``, ``predict`` and ``forecast`` read the same columns
    again, name the model's signals (plots, ``to_frame``) and, with
    ``--time``, give its time index (``model.data``).

    Parameters
    ----------
    model : LTVModel or ARXModel
        The fitted model.
    columns : dict
        The column names by role: ``{"state": ..., "input": ...}`` (the
        inputs may be empty) or ``{"output": ...}``.
    time : ndarray, optional
        The samples' times (``--time``).
    time_name : str, optional
        The name of their column (figures label the time axis with it).
    """
    # An autonomous model has no input signals to name.
    names = {role: names for role, names in columns.items() if names or role != "input"}
    return model.with_data(model.data.renamed(names, time, time_name))


def write_outputs(
    outputs: Outputs,
    report: dict[str, Any],
    lines: list[str],
    *,
    model: Any = None,
    table: Table | None = None,
    figure: Any = None,
) -> Report:
    """Write a command's files in a fixed order, and name them in its report and lines.

    Parameters
    ----------
    outputs : Outputs
        The checked paths (:func:`check_outputs`).
    report, lines : dict, list of str
        The command's report and text lines; each file written is added to
        ``report["files"]`` and as a ``wrote PATH`` line.
    model : LTVModel or ARXModel, optional
        A fitted model: ``--out`` saves it, ``--coef-out`` writes its
        coefficients (and their standard deviations, where it has them).
    table : Table, optional
        What ``--out`` writes instead of a model (CSV).
    figure : matplotlib.figure.Figure, optional
        The ``--plot`` figure, drawn already.

    Returns
    -------
    report, lines
        The same report and lines, to return from the command.

    Raises
    ------
    OutputPathError
        A file that cannot be written after all.
    """
    if outputs.out is not None and model is not None:
        try:
            model.save(outputs.out)
        except OSError as exc:
            raise OutputPathError(_cannot_write("out", outputs.out, exc)) from exc
        _wrote(report, lines, "model", outputs.out)
    elif outputs.out is not None and table is not None:
        write_csv(outputs.out, table.columns, table.values, "out", index=table.row_labels)
        _wrote(report, lines, "out", outputs.out)
    if outputs.coef_out is not None and model is not None:
        frame = model.to_frame(std=model.std() is not None)
        try:
            frame.to_csv(outputs.coef_out)
        except OSError as exc:
            raise OutputPathError(_cannot_write("coef-out", outputs.coef_out, exc)) from exc
        _wrote(report, lines, "coefficients", outputs.coef_out)
    if outputs.plot is not None and figure is not None:
        from ..plotting.figure import save_figure

        save_figure(figure, outputs.plot[0], outputs.plot[1], option="plot")
        _wrote(report, lines, "plot", outputs.plot[0])
    return report, lines


def _cannot_write(option: str, path: Path | str, exc: OSError) -> str:
    return f"{option}: cannot write {str(path)!r}: {exc.strerror or exc}"


def _wrote(report: dict[str, Any], lines: list[str], key: str, path: Path | str) -> None:
    report.setdefault("files", {})[key] = str(path)
    lines.append(f"wrote {path}")
