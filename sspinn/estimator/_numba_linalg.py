"""Small dense linear algebra for numba kernels, written out as plain loops.

numba compiles these in seconds, while its LAPACK-backed ``np.linalg.solve`` and BLAS matmul
take tens of seconds to compile; for the small matrices of the kernels that use them (at most
6×6 in the ZUPT filter, :mod:`sspinn.estimator._zupt_kernels`) the loops are as fast. Every function
allocates and returns a new float64 array. Transposed operands are passed as views (``mm(A, B.T)``
for A·Bᵀ); numba compiles one version per memory layout.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def mm(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """A @ B."""
    n, k = A.shape
    m = B.shape[1]
    C = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            acc = 0.0
            for l in range(k):
                acc += A[i, l] * B[l, j]
            C[i, j] = acc
    return C


@numba.njit(cache=True)
def mv(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    """A @ x."""
    n, k = A.shape
    y = np.zeros(n)
    for i in range(n):
        acc = 0.0
        for l in range(k):
            acc += A[i, l] * x[l]
        y[i] = acc
    return y


@numba.njit(cache=True)
def solve(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """X with A @ X = B, Gaussian elimination with partial pivoting (A square, B 2D)."""
    n = A.shape[0]
    m = B.shape[1]
    M = A.copy()
    X = B.copy()
    for c in range(n):
        p = c
        best = abs(M[c, c])
        for r in range(c + 1, n):
            if abs(M[r, c]) > best:
                best = abs(M[r, c])
                p = r
        if p != c:
            for j in range(n):
                M[c, j], M[p, j] = M[p, j], M[c, j]
            for j in range(m):
                X[c, j], X[p, j] = X[p, j], X[c, j]
        piv = M[c, c]
        for r in range(c + 1, n):
            fct = M[r, c] / piv
            if fct != 0.0:
                for j in range(c, n):
                    M[r, j] -= fct * M[c, j]
                for j in range(m):
                    X[r, j] -= fct * X[c, j]
    for c in range(n - 1, -1, -1):
        for j in range(m):
            acc = X[c, j]
            for l in range(c + 1, n):
                acc -= M[c, l] * X[l, j]
            X[c, j] = acc / M[c, c]
    return X
