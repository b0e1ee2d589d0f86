"""The robot arm of the paper (Figs. 2–3) with measurement noise on its recorded states.

The normalized training run of :func:`ltvmodels.apps.robot.robot_experiment`
(T = 201, four states, two torques and a constant input) gets Gaussian noise
of standard deviation ``sd`` (in units of each state's standard deviation) on
every recorded state; the group-norm model of the experiment (λ = 0.02 λ_max
of the clean run) is then fitted on the noisy states three ways:

* as if the states were exact (today's fit);
* with ``measurement_noise="estimate"`` (EM estimates the sensor variance);
* with ``measurement_noise=sd**2`` (the sensor's variance given).

Printed: the open-loop simulation RMS error against the *clean* states on the
training run and on the validation run (another torque-noise seed, contact at
another time), the RMS error of the smoothed states against the clean ones,
EM's iterations and the estimated variance.

Run:  python benchmarks/bench_noisy_robot.py [--sds 0.05 0.1 0.2] [--em-max-iter 200]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import ltvmodels as ltv
from ltvmodels.apps.robot import robot_experiment


def rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sds", nargs="+", type=float, default=[0.05, 0.1, 0.2])
    parser.add_argument("--em-max-iter", type=int, default=200)
    args = parser.parse_args()
    experiment = robot_experiment()
    xt, ut = experiment.x_train, experiment.u_train
    xv, uv = experiment.x_validation, experiment.u_validation
    lam = 0.02 * ltv.lambda_max(xt, ut, norm="group")
    print(
        f"clean states: simulation RMS train {experiment.rms_train:.4f}, validation "
        f"{experiment.rms_validation:.4f} (λ = {lam:.4g})"
    )
    print(
        f"{'sd':>5}  {'fit':<22} {'train':>7} {'valid.':>7} {'states':>7} "
        f"{'EM it':>6} {'time s':>7}  est. variance"
    )
    for sd in args.sds:
        noisy = xt + sd * np.random.default_rng(7).standard_normal(xt.shape)
        fits = [
            ("exact states", {}),
            ("EM, variance estimated", {"measurement_noise": "estimate"}),
            ("EM, variance given", {"measurement_noise": sd**2}),
        ]
        for name, extra in fits:
            if extra:
                extra["em_max_iter"] = args.em_max_iter
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # EM's convergence warnings: reported below
                model = ltv.fit(noisy, ut, lam=lam, norm="group", **extra)
            seconds = time.perf_counter() - start
            states = getattr(model, "states", None)
            states_error = rms(noisy if states is None else states, xt)
            iterations = model.info.get("em_iterations", "")
            variance = "" if states is None else np.round(model.measurement_noise, 4).tolist()
            print(
                f"{sd:5.2f}  {name:<22} {rms(model.simulate(xt[0], ut), xt):7.4f} "
                f"{rms(model.simulate(xv[0], uv), xv):7.4f} {states_error:7.4f} "
                f"{iterations!s:>6} {seconds:7.2f}  {variance}",
                flush=True,
            )


if __name__ == "__main__":
    main()
