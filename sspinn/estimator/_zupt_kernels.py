"""Compiled kernels of the ZUPT Kalman filter (:class:`sspinn.estimator.zupt.SagittalZuptKalman`).

The estimator integrates the nominal state (angle θ, velocity v, position p) with the strapdown
equations in NumPy; these numba kernels run the open-loop error-state Kalman filter and the
Rauch–Tung–Striebel smoother over it (gaitmap's ``RtsKalman`` in 2D). Symbols:

* error state δx = nominal − true = (δθ, δv_x, δv_y, δp_x, δp_y[, b]), n = 5 or 6, with b the gyro
  bias (rad/s; measured rate = true rate + b);
* f_g = R(θ)·f, the global specific force of the nominal state (``f_global``, (T, 2));
* F_k, the linearised transition from sample k−1 to k (:func:`_transition`, trapezoidal rule):
  δθ' = δθ + b·dt, δv' = δv + dt·J·f̄_g·δθ (+ ½dt²·J·f̄_g·b), δp' = δp + dt·δv + ½dt²·J·f̄_g·δθ,
  with J the +90° rotation (an angle error tilts the global specific force) and f̄_g the mean of
  f_g over the step;
* Q = diag(``q_diag``), the process noise per sample; P₀ = diag(``p0_diag``), the prior;
* stance samples observe z = H·δx + noise, noise covariance R = diag(``r_diag``) (the rows of H
  pick v_x, v_y[, p_y][, b]; ``measurements`` holds z, the nominal values whose true value is
  known in stance);
* filter: x⁻_k = F_k x⁺_{k−1}, P⁻_k = F_k P⁺_{k−1} F_kᵀ + Q; in stance S = H P⁻ Hᵀ + R,
  K = P⁻ Hᵀ S⁻¹, x⁺ = x⁻ + K (z − H x⁻), P⁺ = (I − KH) P⁻ (I − KH)ᵀ + K R Kᵀ (Joseph form);
* smoother: G_k = P⁺_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹, xˢ_k = x⁺_k + G_k (xˢ_{k+1} − x⁻_{k+1}),
  Pˢ_k = P⁺_k + G_k (Pˢ_{k+1} − P⁻_{k+1}) G_kᵀ.

The kernels use explicit loops only (no array expressions or slice assignments) and the
hand-written small linear algebra of :mod:`sspinn.estimator._numba_linalg`, to keep numba's compile time at
a few seconds. Cost: O(T), about 30 ms per pass over 8 k samples and 0.7 kB of covariance storage
per sample (≈ 6 MB for the 8 k-sample validation recording). The first call in a fresh checkout
compiles the kernels (≈ 8 s on a slow 2-core machine); numba caches them on disk
(``__pycache__``), later processes load them in well under a second.
"""

from __future__ import annotations

import numba
import numpy as np

from sspinn.estimator._numba_linalg import mm, mv, solve


@numba.njit(cache=True)
def _transition(f_prev: np.ndarray, f_now: np.ndarray, dt: float, n: int) -> np.ndarray:
    """Error-state transition from sample k−1 to k (states: θ, v_x, v_y, p_x, p_y[, b])."""
    F = np.zeros((n, n))
    for i in range(n):
        F[i, i] = 1.0
    # J·f with J the +90° rotation: d(R(θ)·f)/dθ, averaged over the trapezoidal step
    jx = -0.5 * (f_prev[1] + f_now[1])
    jy = 0.5 * (f_prev[0] + f_now[0])
    F[1, 0] = dt * jx
    F[2, 0] = dt * jy
    F[3, 1] = dt
    F[4, 2] = dt
    F[3, 0] = 0.5 * dt * dt * jx
    F[4, 0] = 0.5 * dt * dt * jy
    if n == 6:
        F[0, 5] = dt
        F[1, 5] = 0.5 * dt * dt * jx
        F[2, 5] = 0.5 * dt * dt * jy
    return F


@numba.njit(cache=True)
def _store(dst: np.ndarray, k: int, src: np.ndarray) -> None:
    """dst[k] = src for a (T, n, n) stack (an explicit loop: numba compiles slice assignment slowly)."""
    n, m = src.shape
    for i in range(n):
        for j in range(m):
            dst[k, i, j] = src[i, j]


@numba.njit(cache=True)
def _store_row(dst: np.ndarray, k: int, src: np.ndarray) -> None:
    """dst[k] = src for a (T, n) array (explicit loop, see :func:`_store`)."""
    for i in range(src.shape[0]):
        dst[k, i] = src[i]


@numba.njit(cache=True)
def _sym_sum(A: np.ndarray, B: np.ndarray, sign: float) -> np.ndarray:
    """The symmetric part of A + sign·B."""
    n = A.shape[0]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (A[i, j] + A[j, i] + sign * (B[i, j] + B[j, i]))
    return out


@numba.njit(cache=True)
def eskf_rts(
    f_global: np.ndarray,
    measurements: np.ndarray,
    stance: np.ndarray,
    dt: float,
    q_diag: np.ndarray,
    p0_diag: np.ndarray,
    H: np.ndarray,
    r_diag: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Open-loop error-state Kalman filter + RTS smoother (equations in the module docstring).

    ``f_global`` (T, 2) is f_g; ``measurements`` (T, m) are the stance-sample observations z of
    ``H @ δx`` (noise variances ``r_diag``); ``stance`` (T,) bool marks the samples that are
    updated; ``q_diag``/``p0_diag`` (n,) are Q and P₀. Returns the smoothed error states xˢ
    (T, n) and their variances diag(Pˢ) (T, n). Written with explicit loops only (no array
    expressions or slice assignments) to keep numba's compile time at a few seconds.
    """
    T = f_global.shape[0]
    n = q_diag.shape[0]
    m = r_diag.shape[0]
    x_prior = np.zeros((T, n))
    x_post = np.zeros((T, n))
    P_prior = np.zeros((T, n, n))
    P_post = np.zeros((T, n, n))
    P = np.zeros((n, n))
    for i in range(n):
        P[i, i] = p0_diag[i]
    x = np.zeros(n)
    A = np.zeros((n, n))
    KR = np.zeros((n, m))
    innovation = np.zeros(m)
    for k in range(T):
        if k > 0:
            F = _transition(f_global[k - 1], f_global[k], dt, n)
            x = mv(F, x)
            P = mm(mm(F, P), F.T)
            for i in range(n):
                P[i, i] += q_diag[i]
        _store_row(x_prior, k, x)
        _store(P_prior, k, P)
        if stance[k]:
            HP = mm(H, P)
            S = mm(HP, H.T)
            for i in range(m):
                S[i, i] += r_diag[i]
            Kt = solve(S, HP)  # (P Hᵀ S⁻¹)ᵀ, as P and S are symmetric
            Hx = mv(H, x)
            for j in range(m):
                innovation[j] = measurements[k, j] - Hx[j]
            for i in range(n):
                for j in range(m):
                    x[i] += Kt[j, i] * innovation[j]
                    KR[i, j] = Kt[j, i] * r_diag[j]
                for j in range(n):
                    acc = 1.0 if i == j else 0.0
                    for l in range(m):
                        acc -= Kt[l, i] * H[l, j]
                    A[i, j] = acc
            P = _sym_sum(mm(mm(A, P), A.T), mm(KR, Kt), 1.0)  # Joseph form (I−KH)P(I−KH)ᵀ + KRKᵀ
        _store_row(x_post, k, x)
        _store(P_post, k, P)
    x_s = np.zeros((T, n))
    var_s = np.zeros((T, n))
    P_s = P_post[T - 1]
    for i in range(n):
        x_s[T - 1, i] = x_post[T - 1, i]
        var_s[T - 1, i] = P_s[i, i]
    dx = np.zeros(n)
    for k in range(T - 2, -1, -1):
        F = _transition(f_global[k], f_global[k + 1], dt, n)
        Gt = solve(P_prior[k + 1], mm(F, P_post[k]))  # (P⁺_k Fᵀ (P⁻_{k+1})⁻¹)ᵀ
        for i in range(n):
            dx[i] = x_s[k + 1, i] - x_prior[k + 1, i]
        for i in range(n):
            acc = x_post[k, i]
            for j in range(n):
                acc += Gt[j, i] * dx[j]
            x_s[k, i] = acc
        D = _sym_sum(P_s, P_prior[k + 1], -1.0)
        P_s = _sym_sum(P_post[k], mm(mm(Gt.T, D), Gt), 1.0)  # G D Gᵀ = Gtᵀ D Gt
        for i in range(n):
            var_s[k, i] = P_s[i, i]
    return x_s, var_s
