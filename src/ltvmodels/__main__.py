"""``python -m ltvmodels``: the same as the ``ltvmodels`` command."""

from .cli import main

__all__: list[str] = []

if __name__ == "__main__":
    raise SystemExit(main())
