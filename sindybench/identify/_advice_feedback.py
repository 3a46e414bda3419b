"""The data advice's checks of the loop: feedback (the inputs' innovations predicting the output) and the
poles of an ARX model of the record (unstable, integrating) (see :mod:`sindybench.identify._advice`)."""

import numpy as np
from scipy.stats import f as f_dist

from ..baselines._arx import least_squares
from ..baselines._lags import input_lags, output_lags
from ._advice_delay import HELD_OUT

__all__ = ["arx_poles", "feedback_test", "pole_findings"]


def _innovations(X, order):
    """Per input, the one-step prediction errors of an AR(``order``) fit, and the smallest share of variance left.

    Row ``k`` of the errors belongs to sample ``order + k``.
    """
    n = X.shape[0]
    errors = np.zeros((n - order, X.shape[1]))
    shares = []
    for i, u in enumerate(X.T):
        _, _, resid = least_squares(output_lags(u[:, None], order, order), u[order:, None])
        errors[:, i] = resid[:, 0]
        var = np.var(u[order:])
        shares.append(float(np.var(resid) / var) if var > 0 else 0.0)
    return errors, min(shares, default=0.0)


def feedback_test(X, y, nk, na=4, nb=10, n_future=10, ar_order=20):
    """The feedback check: ``(p, effect)``, or ``(None, reason)`` when the record cannot tell.

    The test asks whether the *innovations* of the inputs (what an AR(``ar_order``)
    model of each input cannot predict from its own past) at the next
    ``n_future`` samples improve an ARX(``na``, ``nb``, ``nk``) prediction of ``y[t]`` (an F test,
    ``p``), and by how much (``effect``: the share of the ARX residual's sum of
    squares they explain). In open loop an input's innovation is independent of
    everything before it, the output's noise and the ARX model's misfit
    included, so it adds nothing however poor the ARX model is (a slow, lightly
    damped or nonlinear plant); with feedback the inputs react to the output's
    noise, and so do their innovations. Raw future inputs, the former
    regressors, are correlated with the past inputs that a misfitting ARX
    model leaves in its residual: on the open-loop Silverbox and Bouc-Wen
    records they gave p = 0 and 1e-105. The innovation of ``u[t]`` itself is
    left out: a band-limited input's value at ``t`` tells what the plant saw
    between the samples (on Silverbox it explained 7 % of the residual). So a
    controller that reacts within the sample to a slow disturbance, and only
    then, is not seen (its later inputs are predictable from ``u[t]``).

    Inputs that their own past predicts (a periodic multisine: less than 1e-8
    of the variance left) have no innovations to test, and a record without
    residual noise has nothing to react to: ``(None, reason)``.
    """
    innovations, share = _innovations(X, ar_order)
    if share < 1e-8:
        return None, "the inputs are predictable from their own past (periodic, e.g. a multisine)"
    start = max(na, nk + nb - 1, ar_order - 1)
    n = y.shape[0] - n_future
    past = np.hstack([output_lags(y[:n], na, start), input_lags(X[:n], nb, nk, start)])
    future = np.hstack([innovations[start - ar_order + k : n - ar_order + k] for k in range(1, n_future + 1)])
    target = y[start:n]
    _, _, r_past = least_squares(past, target)
    _, _, r_both = least_squares(np.hstack([past, future]), target)
    q = future.shape[1] * target.shape[1]
    dof = target.size - (past.shape[1] + future.shape[1] + 1) * target.shape[1]
    rss_past, rss_both = float(np.sum(r_past ** 2)), float(np.sum(r_both ** 2))
    if dof <= 0 or rss_both <= 1e-20 * float(np.sum((target - target.mean(axis=0)) ** 2)):
        return None, "no residual noise"
    p = float(f_dist.sf((rss_past - rss_both) / q / (rss_both / dof), q, dof))
    return p, 1.0 - rss_both / rss_past


def arx_poles(X, y, nk, orders=(1, 2, 3, 4, 6, 8), rtol=0.01):
    """Discrete poles of each output's own lags in the ARX(n, n, ``nk``) model, ``n`` the smallest of ``orders``
    whose held-out one-step error is within ``rtol`` of the best; an array per output."""
    n_samples = y.shape[0]
    fits = {}
    for n in orders:
        start = max(n, nk + n - 1)
        n_fit = start + int((1 - HELD_OUT) * (n_samples - start))
        if n_fit - start < 4 * (n * (y.shape[1] + X.shape[1]) + 1) or n_samples - n_fit < 10:
            break
        phi = np.hstack([output_lags(y, n, start), input_lags(X, n, nk, start)])
        target = y[start:]
        coef, intercept, _ = least_squares(phi[: n_fit - start], target[: n_fit - start])
        residual = target[n_fit - start:] - phi[n_fit - start:] @ coef - intercept
        scale = np.where(np.var(target, axis=0) > 0, np.var(target, axis=0), 1.0)
        fits[n] = (float(np.mean(np.mean(residual ** 2, axis=0) / scale)), coef)
    if not fits:
        return []
    best = min(loss for loss, _ in fits.values())
    n = min(k for k, (loss, _) in fits.items() if loss <= best * (1 + rtol) + 1e-15)
    coef = fits[n][1]
    m = y.shape[1]
    return [np.roots(np.concatenate([[1.0], -coef[j: n * m: m, j]])) for j in range(m)]


def pole_findings(poles, dt, duration):
    """``(unstable, integrating)`` output indices: a pole that grows within half the record, or one whose time
    constant is longer than half the record (its free run drifts as an integrator's does)."""
    unstable, integrating = [], []
    for j, p in enumerate(poles):
        p = p[np.abs(p) > 0]
        rate = np.log(np.abs(p)) / dt  # the real part of the continuous pole
        if np.any(rate > 2.0 / duration):
            unstable.append(j)
        elif np.any((np.abs(rate) <= 2.0 / duration) & (np.abs(np.angle(p)) < np.pi / 4)):
            integrating.append(j)
    return unstable, integrating
