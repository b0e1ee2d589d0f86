"""``ModelSet``: the models of many units fitted by :func:`ltvmodels.fit_many`, with their summary.

A model set maps each unit that was fitted to its model, keeps one summary
record per unit (fitted or not) and the error message of every unit whose
fit failed. Models live in memory, in a directory (one model file per unit,
read back on access), or nowhere (only the summary was kept).

On disk (:meth:`ModelSet.save`, :func:`load_many`) a model set is a directory
with one ``.npz`` model file per fitted unit (:meth:`RegressionModel.save`)
and ``manifest.json``: the format version, the name of the unit column, and
per unit, in the order of the input, the unit (with its type), the name of
its model file in the directory (or null), its error (or null) and its
summary record (see :mod:`ltvmodels.results.manifest`).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from ..validation.arrays import describe
from .loading import load
from .manifest import (
    MANIFEST,
    check_units,
    manifest_text,
    model_file_name,
    output_directory,
    plain_file_name,
    read_manifest,
    write_manifest,
)

__all__ = ["ModelSet", "load_many"]


class ModelSet(Mapping):
    """Models fitted per unit, a summary row per unit and the units that failed.

    ``ms[unit]`` is the model of a unit (as the estimator returned it);
    iterating yields the units that were fitted, in input order; ``len(ms)``
    counts them. Built by :func:`ltvmodels.fit_many` and
    :func:`ltvmodels.load_many`.

    Attributes
    ----------
    units : list
        Every unit, in input order, fitted or not.
    errors : dict
        ``{unit: message}`` for the units whose fit failed.
    records : list of dict
        One summary record per unit, in input order (what :attr:`summary`
        tabulates): the unit under ``"unit"``, and JSON-compatible values
        (:meth:`save` writes any other value as text).
    by : str
        The name of the unit column (the index name of :attr:`summary`).
    directory : pathlib.Path or None
        Where the model files of units not held in memory are.
    """

    def __init__(
        self,
        units: list,
        records: list[dict],
        errors: dict,
        *,
        by: str = "unit",
        models: dict | None = None,
        directory: str | os.PathLike | None = None,
        files: dict | None = None,
    ) -> None:
        self.units = list(units)
        self.records = list(records)
        self.errors = dict(errors)
        self.by = by
        self._models = dict(models or {})
        self.directory = None if directory is None else Path(directory)
        self._files = dict(files or {})
        for unit, name in self._files.items():
            if not plain_file_name(name):
                raise ValueError(
                    f"files: the model file of unit {unit!r} must be a file name in "
                    f"directory, without a path; received {name!r}"
                )
        self._summary: Any = None
        self._fitted = {unit for unit in self.units if unit not in self.errors}

    # -- the mapping ----------------------------------------------------------------
    def __getitem__(self, unit: Any) -> Any:
        if unit in self._models:
            return self._models[unit]
        if unit in self.errors:
            raise KeyError(f"unit {unit!r} was not fitted: {self.errors[unit]}")
        if unit in self._files and self.directory is not None:
            return load(self.directory / self._files[unit])
        if unit in self._fitted:
            raise KeyError(
                f"unit {unit!r}: its model was not kept (fit_many(..., keep_models=False) "
                "without models_dir); pass models_dir=DIRECTORY to keep the models on disk"
            )
        raise KeyError(f"unit {unit!r} is not in this model set ({len(self.units)} units)")

    def __iter__(self) -> Iterator:
        return iter(self.fitted_units())

    def __len__(self) -> int:
        return len(self.units) - len(self.errors)

    def __contains__(self, unit: object) -> bool:
        return unit in self._fitted

    def fitted_units(self) -> list:
        """The units that were fitted, in input order."""
        return [unit for unit in self.units if unit not in self.errors]

    def __repr__(self) -> str:
        where = (
            "in memory" if self._models else f"in {self.directory}" if self._files else "not kept"
        )
        return (
            f"ModelSet({len(self.units)} units, {len(self)} fitted, "
            f"{len(self.errors)} failed, models {where})"
        )

    # -- the summary ------------------------------------------------------------------
    @property
    def summary(self) -> Any:
        """A pandas DataFrame with one row per unit, indexed by unit (in input order).

        Columns: ``T`` (time steps), ``missing`` (time steps with a missing
        state or input), ``lam`` and ``lam_method`` (how λ was chosen:
        "given", or the criterion of ``lam="auto"``), ``noise_var_<state>``,
        ``loglik``, ``rms`` (root mean square of the one-step prediction
        errors over the observed transitions), ``n_changes`` and
        ``change_times`` (the change points of the sparse and segmented
        fits, as times where the data had them; empty for ``norm="sq"``),
        ``status`` (the fit status, "error" for a unit that failed),
        ``seconds`` (the unit's fit time). Needs pandas.
        """
        if self._summary is None:
            try:
                import pandas as pd
            except ImportError:  # pragma: no cover - the pandas extra is missing
                raise ImportError(
                    "ModelSet.summary needs pandas: pip install 'ltvmodels[pandas]' (the "
                    "records are in ModelSet.records without it)"
                ) from None
            frame = pd.DataFrame.from_records(self.records)
            if "unit" in frame:
                frame = frame.set_index("unit")
                frame.index.name = self.by
            self._summary = frame
        return self._summary

    # -- persistence --------------------------------------------------------------------
    def save(self, directory: str | os.PathLike) -> None:
        """Write the model set to a directory that :func:`ltvmodels.load_many` reads.

        One model file per fitted unit whose model was kept (written from
        memory, or copied from this set's directory) and ``manifest.json``
        (see :mod:`ltvmodels.results.manifest`). Saving to the directory the
        models are read from keeps their files as they are. The manifest is
        written last and atomically: a failure never leaves a half-written one.

        Parameters
        ----------
        directory : str or path-like
            The directory, created (with its parents) if needed.

        Raises
        ------
        TypeError
            ``directory`` is not a path, or a unit is of a type the manifest
            cannot store (checked before anything is written).
        OutputPathError
            ``directory`` is an existing file, or cannot be created or written.
        """
        check_units(self.units, "units")
        target = output_directory(directory, "directory")
        here = target.resolve()
        own = self.directory is not None and self.directory.resolve() == here
        files = {}
        for position, unit in enumerate(self.units):
            if unit in self.errors:
                continue
            if own and unit in self._files:  # already there
                files[unit] = self._files[unit]
                continue
            name = model_file_name(position)
            if unit in self._models:
                self[unit].save(target / name)
            elif unit in self._files and self.directory is not None:
                shutil.copyfile(self.directory / self._files[unit], target / name)
            else:
                continue
            files[unit] = name
        entries = [
            {
                "unit": unit,
                "file": files.get(unit),
                "error": self.errors.get(unit),
                "summary": record,
            }
            for unit, record in zip(self.units, self.records)
        ]
        write_manifest(target, manifest_text(self.by, entries))


def load_many(directory: str | os.PathLike) -> ModelSet:
    """Read a model set written by :meth:`ModelSet.save` or ``fit_many(models_dir=...)``.

    The models stay on disk: ``ms[unit]`` reads a unit's model file when
    asked. Only files inside ``directory`` are read: the manifest names
    them by file name alone.

    Parameters
    ----------
    directory : str or path-like
        The directory holding ``manifest.json`` and the model files.

    Returns
    -------
    ModelSet
        Units come back with their type (dates, times, numbers, text; see
        :mod:`ltvmodels.results.manifest`); a manifest of format 1 gives the
        units that are not strings or numbers as their text.

    Raises
    ------
    TypeError
        ``directory`` is not a path.
    FileNotFoundError
        No ``manifest.json`` in ``directory``.
    ModelFileError
        The manifest is not one this version reads, or is damaged (an entry
        that is not an object, lacks a key, has a unit that cannot be one, a
        file name with a path, an error or summary of the wrong type, a unit
        listed twice); the message names the entry and the problem.
    """
    if not isinstance(directory, (str, os.PathLike)):
        raise TypeError(
            f"directory: expected a directory path (str or pathlib.Path), "
            f"received {describe(directory)}"
        )
    path = Path(directory) / MANIFEST
    if not path.is_file():
        raise FileNotFoundError(
            f"directory: {directory} holds no {MANIFEST}; expected a directory written by "
            "ModelSet.save or fit_many(..., models_dir=...)"
        )
    by, units, records, errors, files = read_manifest(path)
    return ModelSet(units, records, errors, by=by, directory=directory, files=files)
