"""The starts of :class:`~sindybench.hidden.LatentHiddenState` beyond its lag chain, and its fit checks.

* :func:`subspace_start`: the latent trajectory of a linear state-space model
  fitted by subspace identification (:func:`~sindybench.hidden._subspace.moesp`),
  scaled to the strategy's gauge;
* :func:`support_warnings`: what says ``n_latent`` is more than the data support.
"""

import numpy as np

from ._subspace import singular_values, subspace_states

__all__ = ["subspace_start", "support_warnings"]

_TINY = 1e-9  # a driver coefficient below this (relative) cannot carry the scale gauge
_FLOOR = 1e-3  # a singular value below this fraction of the largest: a state the data do not support
_HUGE = 1e6  # a coefficient this many times the row's typical one: an ill-determined latent law


def subspace_start(strategy, u, y, dt, drivers):
    """``(z, z_dot)``: the latent states of a subspace model of ``(u, y)``, scaled to the gauge of ``strategy``.

    ``drivers`` are the columns of ``[measured, z, u]`` whose coefficient in
    each latent row fixes its scale (``scale="driver"``: made 1); with
    ``scale="range"`` each latent state is mapped onto the middle 80 % of
    ``latent_bounds``.
    """
    p, order, q = y.shape[1], int(strategy.order), int(strategy.n_latent)
    if u.shape[1] == 0:
        raise ValueError("start='subspace' needs at least one input; got none.")
    z, z_dot, W, _ = subspace_states(u, y, p * order + q, dt, n_measured_rows=order,
                                     block_rows=getattr(strategy, "block_rows", None))
    if strategy.scale == "range":
        lo, hi = strategy.latent_bounds
        span = np.ptp(z, axis=0)
        span = np.where(span > 0, span, 1.0)
        factor = 0.8 * (hi - lo) / span
        return lo + (hi - lo) * 0.1 + (z - z.min(axis=0)) * factor, z_dot * factor
    scale = np.ones(q)
    for j, col in enumerate(drivers):
        c = W[j, col] * (1.0 if j == 0 else 1.0 / scale[j - 1])  # z_{j-1} is already scaled by scale[j-1]
        if abs(c) <= _TINY * (1.0 + np.max(np.abs(W[j]))):
            raise ValueError(f"the subspace start's z{j} has no driver term to fix its scale; use start='lag'.")
        scale[j] = 1.0 / c
    return z * scale, z_dot * scale


def support_warnings(strategy, model, u, y, dt):
    """Messages saying that ``n_latent`` is larger than the data support (empty when nothing says so).

    Two signs: the singular values of a subspace fit of ``(u, y)`` fall below
    ``1e-3`` of the largest before the model's order
    (``n_outputs * order + n_latent``): the data show fewer states; and a
    latent row's largest coefficient exceeds ``1e6`` times its median
    nonzero one: an ill-determined latent law.
    """
    p, q = y.shape[1], int(strategy.n_latent)
    n_states = p * int(strategy.order) + q
    out = []
    if u.shape[1] >= 1:
        try:
            sv = singular_values(u, y)
        except (ValueError, np.linalg.LinAlgError):
            sv = None
        if sv is not None and len(sv) >= n_states and sv[n_states - 1] < _FLOOR * sv[0]:
            support = int(np.sum(sv >= _FLOOR * sv[0]))
            out.append(f"n_latent={q} may be more than the data support: a subspace fit sees {support} state(s) above "
                       f"1e-3 of the largest singular value, the model has {n_states} "
                       f"(singular values {np.array2string(sv[:n_states + 1], precision=3)})")
    coef = np.asarray(model.coef_, dtype=float)
    n_meas = p * int(strategy.order)
    for j in range(q):
        row = coef[list(model.structure_.learned).index(n_meas + j)]
        nz = np.abs(row[row != 0])
        if nz.size >= 2 and nz.max() > _HUGE * np.median(nz):
            out.append(f"z{j}: coefficients spanning {nz.max() / np.median(nz):.3g} times their median: the latent "
                       f"law is ill-determined; n_latent={q} may be more than the data support")
    return out
