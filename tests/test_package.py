"""The package namespace: every public name loads on use, moved modules say where they went."""

from __future__ import annotations

import importlib.metadata
import re
from pathlib import Path

import pytest

import ltvmodels

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", sorted(ltvmodels.__all__))
def test_every_public_name_resolves(name):
    assert getattr(ltvmodels, name) is not None
    assert name in dir(ltvmodels)


def test_unknown_names_raise_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'fitt'"):
        ltvmodels.fitt  # noqa: B018


@pytest.mark.parametrize(
    "old, new", [("rl", "ltvmodels.apps.rl"), ("gym_rl", "ltvmodels.apps.gym_rl")]
)
def test_moved_applications_warn_and_still_work(old, new):
    with pytest.warns(DeprecationWarning, match=f"moved to {new}"):
        module = getattr(ltvmodels, old)
    assert module.__name__ == new


def test_the_version_is_written_in_one_place():
    # pyproject.toml reads it from ltvmodels.__version__; the installed metadata agrees.
    assert re.fullmatch(r"\d+\.\d+\.\d+", ltvmodels.__version__)
    assert importlib.metadata.version("ltvmodels") == ltvmodels.__version__
    assert 'dynamic = ["version"]' in (ROOT / "pyproject.toml").read_text()
