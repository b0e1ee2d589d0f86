"""``python -m ltvmodels``: the same as the ``ltvmodels`` command."""

from .cli import main

if __name__ == "__main__":
    raise SystemExit(main())
