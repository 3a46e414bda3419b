"""A linear state-space start for latent states: subspace identification (MOESP) in numpy.

Written here rather than taken from a package: the one small, maintained
PyPI implementation found (``nfoursid`` 1.0.2) takes pandas DataFrames and
requires matplotlib and pandas, two dependencies the core does not have, for
what is an SVD and two least-squares solves (about 60 lines below).

The method (Verhaegen's ordinary MOESP): the LQ factorisation of the block
Hankel matrices of the future inputs and outputs removes the inputs'
contribution; the left singular vectors of what remains span the extended
observability matrix, from which ``C`` and ``A`` follow (shift invariance);
``B`` and the initial state then are a linear least-squares fit of the
outputs (``D = 0``: a sampled continuous-time plant is strictly proper).
"""

import hashlib
from collections import OrderedDict

import numpy as np
from numba import njit
from scipy.linalg import logm, null_space

__all__ = ["moesp", "moesp_orders", "singular_values", "subspace_states"]


#: the last fits of :func:`subspace_states` (a few small arrays each), by their data and settings: a search fits the
#: same start for each of its candidates that differ only in what the start does not read (the input hold)
_FITS = OrderedDict()
_MAX_FITS = 16


def _hankel(a, rows, cols):
    """Block Hankel matrix (rows * a.shape[1], cols) of the signal ``a`` (n_samples, k)."""
    return np.vstack([a[r:r + cols].T for r in range(rows)])


def _projected_svd(u, y, n, block_rows=None):
    """SVD ``(U, sv)`` of the outputs' block Hankel matrix with the future inputs projected out (LQ)."""
    (N, p), m = y.shape, u.shape[1]
    i = int(block_rows or max(2 * n, 10))
    cols = N - i + 1
    if cols < 2 * i * (m + p) or n >= i * p:
        raise ValueError(f"a subspace fit of {n} states needs more samples; got {N}.")
    H = np.vstack([_hankel(u, i, cols), _hankel(y, i, cols)]) / np.sqrt(cols)
    L = np.linalg.qr(H.T, mode="r").T  # H = L Q
    U, sv, _ = np.linalg.svd(L[i * m:, i * m:])
    return U, sv


def singular_values(u, y, *, block_rows=10):
    """The singular values :func:`moesp` orders the states by (their decay: how many states the data support)."""
    return _projected_svd(np.asarray(u, dtype=float), np.asarray(y, dtype=float), 1, block_rows)[1]


def moesp(u, y, n_states, *, block_rows=None):
    """Discrete-time ``(A, B, C, x0, sv)`` of order ``n_states`` fitted to ``(u, y)`` by MOESP.

    Parameters
    ----------
    u : ndarray of shape (n_samples, n_inputs)
    y : ndarray of shape (n_samples, n_outputs)
    n_states : int
    block_rows : int, optional
        Block rows of the Hankel matrices; default ``max(2 n_states, 10)``.

    Returns
    -------
    A, B, C, x0 : ndarray
        ``x[k+1] = A x[k] + B u[k]``, ``y[k] = C x[k]``, ``x[0] = x0``.
    sv : ndarray
        The singular values of the projected output Hankel matrix (their
        decay tells how many states the data support).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((400, 1))
    >>> y = np.zeros((400, 1))
    >>> x = 0.0
    >>> for k in range(399):
    ...     x = 0.9 * x + u[k, 0]
    ...     y[k + 1, 0] = x
    >>> A, B, C, x0, sv = moesp(u, y, 1)
    >>> round(float(A[0, 0]), 3), round(float(C[0, 0] * B[0, 0]), 3)
    (0.9, 1.0)
    """
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    U, sv = _projected_svd(u, y, int(n_states), block_rows)
    return _from_svd(U, sv, u, y, int(n_states)) + (sv,)


def moesp_orders(u, y, orders, *, block_rows=None, n_fit=None):
    """``{n: (A, B, C, x0, d, y_hat)}`` of :func:`moesp` at each order of ``orders`` from one factorisation, and ``sv``.

    The models are fitted on the first ``n_fit`` samples (default all):
    ``A`` and ``C`` from the signals about their means; ``B``, ``x0`` and
    ``d``, an output offset (``y[k] = C x[k] + d``), from the signals as they
    are; ``y_hat`` is the free run over every sample of ``u``. Orders the
    factorisation cannot hold (``n >= block_rows * n_outputs``) are left out.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((400, 1))
    >>> fits, sv = moesp_orders(u, np.cumsum(u, axis=0), [1, 2], block_rows=10)
    >>> sorted(fits), round(float(fits[1][0][0, 0]), 3)
    ([1, 2], 1.0)
    """
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    n_fit = len(y) if n_fit is None else int(n_fit)
    i = int(block_rows or max(2 * max(orders), 10))
    uf, yf = u[:n_fit], y[:n_fit]
    U, sv = _projected_svd(uf - uf.mean(axis=0), yf - yf.mean(axis=0), 1, i)
    return {int(n): _from_svd(U, sv, u, y, int(n), n_fit=n_fit) for n in orders if int(n) < i * y.shape[1]}, sv


def _from_svd(U, sv, u, y, n, n_fit=None):
    """``(A, B, C, x0)`` of order ``n`` from the projected SVD ``(U, sv)`` of :func:`_projected_svd`; with
    ``n_fit``, fitted on the first ``n_fit`` samples with an output offset ``d``, and ``(d, y_hat)`` appended."""
    (N, p), m = y.shape, u.shape[1]
    gamma = U[:, :n] * np.sqrt(sv[:n])
    C = gamma[:p]
    A = np.linalg.lstsq(gamma[:-p], gamma[p:], rcond=None)[0]
    # B and x0: y[k] = C A^k x0 + sum_j C A^(k-1-j) B u[j], linear in (x0, B): the responses to x0's entries and to
    # B's entry (r, c) (A^(.) e_r u_c), one propagation of their states
    cols = _responses(np.ascontiguousarray(A), np.ascontiguousarray(C), np.ascontiguousarray(u, dtype=float))
    parts = [cols] + ([np.broadcast_to(np.eye(p), (N, p, p))] if n_fit is not None else [])
    reg = np.concatenate(parts, axis=2).reshape(N * p, -1)
    if not np.all(np.isfinite(reg)):  # an unstable A: its responses overflow (LAPACK would print and then fail)
        raise np.linalg.LinAlgError(f"the responses of the order-{n} subspace model overflow (its A is unstable)")
    k_fit = N if n_fit is None else n_fit
    theta = np.linalg.lstsq(reg[:k_fit * p], y[:k_fit].reshape(-1), rcond=None)[0]
    x0, B = theta[:n], theta[n:n + n * m].reshape(m, n).T
    if n_fit is None:
        return A, B, C, x0
    return A, B, C, x0, theta[n + n * m:], (reg @ theta).reshape(N, p)


@njit(cache=True)
def _responses(A, C, u):
    """The outputs ``C x[k]`` (n_samples, p, n + n m) of the states ``x[k+1] = A x[k] + e_r u_c[k]`` from ``x[0] = e_r``
    (the initial state's entries, columns ``r``) and from ``x[0] = 0`` (B's entries, columns ``n + c n + r``).

    Row by row, in O(p n^2 (1 + m)) per sample: the free responses are ``C A^k``; the forced ones
    ``C S_k`` with ``S_k = sum_(j<k) A^(k-1-j) u_c[j]``, a polynomial in ``A`` (so ``A S_k = S_k A``), hence
    ``C S_(k+1) = (C S_k) A + C u_c[k]``.
    """
    n, p, (N, m) = A.shape[0], C.shape[0], u.shape
    cols = np.empty((N, p, n + n * m))
    free = C.copy()  # C A^k
    forced = np.zeros((m, p, n))  # C S_k per input
    row = np.empty(n)
    for k in range(N):
        for a in range(p):
            for r in range(n):
                cols[k, a, r] = free[a, r]
            for c in range(m):
                for r in range(n):
                    cols[k, a, n + c * n + r] = forced[c, a, r]
        for a in range(p):
            for r in range(n):
                acc = 0.0
                for i in range(n):
                    acc += free[a, i] * A[i, r]
                row[r] = acc
            free[a] = row
            for c in range(m):
                for r in range(n):
                    acc = C[a, r] * u[k, c]
                    for i in range(n):
                        acc += forced[c, a, i] * A[i, r]
                    row[r] = acc
                forced[c, a] = row
    return cols


@njit(cache=True)
def _states(A, B, x0, u):
    """The states ``x[k+1] = A x[k] + B u[k]`` from ``x[0] = x0`` (n_samples, n)."""
    n, (N, m) = A.shape[0], u.shape
    x = np.empty((N, n))
    x[0] = x0
    for k in range(N - 1):
        for r in range(n):
            acc = 0.0
            for i in range(n):
                acc += A[r, i] * x[k, i]
            forced = 0.0
            for c in range(m):
                forced += B[r, c] * u[k, c]
            x[k + 1, r] = acc + forced
    return x


def _continuous(A, B, dt):
    """``(Ac, Bc)`` whose zero-order-hold sampling at ``dt`` is ``(A, B)`` (Euler when the logarithm is not real)."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:], M[n:, n:] = A, B, np.eye(m)
    with np.errstate(all="ignore"):
        try:
            L = logm(M) / dt
        except (ValueError, np.linalg.LinAlgError):
            L = None
    if L is None or not np.all(np.isfinite(L)) or np.max(np.abs(np.imag(L))) > 1e-6 * (1 + np.max(np.abs(L))):
        return (A - np.eye(n)) / dt, B / dt
    L = np.real(L)
    return L[:n, :n], L[:n, n:]


def _moesp_once(u, y, n_states, block_rows):
    """:func:`moesp` of ``(u, y)``, computed once for the same data and settings (copies of the stored fit)."""
    digest = hashlib.blake2b(digest_size=16)
    for a in (u, y):
        a = np.ascontiguousarray(a, dtype=float)
        digest.update(repr(a.shape).encode())
        digest.update(a.tobytes())
    key = (digest.hexdigest(), int(n_states), block_rows)
    fit = _FITS.get(key)
    if fit is None:
        fit = moesp(u, y, n_states, block_rows=block_rows)
        _FITS[key] = fit
        while len(_FITS) > _MAX_FITS:
            _FITS.popitem(last=False)
    else:
        _FITS.move_to_end(key)
    return tuple(np.array(a, copy=True) for a in fit)


def subspace_states(u, y, n_states, dt, *, n_measured_rows=1, block_rows=None):
    """A linear model's state trajectory split into measured coordinates and the rest.

    Fits :func:`moesp` of order ``n_states``, simulates it on the record from
    its fitted initial state, and returns the coordinates ``z = N x`` of the
    state along the orthonormal complement ``N`` of the measured rows
    (``C`` for ``n_measured_rows=1``; ``C`` and ``C Ac`` for 2, the outputs
    and their velocities), with their exact derivatives ``N (Ac x + Bc u)``
    and ``W``, the latent rows' linear coefficients on ``[measured, z, u]``
    (so a gauge can scale them).

    Returns
    -------
    z, z_dot : ndarray of shape (n_samples, n_latent)
        ``n_latent = n_states - n_measured_rows * n_outputs``.
    W : ndarray of shape (n_latent, n_states + n_inputs)
        ``z' = W [measured; z; u]`` (``x = T^-1 [measured; z]``).
    sv : ndarray
        The singular values of :func:`moesp`.
    """
    u = u - u.mean(axis=0)  # about the means: the model has no constant (the library's constants take them)
    y = y - y.mean(axis=0)
    A, B, C, x0, sv = _moesp_once(u, y, n_states, block_rows)
    Ac, Bc = _continuous(A, B, dt)
    rows = [C] if n_measured_rows == 1 else [C, C @ Ac]
    Mrows = np.vstack(rows)
    N = null_space(Mrows).T
    T = np.vstack([Mrows, N])
    x = _states(A, B, x0, np.ascontiguousarray(u, dtype=float))
    z = x @ N.T
    z_dot = (x @ Ac.T + u @ Bc.T) @ N.T
    Tinv = np.linalg.pinv(T)
    return z, z_dot, np.hstack([N @ Ac @ Tinv, N @ Bc]), sv
