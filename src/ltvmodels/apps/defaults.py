"""Settings of the demos that the command line shows in its help.

Kept apart from :mod:`.demos` and free of heavy imports, so that
``ltvmodels --help`` answers without loading the solvers.
"""

__all__ = ["JUMP_LINEAR_LAM", "DEFAULT_DEMO_OUT"]

JUMP_LINEAR_LAM = 30.0
"""Fixed λ of the jump-linear demo (norm="sq", order=1).

Chosen by comparing λ ∈ {1, 3, 5, 10, 20, 30, 50, 100, 300} on seeds 0, 1, 2:
λ = 30 gave the smallest RMS coefficient error for all three seeds (about
0.05–0.06; λ = 10 and λ = 100 roughly double it, least-squares LTI triples it)
and lies at or next to the maximum of the log marginal likelihood
(``model.loglik``). The figure shows the expected trade-off of the squared
norm: low noise in the constant segments, the jump smoothed over about 50
steps (the ``group`` norm, the demo's default, recovers the jump sharply).
"""

DEFAULT_DEMO_OUT = {
    "jump-linear": "ltvmodels-jump-linear.png",
    "robot": "ltvmodels-robot.png",
    "chirp": "ltvmodels-chirp.png",
    "rl": "ltvmodels-rl.png",
    "pendulum": "ltvmodels-pendulum.png",
}
"""Default image file of each demo (the robot demo writes ``<stem>_train`` and
``<stem>_validation`` next to it)."""
