"""The package namespace: every public name loads on use, moved modules say where they went."""

from __future__ import annotations

import pytest

import ltvmodels


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


def test_version():
    assert ltvmodels.__version__ == "0.2.0"
