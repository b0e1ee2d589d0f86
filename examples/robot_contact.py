"""
Paper Figs. 2–3: a two-link arm with Coulomb friction and a stiff wall
======================================================================

Simulates the arm of :mod:`ltvmodels.apps.robot` (computed-torque control along a
straight line into a wall, h = 0.02 s, N = 200) twice with different torque
noise, fits a piecewise-constant LTV model (group lasso, order 1) to the
normalized training run, and writes two figures: the training run against
the model's open-loop simulation (Fig. 2) and the validation run, where the
contact comes at a different time (Fig. 3). Prints the detected change
points, the true events and the simulation RMS errors. Headless.

Usage::

    python examples/robot_contact.py [--out robot.png] [--seed 0] [--validation-seed 1]

writes ``robot_train.png`` and ``robot_validation.png`` (from ``--out``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ltvmodels.apps.robot import plot_robot_experiment, robot_experiment


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--out",
        default="robot.png",
        help="base name of the figures, <stem>_train and <stem>_validation",
    )
    parser.add_argument("--seed", type=int, default=0, help="training noise seed (default: 0)")
    parser.add_argument(
        "--validation-seed", type=int, default=1, help="validation noise seed (default: 1)"
    )
    args = parser.parse_args(argv)
    result = robot_experiment(seed=args.seed, validation_seed=args.validation_seed)
    out = Path(args.out)
    for which in ("train", "validation"):
        path = out.with_name(f"{out.stem}_{which}{out.suffix or '.png'}")
        plot_robot_experiment(result, which).savefig(path, dpi=110)
        print(f"wrote {path}")
    train, val = result.train, result.validation
    print(
        f"training run: q̇₂ changes sign at {train.sign_change_index}, contact at "
        f"{train.contact_index}; validation run: {val.sign_change_index}, {val.contact_index}"
    )
    print(f"detected change points {[int(c) for c in result.changepoints]}")
    print(
        f"open-loop simulation RMS (normalized): training {result.rms_train:.3f}, "
        f"validation {result.rms_validation:.3f}"
    )
    return 0


if __name__ == "__main__":
    # Exit only on failure: the documentation's gallery runs this file in-process.
    if status := main():
        raise SystemExit(status)
