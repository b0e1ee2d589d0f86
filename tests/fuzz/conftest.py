"""Configuration of the fuzzing suite: hypothesis profiles and the outcome summary.

Profiles (used by :func:`fuzz_strategies.fuzz_test`; every fuzz test exists
once per profile):

* ``fast`` — the default run and CI: 25 examples per test (fewer for the
  expensive ones), derandomized (fixed seeds, no example database), no
  deadline. ``python -m pytest tests/fuzz`` runs these.
* ``long`` — the same strategies, 8 times as many examples, in the tests
  marked ``slow``: ``python -m pytest tests/fuzz -m slow``.

``FUZZ_EXAMPLES_FAST`` / ``FUZZ_EXAMPLES_LONG`` override the base counts;
``FUZZ_SHRINK=1`` lets hypothesis shrink a failing example to a minimal one
(off by default: shrinking expensive calls can take minutes);
``FUZZ_SURVEY=1`` collects every distinct failure of a test instead of
stopping at the first one (see :mod:`fuzz_oracle`); ``FUZZ_LOG=path``
appends one line per accepted call (see :mod:`fuzz_oracle`).

At the end of a run the terminal summary lists, per fuzzed function, how many
calls returned a finite result, a finite result with documented ``None``
fields, or a documented library error.
"""

from __future__ import annotations

import os
import sys

from hypothesis import HealthCheck, Phase, settings

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

from fuzz_oracle import EXAMPLES, OUTCOMES, SURVEY, SURVEY_FAILURES  # noqa: E402

_COMMON = dict(
    deadline=None,
    derandomize=True,
    database=None,
    print_blob=False,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.filter_too_much,
        HealthCheck.large_base_example,
        HealthCheck.differing_executors,
    ],
)
# No shrinking by default: a failing example of an expensive call (λ selection, the
# command line) can take hypothesis minutes to shrink. FUZZ_SHRINK=1 turns it on to
# get minimal examples while debugging one test.
_SHRINK = os.environ.get("FUZZ_SHRINK", "") not in ("", "0") and not SURVEY
_PHASES = (Phase.explicit, Phase.reuse, Phase.generate) + ((Phase.shrink,) if _SHRINK else ())

settings.register_profile(
    "fast", max_examples=int(os.environ.get("FUZZ_EXAMPLES_FAST", "25")), phases=_PHASES, **_COMMON
)
settings.register_profile(
    "long", max_examples=int(os.environ.get("FUZZ_EXAMPLES_LONG", "200")), phases=_PHASES, **_COMMON
)


def pytest_terminal_summary(terminalreporter, exitstatus, config):  # noqa: ARG001
    if not OUTCOMES and not SURVEY_FAILURES:
        return
    rep = terminalreporter
    rep.write_sep("=", "ltvmodels fuzzing: outcomes per function")
    labels = sorted({label for label, _ in OUTCOMES})
    kinds = ("finite", "finite+None", "library error")
    width = max((len(label) for label in labels), default=10)
    rep.write_line(f"{'function':<{width}}  " + "  ".join(f"{k:>13}" for k in kinds))
    totals = dict.fromkeys(kinds, 0)
    for label in labels:
        counts = [OUTCOMES.get((label, k), 0) for k in kinds]
        for k, c in zip(kinds, counts, strict=True):
            totals[k] += c
        rep.write_line(f"{label:<{width}}  " + "  ".join(f"{c:>13}" for c in counts))
    total = sum(totals.values())
    rep.write_line(
        f"{sum(EXAMPLES.values())} examples in {len(EXAMPLES)} tests made "
        f"{total} accepted calls: {totals['finite']} finite results, {totals['finite+None']} "
        f"finite results with documented None fields, {totals['library error']} documented "
        f"library errors (failing calls are not counted)"
    )
    if SURVEY_FAILURES:
        rep.write_sep("=", "ltvmodels fuzzing: distinct failures (FUZZ_SURVEY)")
        for test, found in SURVEY_FAILURES.items():
            rep.write_line(f"--- {test}: {len(found)} distinct")
            for text in found.values():
                rep.write_line(text)
