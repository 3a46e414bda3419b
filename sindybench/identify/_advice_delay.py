"""The data advice's input delay: ARX fits over candidate delays, scored on a held-out block
(see :mod:`sindybench.identify._advice`)."""

import logging

import numpy as np

from .._validation import check_integer, check_positive
from ..baselines._arx import least_squares
from ..baselines._lags import input_lags, output_lags
from ._advice_signals import check_record, detect_input_hold

__all__ = ["HELD_OUT", "estimate_delay", "estimate_delay_details"]

logger = logging.getLogger(__name__)

HELD_OUT = 0.25  # the block at the end that confirms a delay (and scores the ARX orders of the poles)
LAG_SHARE = 0.1  # a step response reaching this share of its value at the window's end before the delay: a lag


def _delay_losses(X, y, max_nk, na, nb):
    """Held-out one-step error of ARX(na, nb, nk) for nk = 0 .. max_nk, each relative to the output's variance."""
    n = y.shape[0]
    start = max(na, max_nk + nb - 1)
    n_fit = start + int((1 - HELD_OUT) * (n - start))
    if n_fit - start < 4 * (na * y.shape[1] + nb * X.shape[1] + 1) or n - n_fit < 10:
        raise ValueError(f"{n} samples are too few to estimate a delay of up to {max_nk - 1} samples with ARX("
                         f"na={na}, nb={nb}); expected at least {start + 8 * (na + nb + 1) + 20}.")
    target = y[start:]
    scale = np.var(target[n_fit - start:], axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    y_part = output_lags(y, na, start)
    losses = {}
    for nk in range(max_nk + 1):
        phi = np.hstack([y_part, input_lags(X, nb, nk, start)])
        coef, intercept, _ = least_squares(phi[: n_fit - start], target[: n_fit - start])
        residual = target[n_fit - start:] - phi[n_fit - start:] @ coef - intercept
        losses[nk] = float(np.mean(np.mean(residual ** 2, axis=0) / scale))
    return losses


def _response_before(X, y, nk, base, na, nb):
    """How far the step response has gone before the input lag ``nk``: a delay's has not moved, a lag's has.

    An ARX(``na``) model with every input lag from ``base`` (the lag of a response without
    delay: 1 with a zero-order hold, 0 with a linear one) to ``nk + nb - 1`` is fitted on the
    first 75 % of the record; its step response from each input (in units of the input's and
    the output's standard deviations) is taken at sample ``nk - 1``, the last one before the
    delay, and at ``nk + nb - 1``, the window's end. Returns the largest magnitude at the first
    over the largest at the second; None if the record is too short for the wider model or
    the response is 0. On a delayed record the response before the delay is noise (below 1 %
    in the tests: first- and second-order plants, the zoo's ``dead_time``); a lag, whose
    response starts at once, however slowly (the zoo's ``hidden_tank_overflow``, where a
    smooth response makes the held-out losses prefer a late window), has gone 30-50 % of the way.
    """
    n, m, p = y.shape[0], y.shape[1], X.shape[1]
    width = nk - base + nb
    start = max(na, base + width - 1)
    n_fit = start + int((1 - HELD_OUT) * (n - start))
    if n_fit - start < 4 * (na * m + width * p + 1):
        return None
    phi = np.hstack([output_lags(y, na, start), input_lags(X, width, base, start)])
    coef, _, _ = least_squares(phi[: n_fit - start], y[start:n_fit])
    feedback = coef[: na * m].reshape(na, m, m)  # [i, r, j]: y_r[t-1-i] into y_j[t]
    steps = np.cumsum(coef[na * m:].reshape(width, p, m), axis=0) * np.std(X, axis=0)[None, :, None]
    response = np.zeros((nk + nb, p, m))  # [k, q, j]: y_j at sample k after a unit step of u_q at 0
    for k in range(base, nk + nb):
        response[k] = steps[k - base] + sum(response[k - 1 - i] @ feedback[i] for i in range(min(na, k)))
    scale = np.std(y, axis=0)
    response /= np.where(scale > 0, scale, 1.0)
    end = np.max(np.abs(response[nk + nb - 1]))
    return float(np.max(np.abs(response[nk - 1])) / end) if end > 0 else None


def _chosen_lag(losses, rtol, nb):
    """``(nk, resolved)``: the largest lag whose loss is within ``rtol`` of the best.

    Shorter lags reach the response with their longer windows, so the lags
    within ``rtol`` span at most ``nb`` when the record resolves the delay.
    Otherwise (a smooth input: any window extrapolates to the others) the
    delay is not resolved: ``(None, False)``.
    """
    best = min(losses.values())
    close = [nk for nk, loss in losses.items() if loss <= best * (1 + rtol) + 1e-15]
    if max(close) - min(close) <= nb - 1:
        return max(close), True
    return None, False


def estimate_delay(X, y, dt, *, max_delay=20, hold=None, na=2, nb=3, rtol=0.01):
    """Input delay in samples: the ``input_delay`` of :class:`~sindybench.SINDy` and :class:`~sindybench.HiddenStateSINDy`.

    An ARX model ``y[t] = a_1 y[t-1] + ... + b_0 u[t-nk] + ... + b_{nb-1} u[t-nk-nb+1] + c``
    is fitted by least squares on the first 75 % of the record for each input
    lag ``nk`` from 0 to ``max_delay + 1`` and scored by its one-step error on
    the last 25 % (the held-out block). The lag is the largest ``nk`` whose
    held-out error is within ``rtol`` of the best (shorter lags reach the
    response with their longer windows; longer ones miss its start). A slow
    lag can score best at a late window too (a smooth response): the lag is
    kept only when the step response of an ARX model with every earlier input
    lag too has not moved before it (a delay's stays at 0, a lag's has gone
    more than 10 % of its way: then no delay). A continuous-time model driven through a zero-order hold responds at lag 1
    without delay, so its delay is ``nk - 1``; with a linear hold the input
    acts within the sample, so it is ``nk``. An input that is smooth at the
    sampling rate may not resolve the delay (lags further apart than ``nb``
    all score within ``rtol``): then the delay is 0 (no delay) and a warning
    is logged; confirm the delay on validation data (the simulation error of
    models with neighbouring delays).

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
    dt : float
        Sampling interval (for the message).
    max_delay : int, default=20
    hold : {"zoh", "linear"} or None, default=None
        The input hold; None detects it (:func:`detect_input_hold`).
    na, nb : int, default=2, 3
        ARX orders of the candidates (``na >= 0`` output lags, ``nb >= 1`` input lags).
    rtol : float, default=0.01
        Relative tolerance (``>= 0``) of the lags that score as well as the best.

    Returns
    -------
    int

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((2000, 1))
    >>> y = np.zeros((2000, 1))
    >>> for t in range(5, 2000):
    ...     y[t] = 0.9 * y[t - 1] + 0.5 * u[t - 4]
    >>> estimate_delay(u, y, 0.01, hold="zoh")
    3
    """
    X, y = check_record(X, y, dt)
    return estimate_delay_details(X, y, dt, max_delay, hold, na, nb, rtol, say=True)[0]


def estimate_delay_details(X, y, dt, max_delay, hold, na, nb, rtol, say=False):
    """``(delay, losses, resolved)``; ``say``: warn here when the record does not resolve it (:func:`advice` says it
    in its own warnings)."""
    max_delay = check_integer(max_delay, "max_delay", low=0)
    na, nb = check_integer(na, "na", low=0), check_integer(nb, "nb", low=1)
    rtol = check_positive(rtol, "rtol", strict=False)
    if X.shape[1] == 0:
        return 0, {}, True
    hold = hold if hold is not None else detect_input_hold(X)[0]
    losses = _delay_losses(X, y, max_delay + 1, na, nb)
    nk, resolved = _chosen_lag(losses, rtol, nb)
    base = 1 if hold == "zoh" else 0
    if nk is not None and nk > base:
        share = _response_before(X, y, nk, base, na, nb)
        if share is not None and share > LAG_SHARE:
            logger.info("estimate_delay: input lag nk = %d scores best, but the step response has gone %.0f %% of its "
                        "way before it (a lag, not a delay): no delay", nk, 100 * share)
            nk = base
    delay = 0 if nk is None else max(nk - 1, 0) if hold == "zoh" else min(nk, max_delay)
    if not resolved and say:
        logger.warning("estimate_delay: the record does not resolve the input delay (ARX input lags %s score within "
                       "%g %% of the best, as for a smooth input); taking %d samples (no delay): confirm it on validation data",
                       sorted(k for k, v in losses.items() if v <= min(losses.values()) * (1 + rtol)), 100 * rtol,
                       delay)
    logger.info("estimate_delay: input lag nk = %s (%s hold) -> input_delay = %d samples (%.4g s)", nk, hold, delay,
                delay * dt)
    return delay, losses, resolved
