"""Compiled per-cone operations of the interior-point method (:mod:`.ipm`).

Cone vectors are rows of (n_cones, g + 1) arrays: entry 0 is the scalar part
v₀, entries 1… the vector part v₁. Cone i = r·C + c belongs to row r of the
difference operator D and covers the coefficients c·g … c·g + g − 1 of that
row (group: C = 1, g = K; l1: C = K, g = 1), so the vector parts of all cones
of row r, in order, are the K entries of (ΛDk)_r.

Every kernel is a plain loop over cones or time steps: the per-cone algebra
is a few dozen flops, far too little for numpy's per-call overhead.
:func:`kkt_residuals`, :func:`direction_rhs`, :func:`direction_finish` and
their width-2 forms are Python functions that call the difference kernels
(:func:`weighted_difference`, :func:`add_weighted_difference_adjoint`) and a
compiled per-cone part in turn, and :func:`prepare_newton` and
:func:`corrector_target` Python functions over one compiled part (which
:func:`predictor_corrector` calls too): a compiled caller re-optimizes its callees'
code inside itself, which cost about 0.5–0.9 s of compilation per caller on a
fit's first call, for a few microseconds of dispatch per call.
"""

from __future__ import annotations

import numba
import numpy as np

from .blockkernels import block_size, diagonal_step, offdiagonal_step
from .precompiled import attach

__all__ = [
    "certificate_terms",
    "weighted_difference",
    "add_weighted_difference_adjoint",
    "add_data_block",
    "set_penalty_block",
    "nt_scaling",
    "apply_scaling",
    "elimination_terms",
    "prepare_newton",
    "factor_newton_fixed",
    "factor_newton_any",
    "predictor_corrector",
    "reweight_bands",
    "jordan_product",
    "max_step",
    "kkt_residuals",
    "direction_rhs",
    "direction_finish",
    "take_step",
    "corrector_target",
    "prepare_newton_pairs",
    "direction_rhs_pairs",
    "direction_finish_pairs",
    "corrector_target_pairs",
]


@numba.njit(cache=True)
def weighted_difference(k, coeffs, w, out):  # pragma: no cover - compiled
    """out[r·C + c, 1 + i] = w_j (Dk)_{r, j}, j = c·g + i; column 0 is left alone."""
    R = k.shape[0] - coeffs.shape[0] + 1
    K = k.shape[1]
    g = out.shape[1] - 1
    if g == 1:  # l1: cone r·K + j, no integer division by a run-time g
        for r in range(R):
            for j in range(K):
                acc = 0.0
                for q in range(coeffs.shape[0]):
                    acc += coeffs[q] * k[r + q, j]
                out[r * K + j, 1] = w[j] * acc
        return
    if g == K and coeffs.shape[0] == 2:  # group, first difference: the common case
        c0, c1 = coeffs[0], coeffs[1]
        for r in range(R):
            for j in range(K):
                out[r, 1 + j] = w[j] * (c0 * k[r, j] + c1 * k[r + 1, j])
        return
    # Any cone size (group: C = 1), without integer divisions: one branch less
    # to compile than a separate group loop.
    C = K // g
    for r in range(R):
        for c in range(C):
            for i in range(g):
                j = c * g + i
                acc = 0.0
                for q in range(coeffs.shape[0]):
                    acc += coeffs[q] * k[r + q, j]
                out[r * C + c, 1 + i] = w[j] * acc


@numba.njit(cache=True)
def add_weighted_difference_adjoint(v, coeffs, w, scale, out):  # pragma: no cover - compiled
    """out += scale · DᵀΛ v₁ for cone vectors v; out is (N, K)."""
    K = out.shape[1]
    g = v.shape[1] - 1
    if g == 1:  # l1: cone r·K + j, no integer division by a run-time g
        for r in range(v.shape[0] // K):
            for j in range(K):
                value = scale * w[j] * v[r * K + j, 1]
                for q in range(coeffs.shape[0]):
                    out[r + q, j] += coeffs[q] * value
        return
    if g == K and coeffs.shape[0] == 2:  # group, first difference: the common case
        c0, c1 = coeffs[0], coeffs[1]
        for r in range(v.shape[0]):
            for j in range(K):
                value = scale * w[j] * v[r, 1 + j]
                out[r, j] += c0 * value
                out[r + 1, j] += c1 * value
        return
    # Any cone size (group: C = 1), without integer divisions in the loop.
    C = K // g
    R = v.shape[0] // C
    for r in range(R):
        for c in range(C):
            for i in range(g):
                j = c * g + i
                value = scale * w[j] * v[r * C + c, 1 + i]
                for q in range(coeffs.shape[0]):
                    out[r + q, j] += coeffs[q] * value


@numba.njit(cache=True)
def certificate_terms(k, y, phi, coeffs, w, group, u, grad, e_norms, u_norms):  # pragma: no cover
    """The optimality certificate of a sparse fit's k (:func:`.polish.certificate`) in four
    passes over time: returns (Σ r², Σ_c ‖e_c‖, the gap Σ_c (‖e_c‖ − u_cᵀe_c) >= 0,
    ‖DᵀΛu + ∇f‖²) with e = ΛDk.

    k (N, K) in (output, regressor) order, y (N, q, n), φ (N, q, p), the difference
    coefficients (d + 1,), weights w (K,) >= 0, ``group``: one cone per row of D (else
    one per entry). Outputs: ``u`` (N − d, K), the dual with DᵀΛu = −∇f on the rows
    t < N − d (∇f_t = −2 Σ_j r_tj φ_tjᵀ, into ``grad`` (N, K); u = 0 where w = 0)
    divided by max(1, max_c ‖u_c‖), so that it lies in the dual cones; e_norms and
    u_norms (cones,): ‖e_c‖ and ‖u_c‖ before that division. The recurrence is
    (Λu)_t = (−∇f_t − Σ_{q>=1} c_q (Λu)_{t−q}) / c_0."""
    N, K = k.shape
    d = coeffs.shape[0] - 1
    R = N - d
    # reciprocals: a division per entry and pass cost more than the rest of the pass
    inverse_c0 = 1.0 / coeffs[0]
    inverse_w = np.zeros(K)
    for a in range(K):
        if w[a] > 0.0:
            inverse_w[a] = 1.0 / w[a]
    loss = _data_residuals(k, y, phi, grad)
    for t in range(R):
        for a in range(K):
            acc = -grad[t, a]
            for lag in range(1, min(d, t) + 1):
                acc -= coeffs[lag] * u[t - lag, a]
            u[t, a] = acc * inverse_c0  # Λu until the next pass: the recurrence reads it
    penalty, inner, largest = 0.0, 0.0, 1.0
    for r in range(R):
        cone_e, cone_u = 0.0, 0.0
        for a in range(K):
            acc = 0.0
            for lag in range(d + 1):
                acc += coeffs[lag] * k[r + lag, a]
            e = w[a] * acc
            value = u[r, a] * inverse_w[a]
            u[r, a] = value
            inner += value * e
            if group:
                cone_e += e * e
                cone_u += value * value
            else:
                e_norms[r * K + a] = abs(e)
                u_norms[r * K + a] = abs(value)
                penalty += abs(e)
                largest = max(largest, abs(value))
        if group:
            e_norms[r] = np.sqrt(cone_e)
            u_norms[r] = np.sqrt(cone_u)
            penalty += e_norms[r]
            largest = max(largest, u_norms[r])
    stationarity = 0.0
    shrink = 1.0 / largest
    for t in range(N):
        for a in range(K):
            if t < R:
                u[t, a] *= shrink
            acc = grad[t, a]
            for lag in range(d + 1):
                if 0 <= t - lag < R:
                    acc += coeffs[lag] * w[a] * u[t - lag, a]
            stationarity += acc * acc
    return loss, penalty, max(penalty - inner / largest, 0.0), stationarity


@numba.njit(cache=True, inline="always")
def _nt_cone(s, z, i, v, eta, m):  # pragma: no cover - compiled
    """Nesterov–Todd scaling of cone i of width m: fills v[i] and eta[i] (see
    :func:`nt_scaling`).

    Returns ‖v₁‖². Divisions and square roots are the slow operations here, so
    each is taken once per cone and the entries are scaled by reciprocals.
    """
    s_j = s[i, 0] * s[i, 0]
    z_j = z[i, 0] * z[i, 0]
    dot = s[i, 0] * z[i, 0]
    for a in range(1, m):
        s_j -= s[i, a] * s[i, a]
        z_j -= z[i, a] * z[i, a]
        dot += s[i, a] * z[i, a]
    s_n = np.sqrt(s_j)
    inv_s = 1.0 / s_n
    inv_z = 1.0 / np.sqrt(z_j)
    half_inv_gamma = 0.5 / np.sqrt(0.5 * (1.0 + dot * inv_s * inv_z))
    w0 = (s[i, 0] * inv_s + z[i, 0] * inv_z) * half_inv_gamma
    norm = 1.0 / np.sqrt(2.0 * (w0 + 1.0))
    v[i, 0] = (w0 + 1.0) * norm
    scale = half_inv_gamma * norm
    v1sq = 0.0
    for a in range(1, m):
        va = (s[i, a] * inv_s - z[i, a] * inv_z) * scale
        v[i, a] = va
        v1sq += va * va
    eta[i] = np.sqrt(s_n * inv_z)
    return v1sq


@numba.njit(cache=True)
def nt_scaling(s, z, v, eta, lam):  # pragma: no cover - compiled
    """Nesterov–Todd scaling W = η(2vvᵀ − J) of every cone and λ = Wz.

    With s̄ = s/√(sᵀJs), z̄ = z/√(zᵀJz), γ = √((1 + s̄ᵀz̄)/2), the NT point
    w̄ = (s̄ + Jz̄)/2γ satisfies η²(2w̄w̄ᵀ − J) z = s with η = (sᵀJs / zᵀJz)^¼;
    W is the square root of that matrix, v = (w̄ + e)/√(2(w̄₀ + 1)).
    """
    for i in range(s.shape[0]):
        _nt_cone(s, z, i, v, eta, s.shape[1])
    apply_scaling(v, eta, z, 1.0, lam)


@numba.njit(cache=True)
def apply_scaling(v, eta, x, power, out):  # pragma: no cover - compiled
    """out = W x (power = 1) or W⁻¹ x (power = −1) per cone; out may alias x.

    W⁻¹ = η⁻¹(2Jv vᵀJ − J): the same reflection with v₁ negated.
    """
    n_cones, m = x.shape
    for i in range(n_cones):
        sign = 1.0 if power > 0 else -1.0
        dot = v[i, 0] * x[i, 0]
        for a in range(1, m):
            dot += sign * v[i, a] * x[i, a]
        factor = eta[i] if power > 0 else 1.0 / eta[i]
        out[i, 0] = factor * (2.0 * dot * v[i, 0] - x[i, 0])
        for a in range(1, m):
            out[i, a] = factor * (2.0 * dot * sign * v[i, a] + x[i, a])


@numba.njit(cache=True, inline="always")
def _elimination_cone(v, eta, i, alpha, beta, s_coef):  # pragma: no cover - compiled
    """α, β and s_coef of cone i (see :func:`elimination_terms`)."""
    m = v.shape[1]
    v0 = v[i, 0]
    v1sq = 0.0
    for a in range(1, m):
        v1sq += v[i, a] * v[i, a]
    inv_eta2 = 1.0 / (eta[i] * eta[i])
    alpha[i] = inv_eta2 * ((2.0 * v0 * v0 - 1.0) ** 2 + 4.0 * v0 * v0 * v1sq)
    b = -4.0 * inv_eta2 * v0 * (v0 * v0 + v1sq)
    for a in range(1, m):
        beta[i, a - 1] = b * v[i, a]
    s_coef[i] = 8.0 * v0 * v0 / (1.0 + 8.0 * v0 * v0 * v1sq)


@numba.njit(cache=True)
def elimination_terms(v, eta, alpha, beta, s_coef):  # pragma: no cover - compiled
    """Blocks of W⁻² = [[α, βᵀ], [β, Γ]] used to eliminate t_c, and S_c = Γ − ββᵀ/α.

    S_c is the inverse of the lower-right block of W² = η²(2vvᵀ − J)², which is
    η²(I + 8v₀² v₁v₁ᵀ) because v₀² − ‖v₁‖² = 1; so S_c = η⁻² (I − s_coef_c v₁v₁ᵀ)
    with s_coef_c = 8v₀² / (1 + 8v₀²‖v₁‖²). The penalty blocks ΛSΛ of the
    Newton matrix are formed from it inside :func:`_factor_newton`.
    """
    for i in range(v.shape[0]):
        _elimination_cone(v, eta, i, alpha, beta, s_coef)


def prepare_newton(s, z, r_z, v, eta, lam, lam_sq, u_rz, alpha, beta, s_coef):
    """Everything per cone a Newton system needs, in one pass (see :func:`_prepare_newton`).

    A Python function: as a compiled wrapper it re-optimized the kernel inside
    itself, about 0.5 s of compilation on a fit's first call.
    """
    _prepare_newton(s, z, r_z, v, eta, lam, lam_sq, u_rz, alpha, beta, s_coef, s.shape[1] - 1)


@numba.njit(cache=True)
def _prepare_newton(
    s, z, r_z, v, eta, lam, lam_sq, u_rz, alpha, beta, s_coef, size
):  # pragma: no cover - compiled
    """Everything per cone a Newton system needs, in one pass.

    The NT scaling (v, η), λ = Wz, λ∘λ, u_rz = W⁻² r_z and the elimination
    terms α, β, s_coef: :func:`nt_scaling`, :func:`jordan_product`,
    :func:`apply_scaling` and :func:`elimination_terms` fused, with the
    reflections written out (W x = η(2(vᵀx)v − Jx), W⁻¹x = η⁻¹(2(vᵀJx)Jv − Jx))
    and one division for η⁻¹. The cones' vector parts have the length
    block_size(size): a tuple's length makes it a constant of the compiled
    loops (see :mod:`.blockkernels`).
    """
    m = block_size(size) + 1
    for i in range(s.shape[0]):
        v1sq = _nt_cone(s, z, i, v, eta, m)
        v0 = v[i, 0]
        et = eta[i]
        inv_eta = 1.0 / et
        dot = v0 * z[i, 0]
        for a in range(1, m):
            dot += v[i, a] * z[i, a]
        l0 = et * (2.0 * dot * v0 - z[i, 0])
        lam[i, 0] = l0
        sq = l0 * l0
        for a in range(1, m):
            la = et * (2.0 * dot * v[i, a] + z[i, a])
            lam[i, a] = la
            sq += la * la
            lam_sq[i, a] = 2.0 * l0 * la
        lam_sq[i, 0] = sq
        # u_rz = W⁻¹(W⁻¹ r_z), the first reflection's vector part kept in u_rz
        dot = v0 * r_z[i, 0]
        for a in range(1, m):
            dot -= v[i, a] * r_z[i, a]
        x0 = inv_eta * (2.0 * dot * v0 - r_z[i, 0])
        dot2 = v0 * x0
        for a in range(1, m):
            xa = inv_eta * (r_z[i, a] - 2.0 * dot * v[i, a])
            u_rz[i, a] = xa
            dot2 -= v[i, a] * xa
        u_rz[i, 0] = inv_eta * (2.0 * dot2 * v0 - x0)
        for a in range(1, m):
            u_rz[i, a] = inv_eta * (u_rz[i, a] - 2.0 * dot2 * v[i, a])
        inv_eta2 = inv_eta * inv_eta
        v0sq = v0 * v0
        alpha[i] = inv_eta2 * ((2.0 * v0sq - 1.0) ** 2 + 4.0 * v0sq * v1sq)
        b = -4.0 * inv_eta2 * v0 * (v0sq + v1sq)
        for a in range(1, m):
            beta[i, a - 1] = b * v[i, a]
        s_coef[i] = 8.0 * v0sq / (1.0 + 8.0 * v0sq * v1sq)


@numba.njit(cache=True, inline="always")
def _penalty_row(v, eta, s_coef, penalty, w, r, offset, out, b):  # pragma: no cover - compiled
    """out = (ΛSΛ)_r restricted to the coefficients offset … offset + b − 1.

    Group cones (g = K = b): out = ΛSΛ with S = η_r⁻²(I − s_coef v₁v₁ᵀ). Cones
    of width 2 (l1, g = 1; ``penalty`` non-empty): a diagonal block, one cone
    per coefficient, S_c = penalty[c] from :func:`prepare_newton_pairs`.
    """
    if penalty.shape[0] > 0:
        K = w.shape[0]
        for i in range(b):
            for j in range(b):
                out[i, j] = 0.0
            c = r * K + offset + i
            wi = w[offset + i]
            out[i, i] = wi * wi * penalty[c]
    else:
        # η⁻²(Λ² − s_coef (Λv₁)(Λv₁)ᵀ)
        inv_eta2 = 1.0 / (eta[r] * eta[r])
        scale = inv_eta2 * s_coef[r]
        for i in range(b):
            a_i = w[i] * v[r, 1 + i]
            c_i = scale * a_i
            for j in range(i):
                value = -c_i * (w[j] * v[r, 1 + j])
                out[i, j] = value
                out[j, i] = value
            out[i, i] = inv_eta2 * w[i] * w[i] - c_i * a_i


@numba.njit(cache=True)
def set_penalty_block(ring, coeffs, t, R, out):  # pragma: no cover - compiled
    """Lower triangle of out = Σ_r c_{t−r}² (ΛSΛ)_r: the penalty part of step t's diagonal
    Newton block, from the ring (d + 1, b, b) of the last d + 1 difference rows'
    scaled blocks (R = N − d difference rows)."""
    d = coeffs.shape[0] - 1
    b = out.shape[0]
    for i in range(b):
        for j in range(i + 1):
            out[i, j] = 0.0
    for r in range(max(0, t - d), min(t, R - 1) + 1):
        weight = coeffs[t - r] * coeffs[t - r]
        P = ring[r % (d + 1)]
        for i in range(b):
            for j in range(i + 1):
                out[i, j] += weight * P[i, j]


@numba.njit(cache=True)
def add_data_block(phi, t, n_rep, out):  # pragma: no cover - compiled
    """Lower triangle of out += 2 I_r ⊗ Σ_q φ_tqφ_tqᵀ: the data part of step t's diagonal
    Newton block (phi (N, rows, p), r = n_rep output rows sharing the regressors)."""
    n_rows, p = phi.shape[1], phi.shape[2]
    for rep in range(n_rep):
        base = rep * p
        for i in range(p):
            for j in range(i + 1):
                acc = 0.0
                for row in range(n_rows):
                    acc += phi[t, row, i] * phi[t, row, j]
                out[base + i, base + j] += 2.0 * acc


@numba.njit(cache=True)
def _factor_newton(
    phi, n_rep, v, eta, s_coef, penalty, w, coeffs, offset, pinned, L, size
):  # pragma: no cover - compiled
    """Factor the Newton matrix 2ΦᵀΦ + DᵀΛSΛD into L (N, d+1, b, b).

    ``size`` is the block size b as an int, or as a tuple of length b for the
    version compiled with b a constant (see :mod:`.blockkernels`).

    S comes from the cone scaling (v, η, s_coef) of :func:`prepare_newton`, or
    for cones of width 2 from ``penalty`` (:func:`prepare_newton_pairs`); the
    unused one is empty.

    The block-banded Cholesky of :mod:`.blockkernels` with the penalty
    blocks (ΛSΛ)_r formed on the fly from the cone scaling (one per row of D,
    kept in a ring buffer of d + 1), restricted to the b coefficients from
    ``offset`` on (one output row for l1, all K for group). Solves are left
    to :func:`.blockkernels.solve`: forward substitution inside this sweep
    was slower than a separate pass (3.8 against 2.7 + 0.6 ms at N = 10⁴,
    b = 6, d = 1).

    Coefficients with ``pinned[i] != 0`` (constant in time, solved for
    through a border by the caller) get an identity row and column instead:
    they decouple from the banded system.

    Returns (smallest pivot² ratio, −1 if not positive definite; its time step).
    """
    b = block_size(size)
    N, n_rows, p = phi.shape
    d = coeffs.shape[0] - 1
    R = N - d
    ring = np.zeros((d + 1, b, b))  # zeros: the first difference's path reads both slots
    M = np.empty((b, b))
    ref = np.empty(b)
    any_pinned = False
    for i in range(b):
        any_pinned = any_pinned or pinned[i] != 0.0
    # A first difference without pinned coefficients (the common case) takes its
    # blocks straight from the ring: H_{t,t−1} = c₀c₁ (ΛSΛ)_{t−1} and
    # H_tt = c₁²(ΛSΛ)_{t−1} + c₀²(ΛSΛ)_t + data, the same sums as the general
    # loops below without their zeroing and accumulation (1.2x faster at
    # N = 10⁴, b = 6, the same factor bit for bit).
    first = d == 1 and not any_pinned
    worst = np.inf
    worst_t = 0
    for t in range(N):
        if t < R:
            _penalty_row(v, eta, s_coef, penalty, w, t, offset, ring[t % (d + 1)], b)
        Ltt = L[t, 0]
        if first:
            lo, hi = ring[(t + 1) % 2], ring[t % 2]  # rows t − 1 and t of D
            if t > 0:
                # offdiagonal_step for M = c₀c₁ (ΛSΛ)_{t−1} (nothing to subtract for d = 1)
                w_off = coeffs[0] * coeffs[1]
                Lss = L[t - 1, 0]
                out = L[t, 1]
                for j in range(b):
                    inv = Lss[j, j]
                    for i in range(b):
                        acc = w_off * lo[i, j]
                        for q in range(j):
                            acc -= out[i, q] * Lss[j, q]
                        out[i, j] = acc * inv
            # The diagonal block, lower triangle only, straight into L.
            w_lo = coeffs[1] * coeffs[1] if t > 0 else 0.0
            w_hi = coeffs[0] * coeffs[0] if t < R else 0.0
            for i in range(b):
                for j in range(i + 1):
                    Ltt[i, j] = w_lo * lo[i, j] + w_hi * hi[i, j]
        else:
            for lag in range(min(d, t), 0, -1):
                s = t - lag
                # Block (t, s) of DᵀΛSΛD = Σ_r c_{t−r} c_{s−r} (ΛSΛ)_r.
                for i in range(b):
                    for j in range(b):
                        M[i, j] = 0.0
                for r in range(max(0, t - d), min(s, R - 1) + 1):
                    weight = coeffs[t - r] * coeffs[s - r]
                    P = ring[r % (d + 1)]
                    for i in range(b):
                        for j in range(b):
                            M[i, j] += weight * P[i, j]
                for i in range(b if any_pinned else 0):
                    if pinned[i] != 0.0:
                        for j in range(b):
                            M[i, j] = 0.0
                            M[j, i] = 0.0
                offdiagonal_step(L, M, t, lag, d, b)
            # The diagonal block, lower triangle only, straight into L.
            set_penalty_block(ring, coeffs, t, R, Ltt)
        add_data_block(phi, t, n_rep, Ltt)  # the data part
        for i in range(b if any_pinned else 0):
            if pinned[i] != 0.0:
                for j in range(i):
                    Ltt[i, j] = 0.0
                for j in range(i + 1, b):
                    Ltt[j, i] = 0.0
                Ltt[i, i] = 1.0
        for i in range(b):
            ref[i] = Ltt[i, i]
        ratio = diagonal_step(L, t, d, b, ref)
        if ratio < worst:
            worst = ratio
            worst_t = t
        if ratio < 0:
            return -1.0, t
    return worst, worst_t


# The constant-size version is the same kernel with a tuple ``size``.
factor_newton_fixed = _factor_newton


def factor_newton_any(phi, n_rep, v, eta, s_coef, penalty, w, coeffs, offset, pinned, L):
    """:func:`_factor_newton` with the block size taken from ``L`` at run time.

    A Python function: as a compiled wrapper it made numba inline the kernel
    (and its inlined helpers) once more, about 1 s of compilation.
    """
    return _factor_newton(
        phi, n_rep, v, eta, s_coef, penalty, w, coeffs, offset, pinned, L, L.shape[2]
    )


@numba.njit(cache=True)
def _solve_vector(L, x, size):  # pragma: no cover - compiled
    """Solve L Lᵀ x = rhs in place for one right-hand side x (N, b) (L as in
    :mod:`.blockkernels`, reciprocal pivots on its diagonal; b from ``size``).

    :func:`.blockkernels.solve` for a single column: without the loop over a
    run-time number of columns the b × b loops unroll for a constant b. The
    sweeps are bound by their dependency chains, not by memory; for a first
    difference each entry takes its off-diagonal and diagonal terms in one
    accumulation (0.49 against 0.59 ms at N = 10⁴, b = 6; with the loop over
    lags, as for d = 2, it was slower than separate passes, 1.33 against 1.07 ms).
    """
    b = block_size(size)
    N = L.shape[0]
    d = L.shape[1] - 1
    if d == 1:
        for t in range(N):
            Ltt = L[t, 0]
            for i in range(b):
                acc = x[t, i]
                if t > 0:
                    for q in range(b):
                        acc -= L[t, 1, i, q] * x[t - 1, q]
                for q in range(i):
                    acc -= Ltt[i, q] * x[t, q]
                x[t, i] = acc * Ltt[i, i]
        for t in range(N - 1, -1, -1):
            Ltt = L[t, 0]
            for i in range(b - 1, -1, -1):
                acc = x[t, i]
                if t < N - 1:
                    for q in range(b):
                        acc -= L[t + 1, 1, q, i] * x[t + 1, q]
                for q in range(i + 1, b):
                    acc -= Ltt[q, i] * x[t, q]
                x[t, i] = acc * Ltt[i, i]
        return
    for t in range(N):
        for lag in range(1, min(d, t) + 1):
            Ll = L[t, lag]
            for i in range(b):
                acc = 0.0
                for q in range(b):
                    acc += Ll[i, q] * x[t - lag, q]
                x[t, i] -= acc
        Ltt = L[t, 0]
        for i in range(b):
            acc = x[t, i]
            for q in range(i):
                acc -= Ltt[i, q] * x[t, q]
            x[t, i] = acc * Ltt[i, i]
    for t in range(N - 1, -1, -1):
        for lag in range(1, min(d, N - 1 - t) + 1):
            Ll = L[t + lag, lag]
            for i in range(b):
                acc = 0.0
                for q in range(b):
                    acc += Ll[q, i] * x[t + lag, q]
                x[t, i] -= acc
        Ltt = L[t, 0]
        for i in range(b - 1, -1, -1):
            acc = x[t, i]
            for q in range(i + 1, b):
                acc -= Ltt[q, i] * x[t, q]
            x[t, i] = acc * Ltt[i, i]


@numba.njit(cache=True)
def predictor_corrector(
    coeffs, w, s, z, r_z, r_k, gap, v, eta, lam, lam_sq, u_rz, alpha, beta, s_coef,
    L, target, work, dk, dt, ds, dz, size,
):  # pragma: no cover - compiled  # fmt: skip
    """One iteration's Newton directions for group cones, in one compiled call.

    After :func:`prepare_newton` and the Newton matrix factored into L
    (:func:`factor_newton_fixed` or :func:`factor_newton_any`, all K
    coefficients in one system, none pinned): solves for the predictor target
    −λ∘λ, forms Mehrotra's corrector target σμe − λ∘λ − (W⁻¹Δs_a) ∘ (WΔz_a)
    with σ = (1 − min(1, α_a))³ and μ = gap / n_cones, and solves for it: the
    sequence of :class:`.ipm.NewtonSystem`'s calls without the round trips
    through Python between them (with the residuals, the scaling, the factor
    and the step, five compiled calls per iteration instead of eleven). The
    factorization stays outside: inside, numba linked its code into this
    kernel and re-optimized it, about 1.5 s more on a fit's first call, while
    the start compiles it anyway.

    Fills (Δk, Δt, Δs, Δz) = (dk (N, K), dt, ds, dz) for the corrector;
    target and work are scratch arrays of the cones' shape. Returns the
    largest steps keeping s and z in the cones (each on its own).
    """
    n_cones, m = lam_sq.shape  # m at run time: compiled as a constant it gained nothing
    for c in range(n_cones):
        for a in range(m):
            target[c, a] = -lam_sq[c, a]
    _direction_rhs(target, lam, v, eta, u_rz, z, alpha, beta, r_k, coeffs, w, work, dk, m)
    _solve_vector(L, dk, size)
    step_s, step_z = _direction_finish(
        dk, work, s, r_z, z, alpha, beta, v, eta, s_coef, coeffs, w, dt, ds, dz, m
    )
    sigma_mu = (1.0 - min(1.0, min(step_s, step_z))) ** 3 * gap / n_cones
    _corrector_target(lam, v, eta, ds, dz, sigma_mu, target, m)
    _direction_rhs(target, lam, v, eta, u_rz, z, alpha, beta, r_k, coeffs, w, work, dk, m)
    _solve_vector(L, dk, size)
    return _direction_finish(
        dk, work, s, r_z, z, alpha, beta, v, eta, s_coef, coeffs, w, dt, ds, dz, m
    )


@numba.njit(cache=True)
def reweight_bands(k, coeffs, w, floor, e, bands):  # pragma: no cover - compiled
    """The weights of a reweighted quadratic fit of group cones and the bands of DᵀRD.

    ρ_c = 1/‖(ΛDk)_c‖, floored at ``floor`` times the largest norm, into e[:, 0]
    (e (n_cones, K + 1) also receives ΛDk in its vector parts), and the
    diagonals of DᵀRD, R = diag(ρ), into ``bands`` (d + 1, N) as
    :func:`.banded.difference_bands` holds those of DᵀD: bands[lag, s] =
    (DᵀRD)_{s+lag, s}. Returns False (and leaves ``bands``) where every
    difference is zero or not finite: there is nothing to reweight.
    """
    weighted_difference(k, coeffs, w, e)
    n_cones, m = e.shape
    d = coeffs.shape[0] - 1
    top = 0.0
    for c in range(n_cones):
        sq = 0.0
        for a in range(1, m):
            sq += e[c, a] * e[c, a]
        e[c, 0] = np.sqrt(sq)
        top = max(top, e[c, 0])
    if not (top > 0.0 and top < np.inf):
        return False
    low = floor * top
    bands[:] = 0.0
    for r in range(n_cones):
        weight = 1.0 / max(e[r, 0], low)
        e[r, 0] = weight
        for q1 in range(d + 1):  # row r of D couples r + q2 and r + q1
            for q2 in range(q1 + 1):
                bands[q1 - q2, r + q2] += coeffs[q1] * coeffs[q2] * weight
    return True


@numba.njit(cache=True)
def jordan_product(x, y, out):  # pragma: no cover - compiled
    """out = x ∘ y = (xᵀy, x₀y₁ + y₀x₁) per cone."""
    n_cones, m = x.shape
    for i in range(n_cones):
        dot = 0.0
        for a in range(m):
            dot += x[i, a] * y[i, a]
        for a in range(1, m):
            out[i, a] = x[i, 0] * y[i, a] + y[i, 0] * x[i, a]
        out[i, 0] = dot


@numba.njit(cache=True, inline="always")
def _cone_step_fraction(x, dx, i, m):  # pragma: no cover - compiled
    """(num, den): the largest α with x_i + α·dx_i in the cone (of width m) is num / den
    (inf, 1 if unbounded); see :func:`max_step`."""
    a = dx[i, 0] * dx[i, 0]
    b = x[i, 0] * dx[i, 0]
    c = x[i, 0] * x[i, 0]
    for q in range(1, m):
        a -= dx[i, q] * dx[i, q]
        b -= x[i, q] * dx[i, q]
        c -= x[i, q] * x[i, q]
    if dx[i, 0] >= 0.0 and a >= 0.0:
        return np.inf, 1.0
    return c, max(np.sqrt(max(b * b - a * c, 0.0)) - b, 1e-300)


@numba.njit(cache=True, inline="always")
def _cone_step(x, dx, i):  # pragma: no cover - compiled
    """Largest α with x_i + α·dx_i in the cone (inf if unbounded); see :func:`max_step`."""
    num, den = _cone_step_fraction(x, dx, i, x.shape[1])
    return num / den


@numba.njit(cache=True)
def max_step(x, dx):  # pragma: no cover - compiled
    """Largest α with x + α·dx in every cone (inf if unbounded), x in the interior.

    ‖x₁ + αd₁‖ <= x₀ + αd₀ is a quadratic inequality aα² + 2bα + c >= 0 with
    c = xᵀJx > 0; unless d is itself in the cone the boundary is its smallest
    positive root, c / (√(b² − ac) − b), written without cancellation.
    """
    best = np.inf
    for i in range(x.shape[0]):
        best = min(best, _cone_step(x, dx, i))
    return best


def kkt_residuals(k, t, s, z, y, phi, coeffs, w, r_z, r_k):
    """Residuals of the optimality conditions at (k, t, s, z), in one pass.

    Fills r_z = s − (t, ΛDk) (cone constraints) and r_k = 2Φᵀ(Φk − y) − DᵀΛz₁
    (stationarity in k); the stationarity residual in t is 1 − z₀.

    Returns
    -------
    loss, reg : float
        ‖y − Φk‖² and Σ_c ‖(ΛDk)_c‖: the objective is their sum.
    gap : float
        sᵀz.
    rz_norm, s_norm, rk_norm, rt_max : float
        ‖r_z‖, ‖s‖, ‖r_k‖ and max |1 − z₀|.
    """
    # The differences are separate kernels, called from here rather than from a
    # compiled kernel: a compiled caller re-optimizes their code inside itself
    # (about 0.9 s of a first fit's compilation).
    loss = _data_residuals(k, y, phi, r_k)
    add_weighted_difference_adjoint(z, coeffs, w, -1.0, r_k)
    weighted_difference(k, coeffs, w, r_z)  # vector parts: ΛDk
    return (loss, *_cone_residuals(t, s, z, r_z, r_k))


@numba.njit(cache=True)
def _data_residuals(k, y, phi, r_k):  # pragma: no cover - compiled
    """r_k = 2Φᵀ(Φk − y); returns ‖y − Φk‖² (:func:`kkt_residuals`)."""
    N, n_rows, n = y.shape
    p = phi.shape[2]
    K = n * p
    loss = 0.0
    for tt in range(N):
        for a in range(K):
            r_k[tt, a] = 0.0
        for row in range(n_rows):
            for i in range(n):
                e = y[tt, row, i]
                for a in range(p):
                    e -= k[tt, i * p + a] * phi[tt, row, a]
                loss += e * e
                for a in range(p):
                    r_k[tt, i * p + a] -= 2.0 * e * phi[tt, row, a]
    return loss


@numba.njit(cache=True)
def _cone_residuals(t, s, z, r_z, r_k):  # pragma: no cover - compiled
    """r_z = s − (t, ΛDk) from r_z's vector parts ΛDk, and the sums of :func:`kkt_residuals`
    after ‖y − Φk‖²."""
    N, K = r_k.shape
    g = s.shape[1] - 1
    reg = gap = rz_sq = s_sq = 0.0
    rt_max = 0.0
    if g == 1:  # l1: the same sums without inner loops
        for c in range(s.shape[0]):
            r_0 = s[c, 0] - t[c]
            reg += abs(r_z[c, 1])
            r_1 = s[c, 1] - r_z[c, 1]
            r_z[c, 0] = r_0
            r_z[c, 1] = r_1
            gap += s[c, 0] * z[c, 0] + s[c, 1] * z[c, 1]
            rz_sq += r_0 * r_0 + r_1 * r_1
            s_sq += s[c, 0] * s[c, 0] + s[c, 1] * s[c, 1]
            rt_max = max(rt_max, abs(1.0 - z[c, 0]))
    else:
        for c in range(s.shape[0]):
            norm_sq = 0.0
            r_z[c, 0] = s[c, 0] - t[c]
            for a in range(1, g + 1):
                norm_sq += r_z[c, a] * r_z[c, a]
                r_z[c, a] = s[c, a] - r_z[c, a]
            reg += np.sqrt(norm_sq)
            for a in range(g + 1):
                gap += s[c, a] * z[c, a]
                rz_sq += r_z[c, a] * r_z[c, a]
                s_sq += s[c, a] * s[c, a]
            rt_max = max(rt_max, abs(1.0 - z[c, 0]))
    rk_sq = 0.0
    for tt in range(N):
        for j in range(K):
            rk_sq += r_k[tt, j] * r_k[tt, j]
    return reg, gap, np.sqrt(rz_sq), np.sqrt(s_sq), np.sqrt(rk_sq), rt_max


@numba.njit(cache=True, inline="always")
def _stationarity_rhs(work, r_k, coeffs, w, rhs):  # pragma: no cover - compiled
    """rhs = −r_k + DᵀΛ work₁: the banded system's right-hand side from the cone parts.

    Compiled, for :func:`predictor_corrector`'s one-call iteration (the width-2
    cones call it from Python).
    """
    for tt in range(rhs.shape[0]):
        for j in range(rhs.shape[1]):
            rhs[tt, j] = -r_k[tt, j]
    add_weighted_difference_adjoint(work, coeffs, w, 1.0, rhs)


def direction_rhs(target, lam, v, eta, u_rz, z, alpha, beta, r_k, coeffs, w, work, rhs):
    """First half of a Newton direction: the right-hand side of the banded system.

    With u = W⁻²(r_z + W(λ ⋄ target)) = u_rz + W⁻¹(λ ⋄ target), where
    u_rz = W⁻² r_z is shared by all targets, and f_t = u₀ − (1 − z₀), stores
    work = (f_t, u₁ − β f_t/α) per cone and rhs = −r_k + DᵀΛ work₁.
    """
    _direction_rhs(
        target, lam, v, eta, u_rz, z, alpha, beta, r_k, coeffs, w, work, rhs, target.shape[1]
    )


@numba.njit(cache=True)
def _direction_rhs(
    target, lam, v, eta, u_rz, z, alpha, beta, r_k, coeffs, w, work, rhs, m
):  # pragma: no cover - compiled
    """:func:`direction_rhs` for cones of width m.

    x = λ ⋄ target (x₀ = (λᵀJ target)/(λᵀJλ), x₁ = (target₁ − x₀λ₁)/λ₀) and
    W⁻¹x = η⁻¹(2(vᵀJx)Jv − Jx) are written out per entry, so no cone vector
    goes through memory in between; x₁ is formed twice instead.
    """
    for c in range(target.shape[0]):
        l0 = lam[c, 0]
        det = l0 * l0
        dot = l0 * target[c, 0]
        for a in range(1, m):
            det -= lam[c, a] * lam[c, a]
            dot -= lam[c, a] * target[c, a]
        x0 = dot / det
        inv_lam0 = 1.0 / l0
        dot_v = v[c, 0] * x0  # vᵀJx
        for a in range(1, m):
            dot_v -= v[c, a] * ((target[c, a] - x0 * lam[c, a]) * inv_lam0)
        inv_eta = 1.0 / eta[c]
        f_t = inv_eta * (2.0 * dot_v * v[c, 0] - x0) + u_rz[c, 0] - (1.0 - z[c, 0])
        work[c, 0] = f_t
        ratio = f_t / alpha[c]
        for a in range(1, m):
            x_a = (target[c, a] - x0 * lam[c, a]) * inv_lam0
            work[c, a] = (
                inv_eta * (x_a - 2.0 * dot_v * v[c, a]) + u_rz[c, a] - beta[c, a - 1] * ratio
            )
    _stationarity_rhs(work, r_k, coeffs, w, rhs)


def direction_finish(dk, work, s, r_z, z, alpha, beta, v, eta, s_coef, coeffs, w, dt, ds, dz):
    """Second half of a Newton direction, from the solution Δk of the banded system.

    With e = ΛDΔk: Δt = (f_t − βᵀe)/α, Δs = (Δt, e) − r_z and
    Δz = u − W⁻²(Δt, e) = (1 − z₀, work₁ − S e), using (W⁻²(Δt, e))₀ = f_t and
    (W⁻²(Δt, e))₁ = S e + β f_t/α, which avoid cancellation between large terms.
    Returns the largest steps that keep s + αΔs and z + αΔz in the cones
    (:func:`max_step`).
    """
    return _direction_finish(
        dk, work, s, r_z, z, alpha, beta, v, eta, s_coef, coeffs, w, dt, ds, dz, s.shape[1]
    )


@numba.njit(cache=True)
def _direction_finish(
    dk, work, s, r_z, z, alpha, beta, v, eta, s_coef, coeffs, w, dt, ds, dz, m
):  # pragma: no cover - compiled
    """:func:`direction_finish` for cones of width m."""
    weighted_difference(dk, coeffs, w, ds)  # vector parts: e
    n_cones = ds.shape[0]
    # The smallest steps as fractions num / den, divided out once at the end:
    # a division per cone costs more than the rest of its step computation.
    num_s = num_z = np.inf
    den_s = den_z = 1.0
    for c in range(n_cones):
        acc = work[c, 0]
        dot = 0.0
        for a in range(1, m):
            acc -= beta[c, a - 1] * ds[c, a]
            dot += v[c, a] * ds[c, a]
        dt[c] = acc / alpha[c]
        inv_eta2 = 1.0 / (eta[c] * eta[c])
        coef = s_coef[c] * dot
        dz[c, 0] = 1.0 - z[c, 0]
        for a in range(1, m):
            dz[c, a] = work[c, a] - inv_eta2 * (ds[c, a] - coef * v[c, a])
        ds[c, 0] = dt[c] - r_z[c, 0]
        for a in range(1, m):
            ds[c, a] -= r_z[c, a]
        num, den = _cone_step_fraction(s, ds, c, m)
        if num * den_s < num_s * den:
            num_s, den_s = num, den
        num, den = _cone_step_fraction(z, dz, c, m)
        if num * den_z < num_z * den:
            num_z, den_z = num, den
    return num_s / den_s, num_z / den_z


@numba.njit(cache=True)
def take_step(k, dk, t, dt, s, ds, z, dz, step, dual_step):  # pragma: no cover - compiled
    """(k, t, s) += step · (Δk, Δt, Δs) and z += dual_step · Δz, in place."""
    for i in range(k.shape[0]):
        for j in range(k.shape[1]):
            k[i, j] += step * dk[i, j]
    for c in range(s.shape[0]):
        t[c] += step * dt[c]
        for a in range(s.shape[1]):
            s[c, a] += step * ds[c, a]
            z[c, a] += dual_step * dz[c, a]


def corrector_target(lam, v, eta, ds_a, dz_a, sigma_mu, out):
    """Mehrotra's target σμe − λ∘λ − (W⁻¹Δs_a) ∘ (WΔz_a); ds_a, dz_a are overwritten."""
    _corrector_target(lam, v, eta, ds_a, dz_a, sigma_mu, out, lam.shape[1])


@numba.njit(cache=True)
def _corrector_target(lam, v, eta, ds_a, dz_a, sigma_mu, out, m):  # pragma: no cover - compiled
    """:func:`corrector_target` for cones of width m: the two reflections
    (:func:`apply_scaling`) and the Jordan product in one pass per cone."""
    for c in range(lam.shape[0]):
        v0 = v[c, 0]
        dot_s = v0 * ds_a[c, 0]  # vᵀJΔs_a, for W⁻¹Δs_a
        dot_z = v0 * dz_a[c, 0]  # vᵀΔz_a, for WΔz_a
        for a in range(1, m):
            dot_s -= v[c, a] * ds_a[c, a]
            dot_z += v[c, a] * dz_a[c, a]
        inv_eta = 1.0 / eta[c]
        et = eta[c]
        p0 = inv_eta * (2.0 * dot_s * v0 - ds_a[c, 0])
        q0 = et * (2.0 * dot_z * v0 - dz_a[c, 0])
        prod = p0 * q0
        sq = lam[c, 0] * lam[c, 0]
        for a in range(1, m):
            p_a = inv_eta * (ds_a[c, a] - 2.0 * dot_s * v[c, a])
            q_a = et * (2.0 * dot_z * v[c, a] + dz_a[c, a])
            ds_a[c, a] = p_a
            dz_a[c, a] = q_a
            prod += p_a * q_a
            sq += lam[c, a] * lam[c, a]
        ds_a[c, 0] = p0
        dz_a[c, 0] = q0
        out[c, 0] = sigma_mu - sq - prod
        for a in range(1, m):
            out[c, a] = -2.0 * lam[c, 0] * lam[c, a] - (p0 * dz_a[c, a] + q0 * ds_a[c, a])


# -- Cones of width 2 (norm="l1") --------------------------------------------------------
# A 2-D cone {(t, s): t >= |s|} is a pair of half-lines in the rotated coordinates
# x_a = x₀ + x₁, x_b = x₀ − x₁: x ∈ Q ⇔ x_a, x_b >= 0, the Jordan product is the
# entrywise product, (x ∘ y)_a = x_a y_a, and e = (1, 1). The NT scaling W is
# diagonal there, W_a = √(s_a / z_a), so λ_a = √(s_a z_a), W⁻² = diag(p_a, p_b) with
# p_a = z_a / s_a, and (W⁻¹Δs) ∘ (WΔz) = Δs ∘ Δz: the algebra of the general
# kernels above without square roots, reflections or inner loops. The kernels
# below compute the same quantities from these closed forms (the same iterates
# up to rounding) and are selected by :class:`.ipm.NewtonSystem` for cones of
# width 2. Vectors stay in the (t, s) layout of the general kernels.


@numba.njit(cache=True)
def prepare_newton_pairs(
    s, z, r_z, inv_s, base, inv_alpha, ratio, penalty, lam_sq
):  # pragma: no cover - compiled
    """What a Newton system of 2-D cones needs per cone (:func:`prepare_newton` for m = 2).

    With p = W⁻² = diag(p_a, p_b) in rotated coordinates, α = (p_a + p_b)/2 and
    β = (p_a − p_b)/2 (W⁻² = [[α, β], [β, α]] in (t, s) coordinates), fills

    - inv_s = (1/s_a, 1/s_b): W⁻¹(λ ⋄ x) = (x_a/s_a, x_b/s_b) for a target x;
    - base = u_rz − (1 − z₀, 0), u_rz = W⁻² r_z: the target-free part of the
      right-hand side (:func:`direction_rhs_pairs`);
    - inv_alpha = 1/α, ratio = β/α and penalty = α − β²/α = p_a p_b / α, the
      diagonal Newton-matrix term S_c;
    - lam_sq = λ ∘ λ = (sᵀz, s₀z₁ + s₁z₀).

    Returns False (and stops) if a cone's s or z is not strictly inside its cone,
    which rounding can cause next to the boundary.
    """
    for c in range(s.shape[0]):
        s_a = s[c, 0] + s[c, 1]
        s_b = s[c, 0] - s[c, 1]
        z_a = z[c, 0] + z[c, 1]
        z_b = z[c, 0] - z[c, 1]
        if not (s_a > 0.0 and s_b > 0.0 and z_a > 0.0 and z_b > 0.0):
            return False
        inv_a = 1.0 / s_a
        inv_b = 1.0 / s_b
        p_a = z_a * inv_a
        p_b = z_b * inv_b
        inv_s[c, 0] = inv_a
        inv_s[c, 1] = inv_b
        u_a = p_a * (r_z[c, 0] + r_z[c, 1])
        u_b = p_b * (r_z[c, 0] - r_z[c, 1])
        base[c, 0] = 0.5 * (u_a + u_b) - (1.0 - z[c, 0])
        base[c, 1] = 0.5 * (u_a - u_b)
        inv_sum = 1.0 / (p_a + p_b)
        inv_alpha[c] = 2.0 * inv_sum
        ratio[c] = (p_a - p_b) * inv_sum
        penalty[c] = 2.0 * p_a * p_b * inv_sum
        lam_sq[c, 0] = s[c, 0] * z[c, 0] + s[c, 1] * z[c, 1]
        lam_sq[c, 1] = s[c, 0] * z[c, 1] + s[c, 1] * z[c, 0]
    return True


def direction_rhs_pairs(target, inv_s, base, ratio, r_k, coeffs, w, work, rhs):
    """:func:`direction_rhs` for cones of width 2, from :func:`prepare_newton_pairs`.

    u = u_rz + W⁻¹(λ ⋄ target) is u_rz + (target_a/s_a, target_b/s_b) in rotated
    coordinates; work = (f_t, u₁ − β f_t/α) with f_t = u₀ − (1 − z₀), and
    rhs = −r_k + DᵀΛ work₁.
    """
    _direction_rhs_pairs_cones(target, inv_s, base, ratio, work)
    _stationarity_rhs(work, r_k, coeffs, w, rhs)


@numba.njit(cache=True)
def _direction_rhs_pairs_cones(target, inv_s, base, ratio, work):  # pragma: no cover - compiled
    """The cone part of :func:`direction_rhs_pairs`: fills ``work``."""
    for c in range(target.shape[0]):
        x_a = (target[c, 0] + target[c, 1]) * inv_s[c, 0]
        x_b = (target[c, 0] - target[c, 1]) * inv_s[c, 1]
        f_t = base[c, 0] + 0.5 * (x_a + x_b)
        work[c, 0] = f_t
        work[c, 1] = base[c, 1] + 0.5 * (x_a - x_b) - ratio[c] * f_t


def direction_finish_pairs(
    dk, work, inv_s, r_z, z, inv_alpha, ratio, penalty, coeffs, w, dt, ds, dz
):
    """:func:`direction_finish` for cones of width 2, from :func:`prepare_newton_pairs`.

    With e = ΛDΔk: Δt = f_t/α − (β/α) e, Δs = (Δt, e) − r_z and
    Δz = (1 − z₀, work₁ − S e). Returns the largest steps that keep s + αΔs and
    z + αΔz in the cones: a cone is two half-lines in rotated coordinates, so
    the step is 1 / max(−Δx_a/x_a, −Δx_b/x_b) over all cones (inf if no
    coordinate decreases); :func:`max_step`'s root of a quadratic without its
    cancellation, and without a branch per cone.
    """
    weighted_difference(dk, coeffs, w, ds)  # vector parts: e
    return _direction_finish_pairs_cones(work, inv_s, r_z, z, inv_alpha, ratio, penalty, dt, ds, dz)


@numba.njit(cache=True)
def _direction_finish_pairs_cones(
    work, inv_s, r_z, z, inv_alpha, ratio, penalty, dt, ds, dz
):  # pragma: no cover - compiled
    """The cone part of :func:`direction_finish_pairs`, from ``ds``'s vector parts e = ΛDΔk."""
    shrink_s = shrink_z = 0.0  # the largest relative decrease of a coordinate
    for c in range(ds.shape[0]):
        e = ds[c, 1]
        dt_c = work[c, 0] * inv_alpha[c] - ratio[c] * e
        dt[c] = dt_c
        ds_0 = dt_c - r_z[c, 0]
        ds_1 = e - r_z[c, 1]
        dz_0 = 1.0 - z[c, 0]
        dz_1 = work[c, 1] - penalty[c] * e
        ds[c, 0] = ds_0
        ds[c, 1] = ds_1
        dz[c, 0] = dz_0
        dz[c, 1] = dz_1
        shrink_s = max(shrink_s, -(ds_0 + ds_1) * inv_s[c, 0], -(ds_0 - ds_1) * inv_s[c, 1])
        shrink_z = max(
            shrink_z, -(dz_0 + dz_1) / (z[c, 0] + z[c, 1]), -(dz_0 - dz_1) / (z[c, 0] - z[c, 1])
        )
    step_s = 1.0 / shrink_s if shrink_s > 0.0 else np.inf
    step_z = 1.0 / shrink_z if shrink_z > 0.0 else np.inf
    return step_s, step_z


@numba.njit(cache=True)
def corrector_target_pairs(lam_sq, ds_a, dz_a, sigma_mu, out):  # pragma: no cover - compiled
    """:func:`corrector_target` for cones of width 2: σμe − λ∘λ − Δs_a ∘ Δz_a.

    (W⁻¹Δs) ∘ (WΔz) = Δs ∘ Δz for these cones: W is diagonal in the rotated
    coordinates, where ∘ is the entrywise product. ds_a and dz_a are not changed.
    """
    for c in range(lam_sq.shape[0]):
        out[c, 0] = sigma_mu - lam_sq[c, 0] - (ds_a[c, 0] * dz_a[c, 0] + ds_a[c, 1] * dz_a[c, 1])
        out[c, 1] = -lam_sq[c, 1] - (ds_a[c, 0] * dz_a[c, 1] + ds_a[c, 1] * dz_a[c, 0])


# the signatures of a first fit, compiled ahead of time where the package was built with them
attach(globals())
