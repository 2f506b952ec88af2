"""Cyclic pentadiagonal systems and the box-constrained QP of the racing line.

The racing line's quadratic programme (:mod:`h2h_racing.policies.racing_line`) has a Hessian
that couples each grid point only with its two neighbours on each side, round a closed loop:
a symmetric *cyclic pentadiagonal* matrix. Stored densely it costs ``K^2`` memory and ``K^2``
work per solve, minutes for the ~2,500 points of a 500 m circuit; stored as three bands it
costs ``O(K)`` per solve.

Factorisation. With ``m = K - 2``, the matrix is split into the pentadiagonal leading block
``B`` (points ``0 .. m-1``, no wrap-around), the border ``C`` (``m x 2``: the couplings of the
last two points with the first and last two of ``B``, which carry the wrap-around) and the
``2 x 2`` block ``D`` of the last two points. ``B = L diag(D_B) L'`` is factorised once with a
banded LDL' (Golub & Van Loan, *Matrix Computations*, 4th ed., alg. 4.3.6), and the border by
block elimination (the Schur complement ``S = D - C' B^-1 C``)::

    y = B^-1 r1,   x2 = S^-1 (r2 - C' y),   x1 = y - (B^-1 C) x2

which is exact (no iteration) for any symmetric positive definite cyclic pentadiagonal matrix.

The QP ``min x'Hx/2 + lin'x, lo <= x <= hi`` is solved by ADMM with over-relaxation (Boyd
et al., *Distributed Optimization and Statistical Learning via ADMM*, 2011, sec. 5.2; the
OSQP iteration), each iteration one banded solve with ``H + rho I``. Compiled with numba.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numba import njit

FloatArray = npt.NDArray[np.float64]


class CyclicPentadiagonal:
    """A factorised symmetric positive definite cyclic pentadiagonal matrix ``M`` (K x K).

    ``M[i, i] = diag[i]``, ``M[i, (i + 1) % K] = off1[i]``, ``M[i, (i + 2) % K] = off2[i]``,
    and symmetric.

    Args:
        diag: Main diagonal, shape (K,), K >= 5.
        off1: First off-diagonal with its wrap-around entry ``M[K-1, 0]`` last, shape (K,).
        off2: Second off-diagonal with ``M[K-2, 0]`` and ``M[K-1, 1]`` last, shape (K,).

    Raises:
        ValueError: On bad shapes, or if ``M`` is not positive definite.
    """

    def __init__(self, diag: FloatArray, off1: FloatArray, off2: FloatArray) -> None:
        d0, d1, d2 = (np.ascontiguousarray(a, dtype=np.float64) for a in (diag, off1, off2))
        k = len(d0)
        if k < 5 or d1.shape != (k,) or d2.shape != (k,):
            raise ValueError(f"expected three bands of the same length K >= 5, got shapes "
                             f"{d0.shape}, {d1.shape}, {d2.shape}")
        m = k - 2
        self.size = k
        self.lead, self.l1, self.l2 = _ldl_band2(d0[:m], d1[:m], d2[:m])
        if not np.all(self.lead > 0):
            raise ValueError("the matrix is not positive definite (a zero or negative pivot)")
        border = np.zeros((2, m))  # C', row-major: the two border columns of B's rows
        for col, j in enumerate((k - 2, k - 1)):
            for i in range(m):
                border[col, i] = _entry(d1, d2, k, i, j)
        corner = np.array([[d0[k - 2], d1[k - 2]], [d1[k - 2], d0[k - 1]]])
        self.border = border
        self.z = np.stack([_band_solve(self.lead, self.l1, self.l2, border[c].copy())
                           for c in range(2)])  # (B^-1 C)', shape (2, m)
        schur = corner - border @ self.z.T
        if not (schur[0, 0] > 0 and np.linalg.det(schur) > 0):
            raise ValueError("the matrix is not positive definite (its Schur complement is not)")
        self.schur_inv = np.linalg.inv(schur)

    def solve(self, rhs: FloatArray) -> FloatArray:
        """Return ``M^-1 rhs`` for ``rhs`` of shape (K,)."""
        out = np.empty(self.size)
        _cyclic_solve(self.lead, self.l1, self.l2, self.border, self.z, self.schur_inv,
                      np.ascontiguousarray(rhs, dtype=np.float64), out)
        return out


def _entry(d1: FloatArray, d2: FloatArray, k: int, i: int, j: int) -> float:
    """Off-diagonal entry ``M[i, j]`` (i != j) of the cyclic pentadiagonal matrix."""
    ahead = (j - i) % k
    if ahead == 1:
        return float(d1[i])
    if ahead == 2:
        return float(d2[i])
    behind = (i - j) % k
    if behind == 1:
        return float(d1[j])
    if behind == 2:
        return float(d2[j])
    return 0.0


def box_qp(diag: FloatArray, off1: FloatArray, off2: FloatArray, lin: FloatArray,
           lo: FloatArray, hi: FloatArray, start: FloatArray, rho: float,
           tolerance: float = 1e-6, max_iterations: int = 20_000) -> FloatArray:
    """Minimise ``x'Hx/2 + lin'x`` subject to ``lo <= x <= hi``, H cyclic pentadiagonal.

    ADMM on the splitting ``x = z, z in [lo, hi]`` with over-relaxation ``alpha = 1.6``:
    ``x = (H + rho I)^-1 (rho (z - u) - lin)``, ``z = clip(alpha x + (1 - alpha) z + u)``,
    ``u += alpha x + (1 - alpha) z_old - z``.

    Args:
        diag, off1, off2: The bands of H (see :class:`CyclicPentadiagonal`), positive definite.
        lin: Linear term, shape (K,).
        lo: Lower bounds, shape (K,).
        hi: Upper bounds, shape (K,).
        start: Initial guess (warm start), shape (K,).
        rho: ADMM penalty, relative to the largest absolute row sum of H.
        tolerance: Stop when the primal and dual residuals are below this.
        max_iterations: Iteration cap.

    Returns:
        The minimiser, shape (K,), within the bounds.
    """
    d0, d1, d2 = (np.asarray(a, dtype=np.float64) for a in (diag, off1, off2))
    row_sum = (np.abs(d0) + np.abs(d1) + np.abs(np.roll(d1, 1)) + np.abs(d2)
               + np.abs(np.roll(d2, 2)))
    rho = rho * float(row_sum.max())
    factor = CyclicPentadiagonal(d0 + rho, d1, d2)
    z = np.minimum(np.maximum(np.asarray(start, dtype=np.float64), lo), hi)
    return _admm(factor.lead, factor.l1, factor.l2, factor.border, factor.z, factor.schur_inv,
                 np.ascontiguousarray(lin, dtype=np.float64),
                 np.ascontiguousarray(lo, dtype=np.float64),
                 np.ascontiguousarray(hi, dtype=np.float64), z, rho, tolerance, max_iterations)


@njit(cache=True)
def _ldl_band2(d0, d1, d2):  # pragma: no cover
    """Banded LDL' of a (non-cyclic) pentadiagonal matrix: returns (D, L[i, i-1], L[i, i-2])."""
    n = d0.shape[0]
    dd = np.empty(n)
    l1 = np.zeros(n)
    l2 = np.zeros(n)
    for i in range(n):
        if i >= 2:
            l2[i] = d2[i - 2] / dd[i - 2]
        if i >= 1:
            a = d1[i - 1]
            if i >= 2:
                a -= l2[i] * l1[i - 1] * dd[i - 2]
            l1[i] = a / dd[i - 1]
        piv = d0[i]
        if i >= 1:
            piv -= l1[i] * l1[i] * dd[i - 1]
        if i >= 2:
            piv -= l2[i] * l2[i] * dd[i - 2]
        dd[i] = piv
    return dd, l1, l2


@njit(cache=True)
def _band_solve(dd, l1, l2, r):  # pragma: no cover
    """Solve ``L diag(dd) L' x = r`` in place (r is overwritten and returned)."""
    n = dd.shape[0]
    for i in range(1, n):
        r[i] -= l1[i] * r[i - 1]
        if i >= 2:
            r[i] -= l2[i] * r[i - 2]
    for i in range(n):
        r[i] /= dd[i]
    for i in range(n - 2, -1, -1):
        r[i] -= l1[i + 1] * r[i + 1]
        if i + 2 < n:
            r[i] -= l2[i + 2] * r[i + 2]
    return r


@njit(cache=True)
def _cyclic_solve(dd, l1, l2, border, z, schur_inv, rhs, out):  # pragma: no cover
    """Block elimination of the border: ``out = M^-1 rhs``."""
    m = dd.shape[0]
    y = rhs[:m].copy()
    _band_solve(dd, l1, l2, y)
    # Plain loops, not np.dot: numba compiles np.dot into a BLAS call that needs scipy at
    # run time, which the package does not depend on.
    r0 = rhs[m]
    r1 = rhs[m + 1]
    for i in range(m):
        r0 -= border[0, i] * y[i]
        r1 -= border[1, i] * y[i]
    x0 = schur_inv[0, 0] * r0 + schur_inv[0, 1] * r1
    x1 = schur_inv[1, 0] * r0 + schur_inv[1, 1] * r1
    for i in range(m):
        out[i] = y[i] - z[0, i] * x0 - z[1, i] * x1
    out[m] = x0
    out[m + 1] = x1


@njit(cache=True)
def _admm(dd, l1, l2, border, zfac, schur_inv, lin, lo, hi, z, rho, tolerance,
          max_iterations):  # pragma: no cover
    """The ADMM iteration of :func:`box_qp` (``z`` is the clipped warm start)."""
    k = lin.shape[0]
    alpha = 1.6
    u = np.zeros(k)
    x = np.empty(k)
    rhs = np.empty(k)
    for _ in range(max_iterations):
        for i in range(k):
            rhs[i] = rho * (z[i] - u[i]) - lin[i]
        _cyclic_solve(dd, l1, l2, border, zfac, schur_inv, rhs, x)
        primal = 0.0
        dual = 0.0
        for i in range(k):
            relaxed = alpha * x[i] + (1.0 - alpha) * z[i]
            z_new = min(max(relaxed + u[i], lo[i]), hi[i])
            u[i] += relaxed - z_new
            primal = max(primal, abs(x[i] - z_new))
            dual = max(dual, abs(z_new - z[i]))
            z[i] = z_new
        if primal < tolerance and dual < tolerance:
            break
    return z
