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

Run:  python benchmarks/bench_lcurve_choices.py [--out choices.json] [--compare old.json]
"""

from __future__ import annotations

import argparse
import json
import warnings

import ltvmodels as ltv
from ltvmodels.core import ipm, sparse


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
    args = parser.parse_args()
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
    if args.compare:
        with open(args.compare, encoding="utf-8") as file:
            before = {tuple(r["case"]): r for r in json.load(file)}
        changed = [r for r in rows if before[tuple(r["case"])]["lam"] != r["lam"]]
        print(f"chosen λ differs on {len(changed)} of {len(rows)} series")
        for r in changed:
            print(f"  {r['case']}: {before[tuple(r['case'])]['lam']:.6g} -> {r['lam']:.6g}")


if __name__ == "__main__":
    main()
