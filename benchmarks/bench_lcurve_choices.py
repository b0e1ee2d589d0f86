"""Benchmark: the sparse norms' L-curve on 80 series — its choices and its iterations.

Selects λ by ``select_lambda(method="lcurve")`` (the default range) for 80
series: norms "group" and "l1", orders 1 and 2, the jump-linear and the
random-walk systems, T = 150 and 400 (seeds 0-3) and T = 2000 (seeds 0-1).
Prints, per norm and order, the interior-point iterations of all the
selection's fits and the fits that did not converge, and writes every choice to
``--out`` (JSON). With ``--compare`` (a file written by another version) it
lists the series whose chosen λ differs: the L-curve's corner moves with
differences in its fits at the level of their tolerance, so a change of a
solver's path (where it stops, its start) shows here before it shows in
the timings.

Which way a choice moved is judged by ``--reference``: the choices of the same
selection with every candidate solved to 1e-9 (written by ``--tol 1e-9 --out``).
A change may move choices only towards them: the listing shows each moved
choice's reference, and the count of choices that agree with it is printed (72
of 80 at the default tolerance 1e-4). The reference is settled for order 1 (the
same choices at 1e-10); five order-2 series of T = 2000 choose differently at
1e-10, where some of their fits stop at working precision.

Run:  python benchmarks/bench_lcurve_choices.py [--out choices.json] [--compare old.json]
          [--reference exact.json] [--tol 1e-9]
"""

from __future__ import annotations

import argparse
import json
import warnings

import ltvmodels as ltv
from ltvmodels.core import ipm, sparse
from ltvmodels.estimators import selection


def cases():
    """(norm, order, system, T, seed) of the 80 series."""
    for norm in ("group", "l1"):
        for order in (1, 2):
            for system in ("jump", "rw"):
                for T in (150, 400, 2000):
                    for seed in range(4) if T < 2000 else range(2):
                        yield norm, order, system, T, seed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=None, help="write the choices to this JSON file")
    parser.add_argument("--compare", default=None, help="a JSON file of choices to compare with")
    parser.add_argument(
        "--reference",
        default=None,
        help="a JSON file of choices with exactly solved candidates (written with --tol 1e-9): "
        "how many choices agree with it",
    )
    parser.add_argument(
        "--tol",
        type=float,
        default=None,
        help="every candidate's solver tolerance (LCURVE_TOL and LCURVE_FAR_TOL)",
    )
    args = parser.parse_args()
    if args.tol is not None:  # every candidate's, the far ones' too
        selection.LCURVE_TOL = selection.LCURVE_FAR_TOL = args.tol
    counts = {"iterations": 0, "unconverged": 0}
    solve = ipm.fit_sparse_ipm

    def counted(*arguments, **options):
        result = solve(*arguments, **options)
        counts["iterations"] += result.iterations
        counts["unconverged"] += not result.converged
        return result

    sparse.fit_sparse_ipm = counted  # the solver that the sparse fits call
    rows = []
    try:
        for norm, order, system, T, seed in cases():
            if system == "jump":
                data = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=seed)
            else:
                data = ltv.systems.random_walk_system(T=T, seed=seed)
            counts.update(iterations=0, unconverged=0)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                choice = ltv.select_lambda(data.x, data.u, norm=norm, order=order, method="lcurve")
            rows.append(
                {
                    "case": [norm, order, system, T, seed],
                    "lam": choice.lam,
                    "n_fits": choice.n_fits,
                    "iterations": counts["iterations"],
                    "unconverged": counts["unconverged"],
                    "warnings": len(caught),
                }
            )
    finally:
        sparse.fit_sparse_ipm = solve
    print(f"{'norm':>5} {'order':>5} {'series':>6} {'iterations':>10} {'unconverged':>11}")
    for norm in ("group", "l1"):
        for order in (1, 2):
            part = [r for r in rows if r["case"][:2] == [norm, order]]
            print(
                f"{norm:>5} {order:>5} {len(part):>6} {sum(r['iterations'] for r in part):>10} "
                f"{sum(r['unconverged'] for r in part):>11}"
            )
    print(f"warnings: {sum(r['warnings'] for r in rows)}")
    if args.out:
        with open(args.out, "w", encoding="utf-8") as file:
            json.dump(rows, file, indent=1)
    reference = read_choices(args.reference)
    if reference:
        agree = sum(same(r["lam"], reference[tuple(r["case"])]) for r in rows)
        print(f"the choice of exactly solved candidates ({args.reference}): {agree} of {len(rows)}")
    if args.compare:
        before = read_choices(args.compare)
        changed = [r for r in rows if not same(before[tuple(r["case"])], r["lam"])]
        print(f"chosen λ differs on {len(changed)} of {len(rows)} series")
        for r in changed:
            exact = reference.get(tuple(r["case"]))
            mark = "" if exact is None else f"  (exactly solved: {exact:.6g})"
            print(f"  {r['case']}: {before[tuple(r['case'])]:.6g} -> {r['lam']:.6g}{mark}")


def read_choices(path: str | None) -> dict:
    """{case: chosen λ} of a file written with --out (empty without a path)."""
    if path is None:
        return {}
    with open(path, encoding="utf-8") as file:
        return {tuple(r["case"]): r["lam"] for r in json.load(file)}


def same(a: float, b: float) -> bool:
    """The same candidate (the refinements' λ are products of the grid's, to rounding)."""
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b))


if __name__ == "__main__":
    main()
