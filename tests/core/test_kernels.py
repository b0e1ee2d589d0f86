"""The block-size-specialized kernels (small blocks, long series) equal the generic ones."""

import tracemalloc

import numpy as np
import pytest

import ltvmodels as ltv
from ltvmodels.core import banded


@pytest.mark.parametrize("order", [1, 2])
def test_fixed_block_kernels_equal_generic(monkeypatch, order):
    rng = np.random.default_rng(7)
    x = rng.standard_normal((120, 2))
    u = rng.standard_normal((120, 1))
    assert isinstance(banded.kernel_size(119, 3), tuple)  # small blocks: specialized
    fixed = ltv.fit(x, u, lam=3.0, order=order)
    monkeypatch.setattr(banded, "FIXED_BLOCK_SMALL_B", 0)
    assert banded.kernel_size(119, 3) == 3
    generic = ltv.fit(x, u, lam=3.0, order=order)
    np.testing.assert_allclose(fixed.k, generic.k, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(fixed.cov, generic.cov, rtol=1e-12, atol=1e-14)
    assert fixed.loglik == pytest.approx(generic.loglik, rel=1e-13)


@pytest.mark.slow
def test_long_series_agrees_with_kalman_smoother():
    """Above the size threshold (specialized kernels, as used for long series) the
    banded solver still equals the independent Kalman smoother."""
    from ltvmodels.systems import random_walk_system

    data = random_walk_system(T=60_000, n=3, m=2, seed=3)
    assert (data.N * (data.n + data.m)) >= banded.FIXED_BLOCK_MIN_SIZE
    for order in (1, 2):
        model = ltv.fit(data.x, data.u, lam=30.0, order=order, noise_var=0.01)
        smoothed = ltv.kalman_smoother(data.x, data.u, lam=30.0, order=order, noise_var=0.01)
        scale = np.abs(model.k).max()
        assert np.abs(model.k - smoothed.k).max() < 1e-8 * scale
        np.testing.assert_allclose(model.cov, smoothed.cov, rtol=1e-6, atol=1e-12)
        assert model.loglik == pytest.approx(smoothed.loglik, rel=1e-9)


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0], [-1.0, 3.0, -3.0, 1.0]])
@pytest.mark.parametrize("q, p", [(1, 5), (3, 4), (1, 10)])
def test_shared_rows_solver_equals_the_general_block_solver(coeffs, q, p):
    """solve_shared_rows (the fused sweeps of a scalar λ) against solve_block_banded on
    the same system: the solution, covariances, log det and the residual and penalty
    sums. p = 10 takes the kernels compiled for a run-time block size."""
    rng = np.random.default_rng(3)
    N, n = 80, 3
    coeffs = np.array(coeffs)
    phi = rng.standard_normal((N, q, p))
    y = rng.standard_normal((N, q, n))
    w = rng.uniform(0.5, 4.0, p)
    shared = banded.solve_shared_rows(phi, y, w, coeffs, compute_cov=True)
    system = banded.BlockSystem(phi, 1, 1.0, np.zeros((0, p, p)), np.diag(w), coeffs)
    rhs = np.einsum("tja,tji->tai", phi, y)
    general = banded.solve_block_banded(system, rhs, compute_cov=True)
    theta = np.swapaxes(general.theta, 1, 2)  # (N, n, p)
    np.testing.assert_allclose(shared.theta, theta, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(shared.cov, general.cov, rtol=1e-12, atol=1e-13)
    assert shared.logdet == pytest.approx(general.logdet, rel=1e-13)
    residuals = y - np.einsum("tia,tja->tji", theta, phi)
    np.testing.assert_allclose(
        shared.rss, np.einsum("tji,tji->i", residuals, residuals), rtol=1e-12
    )
    d = len(coeffs) - 1
    differences = sum(c * theta[j : N - d + j] for j, c in enumerate(coeffs))
    np.testing.assert_allclose(shared.squares, np.einsum("tia,a->i", differences**2, w), rtol=1e-12)
    assert shared.gram_trace == pytest.approx(np.sum(phi**2), rel=1e-13)
    # without covariances a first difference keeps the lower triangles of the factor's
    # diagonal blocks alone, packed, and recomputes the others: the same numbers, bit
    # for bit
    without = banded.solve_shared_rows(phi, y, w, coeffs, compute_cov=False)
    assert without.cov is None
    np.testing.assert_array_equal(without.theta, shared.theta)
    assert (without.logdet, without.gram_trace) == (shared.logdet, shared.gram_trace)
    np.testing.assert_array_equal(without.rss, shared.rss)
    np.testing.assert_array_equal(without.squares, shared.squares)


def test_shared_rows_solver_without_covariances_stores_packed_diagonal_blocks():
    """A first difference without covariances allocates the lower triangles of the
    factor's diagonal blocks (N, p(p+1)/2) and Θ (N, n, p), nothing else of size N
    (tracemalloc's peak)."""
    rng = np.random.default_rng(4)
    N, q, p, n = 4000, 1, 5, 3
    phi = rng.standard_normal((N, q, p))
    y = rng.standard_normal((N, q, n))
    coeffs, w = np.array([-1.0, 1.0]), np.full(p, 9.0)
    banded.solve_shared_rows(phi, y, w, coeffs, compute_cov=False)  # compiled before
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        banded.solve_shared_rows(phi, y, w, coeffs, compute_cov=False)
        peak = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    needed = 8 * N * (p * (p + 1) // 2 + n * p)
    # full diagonal blocks would add 8 N p(p−1)/2, the off-diagonal ones 8 N p² more
    assert needed <= peak < needed + 8 * N * p


def test_shared_rows_solver_reports_a_singular_system():
    phi = np.zeros((30, 1, 2))  # no data: a first difference leaves H singular
    with pytest.raises(ltv.SingularProblemError, match="singular"):
        banded.solve_shared_rows(
            phi, np.zeros((30, 1, 1)), np.ones(2), np.array([-1.0, 1.0]), compute_cov=False
        )


@pytest.mark.parametrize("coeffs", [[-1.0, 1.0], [1.0, -2.0, 1.0]])
@pytest.mark.parametrize("q", [1, 2])
def test_weighted_rows_factor_equals_a_dense_solve(coeffs, q):
    """One factorization per output of Σ_j a_tjc φφᵀ + DᵀD ⊗ diag(w_c) (the robust losses'
    Newton systems) solves each output's system as a dense solve does; outputs left
    inactive are not touched."""
    rng = np.random.default_rng(3)
    N, p, n = 25, 3, 3
    coeffs = np.array(coeffs)
    phi = rng.standard_normal((N, q, p))
    a = rng.uniform(0.05, 1.0, (N, q, n))
    w = rng.uniform(0.5, 4.0, (n, p))
    rhs = rng.standard_normal((n, N, p, 2))
    active = np.array([True, False, True])
    forward = rhs.copy()
    factor = banded.WeightedRowsFactor(phi, a, w, coeffs, forward, active)
    factor.finish(forward)
    solved = factor.solve(rhs.copy())
    d = len(coeffs) - 1
    D = np.zeros((N - d, N))
    for row in range(N - d):
        D[row, row : row + d + 1] = coeffs
    for c in range(n):
        if not active[c]:
            np.testing.assert_array_equal(forward[c], rhs[c])
            np.testing.assert_array_equal(solved[c], rhs[c])
            continue
        H = np.kron(D.T @ D, np.diag(w[c]))
        for t in range(N):
            H[t * p : (t + 1) * p, t * p : (t + 1) * p] += np.einsum(
                "j,ja,jb->ab", a[t, :, c], phi[t], phi[t]
            )
        expected = np.linalg.solve(H, rhs[c].reshape(N * p, 2)).reshape(N, p, 2)
        np.testing.assert_allclose(forward[c], expected, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(solved[c], expected, rtol=1e-10, atol=1e-12)


def test_weighted_rows_factor_reports_a_singular_system():
    phi = np.zeros((10, 1, 2))  # no data: DᵀD ⊗ diag(w) alone is singular
    with pytest.raises(ltv.SingularProblemError, match="singular"):
        banded.WeightedRowsFactor(
            phi,
            np.ones((10, 1, 1)),
            np.ones((1, 2)),
            np.array([-1.0, 1.0]),
            np.zeros((1, 10, 2, 1)),
            np.ones(1, dtype=bool),
        )


def _dense_weighted_rows(phi, a, w, coeffs, c):
    """H_c = blkdiag_t(Σ_j a_tjc φφᵀ) + DᵀD ⊗ diag(w_c) as a dense matrix."""
    N, _, p = phi.shape
    d = len(coeffs) - 1
    D = np.zeros((N - d, N))
    for row in range(N - d):
        D[row, row : row + d + 1] = coeffs
    H = np.kron(D.T @ D, np.diag(w[c]))
    for t in range(N):
        H[t * p : (t + 1) * p, t * p : (t + 1) * p] += np.einsum(
            "j,ja,jb->ab", a[t, :, c], phi[t], phi[t]
        )
    return H


@pytest.mark.parametrize("q", [1, 2])
@pytest.mark.parametrize("zeros", [0.0, 0.4])
def test_weighted_rows_kalman_equals_a_dense_solve(q, zeros):
    """The covariance-form (Kalman) solve of the first-difference systems, rows given by
    weight a and target b, equals a dense solve of H_c θ = Σ_j b φ; rows of weight 0 (the
    semismooth Newton model's outliers) and a scaled difference c_1 (θ_{t+1} − θ_t) too;
    outputs left inactive are not touched."""
    rng = np.random.default_rng(5)
    N, p, n = 40, 3, 3
    coeffs = np.array([-1.5, 1.5])
    phi = rng.standard_normal((N, q, p))
    a = rng.uniform(0.05, 1.0, (N, q, n))
    a[rng.random((N, q, n)) < zeros] = 0.0
    targets = rng.standard_normal((N, q, n))
    w = rng.uniform(0.5, 4.0, (n, p))
    active = np.array([True, False, True])
    assert banded.WeightedRowsKalman.applies(coeffs, w)
    out = np.full((n, N, p), 7.0)
    unsolved = banded.WeightedRowsKalman(N, q, p, n).solve(phi, a, targets, w, coeffs, active, out)
    assert not unsolved.any()
    np.testing.assert_array_equal(out[1], 7.0)
    for c in (0, 2):
        H = _dense_weighted_rows(phi, a, w, coeffs, c)
        rhs = np.einsum("tj,tja->ta", targets[:, :, c], phi).reshape(-1)
        expected = np.linalg.solve(H, rhs).reshape(N, p)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(out[c], expected, rtol=1e-11, atol=1e-12 * scale)


def _kalman_rows(rng, N, q, p, n):
    """A first difference's coefficients, φ (N, q, p), row weights a (N, q, n) with
    about 30 % zeros, and penalty weights w (n, p)."""
    phi = rng.standard_normal((N, q, p))
    a = rng.uniform(0.05, 1.0, (N, q, n))
    a[rng.random((N, q, n)) < 0.3] = 0.0
    return np.array([-1.5, 1.5]), phi, a, rng.uniform(0.5, 4.0, (n, p))


def _assert_dense_solution(solution, phi, a, w, coeffs, c, rhs):
    """``solution`` (N, p) solves output c's system H θ = rhs (N, p), H built densely."""
    H = _dense_weighted_rows(phi, a, w, coeffs, c)
    expected = np.linalg.solve(H, rhs.reshape(-1)).reshape(rhs.shape)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(solution, expected, rtol=1e-11, atol=1e-12 * scale)


@pytest.mark.parametrize("q", [1, 2])
def test_weighted_rows_kalman_general_term_equals_a_dense_solve(q):
    """A general term g added to the right-hand side (H_c θ = Σ_j b φ + g_c), with and
    without row targets, equals a dense solve; the outputs left inactive are not touched."""
    rng = np.random.default_rng(8)
    N, p, n = 40, 3, 3
    coeffs, phi, a, w = _kalman_rows(rng, N, q, p, n)
    linear = rng.standard_normal((n, N, p))
    active = np.array([True, True, False])
    for targets in (np.zeros((N, q, n)), rng.standard_normal((N, q, n))):
        out = np.full((n, N, p), 7.0)
        unsolved = banded.WeightedRowsKalman(N, q, p, n).solve(
            phi, a, targets, w, coeffs, active, out, linear=linear
        )
        assert not unsolved.any()
        np.testing.assert_array_equal(out[2], 7.0)
        for c in (0, 1):
            rhs = np.einsum("tj,tja->ta", targets[:, :, c], phi) + linear[c]
            _assert_dense_solution(out[c], phi, a, w, coeffs, c, rhs)


@pytest.mark.parametrize("q", [1, 2])
def test_weighted_rows_kalman_replay_equals_a_fresh_solve(q):
    """A second right-hand side with the rows of the last solve (``replay``: the stored
    covariances and gains) gives the fresh filter's solution bit for bit, for a subset
    of the outputs, and that of a dense solve."""
    rng = np.random.default_rng(11)
    N, p, n = 40, 3, 3
    coeffs, phi, a, w = _kalman_rows(rng, N, q, p, n)
    targets = rng.standard_normal((N, q, n))
    first, second = rng.standard_normal((2, n, N, p))
    kalman = banded.WeightedRowsKalman(N, q, p, n)
    out = np.empty((n, N, p))
    kalman.solve(phi, a, targets, w, coeffs, np.ones(n, dtype=bool), out, linear=first)
    active = np.array([True, False, True])
    replayed = np.full((n, N, p), 7.0)
    unsolved = kalman.solve(
        phi, a, targets, w, coeffs, active, replayed, linear=second, replay=True
    )
    assert not unsolved.any()
    fresh = np.full((n, N, p), 7.0)
    banded.WeightedRowsKalman(N, q, p, n).solve(
        phi, a, targets, w, coeffs, active, fresh, linear=second
    )
    np.testing.assert_array_equal(replayed, fresh)
    for c in (0, 2):
        rhs = np.einsum("tj,tja->ta", targets[:, :, c], phi) + second[c]
        _assert_dense_solution(replayed[c], phi, a, w, coeffs, c, rhs)


def test_weighted_rows_kalman_leaves_rows_that_would_cancel_digits():
    """``max_reduction``: an output with a row whose update divides the variance along
    its regressor by more than the limit (1 + a φᵀPφ, here a regressor 10⁶ times the
    others') comes back unsolved, the others solved as without the limit; with no limit
    that output is solved too."""
    rng = np.random.default_rng(4)
    N, q, p, n = 40, 1, 3, 3
    coeffs, phi, a, w = _kalman_rows(rng, N, q, p, n)
    a[:, :, :] = np.where(a > 0, a, 0.5)  # every row counts
    phi[25, 0, 0] = 1e6
    a[25, 0, 1] = 0.0  # output 1 leaves that row out
    targets = rng.standard_normal((N, q, n))
    active = np.ones(n, dtype=bool)
    limited, plain = np.full((n, N, p), 7.0), np.full((n, N, p), 7.0)
    kalman = banded.WeightedRowsKalman(N, q, p, n)
    unsolved = kalman.solve(phi, a, targets, w, coeffs, active, limited, max_reduction=1e8)
    np.testing.assert_array_equal(unsolved, [True, False, True])
    assert not kalman.solve(phi, a, targets, w, coeffs, active, plain).any()
    np.testing.assert_array_equal(limited[1], plain[1])
    rhs = np.einsum("tj,tja->ta", targets[:, :, 1], phi)
    _assert_dense_solution(limited[1], phi, a, w, coeffs, 1, rhs)


def test_weighted_rows_kalman_leaves_what_it_cannot_hand_over():
    """Too few steps for the information form to hand over, or a singular system: the
    outputs come back unsolved (the caller factors them, and the factorization
    reports a singular one); other orders and zero weights are not its systems."""
    rng = np.random.default_rng(2)
    p, n, coeffs = 3, 2, np.array([-1.0, 1.0])
    short = rng.standard_normal((3, 1, p))  # N = p: Λ is first invertible at the last step
    a, w = np.ones((3, 1, n)), np.ones((n, p))
    out = np.empty((n, 3, p))
    unsolved = banded.WeightedRowsKalman(3, 1, p, n).solve(
        short, a, rng.standard_normal((3, 1, n)), w, coeffs, np.ones(n, dtype=bool), out
    )
    assert unsolved.all()
    empty = np.zeros((10, 1, p))  # no data: DᵀD ⊗ diag(w) alone is singular
    unsolved = banded.WeightedRowsKalman(10, 1, p, n).solve(
        empty,
        np.ones((10, 1, n)),
        np.zeros((10, 1, n)),
        w,
        coeffs,
        np.ones(n, dtype=bool),
        np.empty((n, 10, p)),
    )
    assert unsolved.all()
    assert not banded.WeightedRowsKalman.applies(np.array([1.0, -2.0, 1.0]), w)
    assert not banded.WeightedRowsKalman.applies(np.array([-1.0, 2.0]), w)
    assert not banded.WeightedRowsKalman.applies(coeffs, np.array([[1.0, 0.0, 1.0]]))


@pytest.mark.parametrize("q", [1, 2])
@pytest.mark.parametrize("fixed", [False, True])
def test_first_difference_solve_equals_a_dense_solve(q, fixed):
    """The reweighted fits' kernel solves s·blkdiag(Σ_j φφᵀ) + DᵀRD ⊗ diag(wsq), R one
    weight per difference, for several right-hand sides, as a dense solve does; its
    factor is the general block factorization's."""
    from ltvmodels.core import blockkernels as kernels

    rng = np.random.default_rng(5)
    N, p, r = 30, 3, 2
    coeffs = np.array([-1.0, 1.0])
    phi = rng.standard_normal((N, q, p))
    rho = rng.uniform(0.01, 50.0, N - 1)
    wsq = rng.uniform(0.5, 4.0, p)
    D = np.zeros((N - 1, N))
    for row in range(N - 1):
        D[row, row : row + 2] = coeffs
    DRD = D.T @ (rho[:, None] * D)
    bands = np.zeros((2, N))
    bands[0] = np.diag(DRD)
    bands[1, :-1] = np.diag(DRD, -1)
    H = np.kron(DRD, np.diag(wsq))
    for t in range(N):
        H[t * p : (t + 1) * p, t * p : (t + 1) * p] += 2.0 * phi[t].T @ phi[t]
    rhs = rng.standard_normal((N, r, p))
    expected = np.linalg.solve(H, rhs.transpose(0, 2, 1).reshape(N * p, r))
    X, L = rhs.copy(), np.empty((N, 2, p, p))
    size = (0,) * p if fixed else p
    worst, _ = kernels.first_difference_solve(phi, 2.0, wsq, bands, X, L, size)
    assert worst > 0
    np.testing.assert_allclose(
        X.transpose(0, 2, 1).reshape(N * p, r), expected, rtol=1e-10, atol=1e-12
    )
    general = np.empty((N, 2, p, p))
    kernels.factor_forward(
        phi, 1, 2.0, np.zeros((0, p, p)), np.diag(wsq), bands, np.zeros((N, p, 0)), general, size
    )
    np.testing.assert_allclose(L[:, 0], general[:, 0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(L[1:, 1], general[1:, 1], rtol=1e-12, atol=1e-14)
    # No data: the difference penalty alone is singular.
    worst, _ = kernels.first_difference_solve(0.0 * phi, 2.0, wsq, bands, rhs.copy(), L, size)
    assert worst <= 1e-12


def test_first_difference_solve_pairs_right_hand_sides_exactly():
    """Above PAIRED_RHS_MIN_B the kernel solves its right-hand sides two at a time:
    each column's solution is the one it gets alone, bit for bit, and a dense solve's."""
    from ltvmodels.core import blockkernels as kernels

    rng = np.random.default_rng(11)
    N, p, r = 25, kernels.PAIRED_RHS_MIN_B + 2, 3  # a pair and one alone
    phi = rng.standard_normal((N, 1, p))
    rho = rng.uniform(0.01, 50.0, N - 1)
    wsq = rng.uniform(0.5, 4.0, p)
    bands = np.zeros((2, N))
    bands[0, :-1] += rho
    bands[0, 1:] += rho
    bands[1, :-1] = -rho
    rhs = rng.standard_normal((N, r, p))
    X, L = rhs.copy(), np.empty((N, 2, p, p))
    assert kernels.first_difference_solve(phi, 2.0, wsq, bands, X, L, p)[0] > 0
    for c in range(r):
        alone = np.ascontiguousarray(rhs[:, c : c + 1])
        kernels.first_difference_solve(phi, 2.0, wsq, bands, alone, L, p)
        np.testing.assert_array_equal(X[:, c], alone[:, 0])
    H = np.zeros((N * p, N * p))
    for t in range(N):
        H[t * p : (t + 1) * p, t * p : (t + 1) * p] = 2.0 * np.outer(phi[t, 0], phi[t, 0])
        H[t * p : (t + 1) * p, t * p : (t + 1) * p] += np.diag(bands[0, t] * wsq)
        if t + 1 < N:
            H[(t + 1) * p : (t + 2) * p, t * p : (t + 1) * p] = np.diag(bands[1, t] * wsq)
            H[t * p : (t + 1) * p, (t + 1) * p : (t + 2) * p] = np.diag(bands[1, t] * wsq)
    expected = np.linalg.solve(H, rhs.transpose(0, 2, 1).reshape(N * p, r))
    np.testing.assert_allclose(
        X.transpose(0, 2, 1).reshape(N * p, r), expected, rtol=1e-9, atol=1e-11
    )


def test_kernels_receive_c_ordered_arrays_from_the_bordered_solve():
    """Coefficients held constant (λ = inf) go through the bordered solve, whose
    right-hand side is a concatenation that numpy may lay out in Fortran order: the
    kernels must receive it C-ordered, as everywhere (each other layout compiles
    them once more, seconds of a first call)."""
    numba = pytest.importorskip("numba")
    data = ltv.systems.jump_linear(T=60, change_at=30, seed=0)
    lam = np.array([1.0, np.inf, 1.0, 1.0, 1.0, np.inf])
    model = ltv.fit(data.x, data.u, lam=lam)
    assert np.ptp(model.k[:, [1, 5]], axis=0).max() == 0.0  # the bordered solve ran
    for kernel in (banded.kernels.factor_forward, banded.kernels.backward):
        layouts = {
            arg.layout
            for signature in kernel.signatures
            for arg in signature
            if isinstance(arg, numba.types.Array)
        }
        assert layouts == {"C"}, kernel


@pytest.mark.parametrize("loss", ["huber", "laplace"])
@pytest.mark.parametrize("order", [1, 2])
def test_robust_losses_constant_size_passes_equal_the_generic_ones(monkeypatch, loss, order):
    """Long series run the robust losses' per-entry passes compiled for a constant p
    (banded.long_series_size): the same sums in the same order, so the same fit bit for
    bit as the passes for a run-time p (here forced by a threshold of 0 unknowns)."""
    rng = np.random.default_rng(11)
    x = rng.standard_normal((150, 2))
    x[[20, 70, 110], 0] += 8.0  # outliers
    u = rng.standard_normal((150, 1))
    assert banded.long_series_size(149, 3) == 3  # short: the run-time p
    generic = ltv.fit(x, u, lam=3.0, order=order, loss=loss)
    monkeypatch.setattr(banded, "FIXED_BLOCK_MIN_SIZE", 0)
    assert banded.long_series_size(149, 3) == (0, 0, 0)
    constant = ltv.fit(x, u, lam=3.0, order=order, loss=loss)
    np.testing.assert_array_equal(constant.k, generic.k)
    assert constant.info["iterations"] == generic.info["iterations"]
