"""Benchmark: many series — ``fit_many`` against a bare loop of ``fit`` and statsmodels.

Data: ``--units`` jump-linear series (n = 2, m = 1) of ``--T`` samples, as a
mapping {unit: (x, u)}. For each case (``sq`` with a fixed λ, ``sq`` with
``lam="auto"``, ``group`` with a fixed λ) it prints units per second of

* a bare loop of ``ltvmodels.fit`` in this process (the reference),
* ``fit_many(n_jobs=1)`` (this process; its per-unit overhead over the bare
  loop, target ≤ 20 %), ``fit_many(n_jobs=2)`` (a local process pool; the
  speed-up over n_jobs=1, target ≥ 1.7× on 2 cores) — with
  ``keep_models=False`` as the bare loop, which drops its models, and again
  with the models kept (target ≥ 1.5×; 10⁴ models of T = 500 are 0.6 GB) —
  after a first call has started the pool's workers; each the best of
  ``--repeat`` runs (3), the five taking turns,
  and ``fit_many`` on a 2-worker ``dask.distributed.LocalCluster``
  (``--no-cluster`` skips it; it runs last, so that no scheduler thread is
  alive in this process during the other timings),

and, in the same run on the first ``--peer-units`` series, statsmodels' Kalman
smoother of the same time-varying-parameter model at the same λ (case ``sq``)
and statsmodels' maximum-likelihood fit of its variances (case ``auto``: the
peer of ``lam="auto"``, whose criterion is the same marginal likelihood),
with the ratio and the agreement of the smoothed coefficients / of λ.

Small jobs (``--small``, run first): 50, 400 and 3,000 jump-linear units of
T = 200 in a long DataFrame, ``lam=10.0`` and ``lam="auto"``, fitted with
``n_jobs=1``, ``n_jobs=2`` and the default (``n_jobs=None``), each with the
worker pool stopped before the call ("cold": the first call of a session
starts its workers) and with the workers of the call before still running
("warm"). Targets on 2 cores: the default never more than 10 % slower than
``n_jobs=1``; ``n_jobs=2`` at least 1.7× faster than ``n_jobs=1`` for the
3,000-unit ``lam="auto"`` job.

Run:  python benchmarks/bench_many.py [--units 10000] [--T 500] [--cases sq auto group]
      python benchmarks/bench_many.py --small-only     (the small-jobs table alone)
      python benchmarks/bench_many.py --no-small --cases sq --no-cluster  (10⁴ units, sq)
Peers: ``pip install ".[bench,dask]"``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import ltvmodels as ltv

LAM = 10.0
GROUP_LAM = 5.0


def make_units(n_units: int, T: int) -> dict:
    return {
        unit: (d.x, d.u)
        for unit, d in enumerate(
            ltv.systems.jump_linear(T=T, change_at=T // 2, seed=unit) for unit in range(n_units)
        )
    }


def long_table(n_units: int, T: int):
    """Jump-linear units as one long DataFrame: columns unit, t, x1, x2, u."""
    import pandas as pd

    frames = []
    for unit in range(n_units):
        d = ltv.systems.jump_linear(T=T, change_at=T // 2, seed=unit)
        frames.append(
            pd.DataFrame(
                {"unit": unit, "t": np.arange(T), "x1": d.x[:, 0], "x2": d.x[:, 1], "u": d.u[:, 0]}
            )
        )
    return pd.concat(frames, ignore_index=True)


def small_jobs() -> None:
    """The small-jobs table (see the module docstring).

    Each cell is the best of 5 runs (3 for 3,000 units); the three ``n_jobs``
    take turns within each repetition, each after the same preparation (the
    pool stopped, or its workers started), so that the ratios compare runs
    under the same conditions.
    """
    from ltvmodels.estimators.engines import shutdown_pool

    print("small jobs: jump-linear units of T = 200 (n = 2, m = 1) in a long DataFrame")
    print("seconds (ratio = time of n_jobs=1 / time), best of 5 (3 for 3,000 units)")
    rule = "-" * 16
    print(f"{'':16s} {rule} cold {rule}   {rule} warm {rule}")
    columns = "n_jobs=1  n_jobs=2        default       "
    print(f"  units  lam     {columns}   {columns}")
    table = long_table(3000, 200)
    for n_units in (50, 400, 3000):
        frame = table[table["unit"] < n_units]
        repeat = 3 if n_units > 400 else 5
        for lam in (10.0, "auto"):

            def run(n_jobs, frame=frame, lam=lam):
                ms = ltv.fit_many(
                    frame,
                    by="unit",
                    state=["x1", "x2"],
                    inputs="u",
                    time="t",
                    lam=lam,
                    n_jobs=n_jobs,
                    keep_models=False,
                    progress=False,
                )
                assert not ms.errors, ms.errors

            run(1)  # compile and load the kernels of this case
            text = ""
            for cold in (True, False):
                times = {1: [], 2: [], None: []}
                for _ in range(repeat):
                    for n_jobs in times:
                        if cold:
                            shutdown_pool()
                            time.sleep(0.5)  # the stopped workers gone, as at a session's start
                        else:
                            run(2)  # the pool's workers are running
                        times[n_jobs].append(timed(lambda: run(n_jobs))[0])
                one, two, default = (min(times[n_jobs]) for n_jobs in times)
                text += (
                    f"  {one:6.3f}  {two:6.3f} ({one / two:4.2f}x) {default:6.3f} "
                    f"({one / default:4.2f}x) "
                )
            print(f"  {n_units:5d}  {str(lam):6s}{text}")
    shutdown_pool()


def timed(func):
    start = time.perf_counter()
    result = func()
    return time.perf_counter() - start, result


def statsmodels_tvp(x: np.ndarray, u: np.ndarray, lam: float | None):
    """statsmodels' diffuse Kalman smoother of k_{t+1} = k_t + w_t, x[t+1] = (I ⊗ φ_tᵀ) k_t + e_t.

    With ``lam`` the variances are σ_i² (obs) and σ_i²/λ² (drift) at a σ_i² whose
    value does not change the smoothed mean; with ``lam=None`` the σ_i² and the
    shared λ are estimated by maximum likelihood (statsmodels' ``fit``). Returns
    (smoothed k (N, K), λ).
    """
    from statsmodels.tsa.statespace.kalman_smoother import KalmanSmoother
    from statsmodels.tsa.statespace.mlemodel import MLEModel

    phi = np.hstack([x[:-1], u[:-1]])
    y = x[1:]
    N, p = phi.shape
    n = y.shape[1]
    if lam is not None:  # the bare smoother (statsmodels' fastest path), σ² = 1
        smoother = KalmanSmoother(k_endog=n, k_states=n * p, k_posdef=n * p)
        smoother.bind(np.asfortranarray(y.T))
        smoother["design"] = np.einsum("ij,ta->ijat", np.eye(n), phi).reshape(n, n * p, N)
        smoother["obs_cov"] = np.eye(n)
        smoother["transition"] = np.eye(n * p)
        smoother["selection"] = np.eye(n * p)
        smoother["state_cov"] = np.eye(n * p) / lam**2
        smoother.initialize_diffuse()
        return smoother.smooth().smoothed_state.T, lam

    class TVP(MLEModel):
        def __init__(self):
            super().__init__(y, k_states=n * p, k_posdef=n * p, initialization="diffuse")
            design = np.zeros((n, n * p, N))
            for i in range(n):
                design[i, i * p : (i + 1) * p, :] = phi.T
            self["design"] = design
            self["transition"] = np.eye(n * p)
            self["selection"] = np.eye(n * p)

        @property
        def start_params(self):  # log σ_1², …, log σ_n², log λ
            return np.r_[np.log(np.var(y, axis=0)), np.log(LAM)]

        def update(self, params, **kwargs):
            params = super().update(params, **kwargs)
            var, lam_ = np.exp(params[:n]), np.exp(params[n])
            self["obs_cov"] = np.diag(var)
            self["state_cov"] = np.kron(np.diag(var), np.eye(p) / lam_**2)

    result = TVP().fit(disp=False)
    return result.smoothed_state.T, float(np.exp(result.params[n]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--units", type=int, default=10000)
    parser.add_argument("--T", type=int, default=500)
    parser.add_argument(
        "--cases", nargs="+", default=["sq", "auto", "group"], choices=["sq", "auto", "group"]
    )
    parser.add_argument("--peer-units", type=int, default=50)
    parser.add_argument("--no-cluster", action="store_true")
    parser.add_argument(
        "--repeat", type=int, default=3, help="runs of each timing; the best is printed"
    )
    parser.add_argument("--small-only", action="store_true", help="only the small-jobs table")
    parser.add_argument("--no-small", action="store_true", help="without the small-jobs table")
    args = parser.parse_args()
    if not args.no_small:
        small_jobs()
    if args.small_only:
        return

    data = make_units(args.units, args.T)
    units = list(data.items())
    cases = {
        case: options
        for case, options in (
            ("sq", dict(lam=LAM)),
            ("auto", dict(lam="auto")),
            ("group", dict(lam=GROUP_LAM, norm="group")),
        )
        if case in args.cases
    }
    for options in cases.values():  # compile the kernels before the timings
        ltv.fit(*data[0], **options)
    # The pool's workers are started (they stay for later calls): these rows time a
    # session's later calls; the small-jobs table times the first one too ("cold").
    ltv.fit_many(dict(units[:20]), n_jobs=2, lam=LAM, progress=False)
    print(
        f"{args.units} jump-linear units, T = {args.T}, n = 2, m = 1 (warm worker pool), "
        f"best of {args.repeat}"
    )
    # No cluster is alive while this process is timed alone: an in-process
    # scheduler's threads take the interpreter lock from the fits (~40 % here).
    single = {}
    rate = args.units
    for case, options in cases.items():

        def bare_loop():  # the models are dropped, as with keep_models=False
            for _, (x, u) in units:
                ltv.fit(x, u, **options)

        def many(n_jobs, keep_models):
            ms = ltv.fit_many(
                data, n_jobs=n_jobs, keep_models=keep_models, progress=False, **options
            )
            assert not ms.errors, ms.errors

        runs = {
            "bare": bare_loop,
            "one": lambda: many(1, False),
            "two": lambda: many(2, False),
            "one_kept": lambda: many(1, True),
            "two_kept": lambda: many(2, True),
        }
        times: dict[str, list[float]] = {name: [] for name in runs}
        for _ in range(args.repeat):  # in turns, so that a slow spell of the machine hits all
            for name, run in runs.items():
                times[name].append(timed(run)[0])
        bare, one, two, one_kept, two_kept = (min(times[name]) for name in runs)
        single[case] = one
        print(f"\n{case} {options}")
        print(
            f"  bare fit loop            {rate / bare:7.0f} units/s  "
            f"({bare / rate * 1e3:.3f} ms per unit)"
        )
        print(
            f"  fit_many n_jobs=1        {rate / one:7.0f} units/s  "
            f"(overhead {100 * (one / bare - 1):+.1f} % of the fit time)"
        )
        print(
            f"  fit_many n_jobs=2        {rate / two:7.0f} units/s  "
            f"(speed-up {one / two:.2f}x over n_jobs=1)"
        )
        print(
            f"  with the models kept:    {rate / one_kept:7.0f} and {rate / two_kept:.0f} "
            f"units/s (speed-up {one_kept / two_kept:.2f}x)"
        )
        if case in ("sq", "auto"):
            peer_units = units[: args.peer_units]
            statsmodels_tvp(*units[0][1], LAM)  # import statsmodels outside the timing
            ours, models = timed(lambda: [ltv.fit(x, u, **options) for _, (x, u) in peer_units])
            peer, results = timed(
                lambda: [
                    statsmodels_tvp(x, u, None if case == "auto" else LAM)
                    for _, (x, u) in peer_units
                ]
            )
            dk = max(float(np.max(np.abs(m.k - k))) for m, (k, _) in zip(models, results))
            what = "MLE fit" if case == "auto" else "smoother"
            line = (
                f"  statsmodels {what} on {len(peer_units)} units: "
                f"{peer / len(peer_units) * 1e3:.2f} ms per unit vs ours "
                f"{ours / len(peer_units) * 1e3:.2f} ms: ratio {peer / ours:.1f}x; "
                f"max |Δk| {dk:.1e}"
            )
            if case == "auto":
                rel = max(abs(m.lam / lam - 1) for m, (_, lam) in zip(models, results))
                line += f"; λ agrees to {rel:.1e} (relative)"
            print(line)
    if args.no_cluster:
        return
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        client.run(lambda: ltv.fit(*make_units(1, 100)[0], lam=1.0))  # warm the workers
        print("\nfit_many on a LocalCluster of 2 worker processes")
        for case, options in cases.items():
            dask_time, _ = timed(
                lambda: ltv.fit_many(
                    data, engine=client, progress=False, keep_models=False, **options
                )
            )
            print(
                f"  {case:6s} {args.units / dask_time:9.0f} units/s  "
                f"(speed-up {single[case] / dask_time:.2f}x over fit_many n_jobs=1)"
            )


if __name__ == "__main__":
    main()
