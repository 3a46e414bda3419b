"""The linear base of ``identify``: a linear state-space model whose order the data decide.

A family of its own (``"linear_ss"``), and the model the parsimony rule holds
every nonlinear candidate against. Its structure comes from the data before
any fit (:func:`linear_order`): discrete-time MOESP models
(:func:`~sindybench.hidden._subspace.moesp_orders`) of orders 1 to 10 at a few
Hankel depths, fitted on the first 80 % of the estimation record and scored by
their free run over the rest; the smallest order within 2 % of the best RMSE
wins, with its depth. The estimator is the library's own continuous-time form:
a :class:`~sindybench.HiddenStateSINDy` whose
:class:`~sindybench.hidden.LatentHiddenState` holds the ``n - n_outputs``
states beyond the outputs, started from the subspace model of that order and
depth (converted to continuous time by the matrix logarithm), linear library,
refined by simulation error, started on new data by least squares of its first
samples with a prior where its states lie (``initial_state="prior"``: ten
samples cannot tell six states apart); so ``predict``, ``equations``, the refinements,
the filter, ``to_json`` and the bands work on it. Order 1 (one output) is a
first-order :class:`~sindybench.SINDy` with a linear library, refined.
"""

import numpy as np

from .._sindy import SINDy
from ..hidden import HiddenStateSINDy, LatentHiddenState
from ..hidden._subspace import moesp_orders
from ..libraries import PolynomialLibrary
from ..optimizers import STLS
from ..refine import OutputErrorRefinement

__all__ = ["LINEAR_FAMILY", "linear_base_index", "linear_base_rule", "linear_order", "make_linear", "propose_linear"]

LINEAR_FAMILY = "linear_ss"
#: the orders and Hankel depths (block rows) the linear base tries
MAX_ORDER, BLOCK_ROWS = 10, (10, 20, 40, 80)
_TOLERANCE = 0.02  # the smallest order within this relative RMSE of the best
_VALIDATION = 0.2
_REFINEMENT = {"max_nfev": 30, "max_samples": 5000}
#: how the linear base (and the families on its states) start new data: least squares of the first samples with a
#: prior where the model's states lie (``HiddenStateSINDy(initial_state="prior")``): well posed with many states
START = "prior"


def linear_order(X, y, *, max_order=MAX_ORDER, block_rows=BLOCK_ROWS, validation=_VALIDATION):
    """The linear base's order and Hankel depth, chosen by the free run of MOESP models on the record's end.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_inputs)
    y : ndarray of shape (n_samples, n_outputs)

    Returns
    -------
    dict or None
        ``order``, ``block_rows``, ``rmse`` (the chosen model's validation
        RMSE over the outputs' standard deviation), ``alternatives`` (the
        smallest ``(order, block_rows)`` within twice the best RMSE, if
        another) and ``scores`` (``{(order,
        block_rows): rmse}``, as text) and ``n_outputs``; None when no model could be fitted (no input,
        or too few samples).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((600, 1))
    >>> y = np.zeros((600, 1))
    >>> x = np.zeros(2)
    >>> for k in range(599):
    ...     x = np.array([[1.6, -0.8], [1.0, 0.0]]) @ x + np.array([1.0, 0.0]) * u[k, 0]
    ...     y[k + 1, 0] = x[0]
    >>> linear_order(u, y + 0.01 * rng.standard_normal(y.shape), max_order=4, block_rows=(10,))["order"]
    2
    """
    X, y = np.asarray(X, dtype=float), np.asarray(y, dtype=float)
    if X.shape[1] == 0:
        return None
    n = len(y)
    n_fit = n - max(int(validation * n), 2)
    scale = np.where(np.std(y[n_fit:], axis=0) > 0, np.std(y[n_fit:], axis=0), 1.0)
    scores = {}
    for rows in block_rows:
        try:
            fits, _ = moesp_orders(X, y, range(1, max_order + 1), block_rows=rows, n_fit=n_fit)
        except (ValueError, np.linalg.LinAlgError):
            continue
        for order, (A, _, _, _, _, y_hat) in fits.items():
            poles = np.linalg.eigvals(A) if np.all(np.isfinite(A)) else np.array([np.nan])
            if not np.all(np.abs(poles) <= 1.0 + 1e-9) or np.any((np.abs(poles.imag) < 1e-12) & (poles.real <= 0)):
                continue  # unstable, or a pole on the negative axis: no continuous-time model samples to it
            rmse = float(np.sqrt(np.mean(((y_hat[n_fit:] - y[n_fit:]) / scale) ** 2)))
            if np.isfinite(rmse):
                scores[(order, rows)] = rmse
    if not scores:
        return None
    best = min(scores.values())
    order, rows = min((k for k, v in scores.items() if v <= best * (1 + _TOLERANCE)), key=lambda k: (k[0], scores[k]))
    # and the smallest order within twice the best RMSE (its own best depth): validation of the continuous-time
    # models decides between the two (a discrete model may have no well-conditioned continuous-time form)
    small = min((k for k, v in scores.items() if v <= 2.0 * best), key=lambda k: (k[0], scores[k]))
    alternatives = [] if small[0] == order else [(int(small[0]), int(small[1]))]
    return {"order": int(order), "block_rows": int(rows), "rmse": scores[(order, rows)], "n_outputs": y.shape[1],
            "alternatives": alternatives,
            "scores": {f"n={k[0]} rows={k[1]}": v for k, v in scores.items()}}


def propose_linear(settings, n_outputs, n_inputs, hold, delay):
    """The linear base's structures: the order the data chose, and a smaller one within twice its error (none
    without an input or an order)."""
    base = settings.get("linear")
    if base is None or n_inputs == 0:
        return []
    out = []
    for order, rows in [(base["order"], base["block_rows"])] + [tuple(a) for a in base.get("alternatives", [])]:
        order = max(order, n_outputs)
        out.append(({"family": LINEAR_FAMILY, "library": f"linear n={order} rows={rows}",
                     "derivative": "finite_difference", "input_hold": hold, "input_delay": delay},
                    PolynomialLibrary(degree=1)))
    return out


def _parse(library_name):
    fields = dict(part.split("=") for part in library_name.split()[1:])
    return int(fields["n"]), int(fields["rows"])


def make_linear(structure, library, dt, differentiation, settings, *, random_state=0):
    """The unfitted linear base of ``structure`` (its order and depth in its library's name)."""
    from sklearn.base import clone

    order, rows = _parse(structure["library"])
    optimizer = STLS(threshold=0.0, alpha=1e-9, normalize_columns=True)
    refine = OutputErrorRefinement(**_REFINEMENT)
    hold, delay = structure["input_hold"], structure["input_delay"]
    n_outputs = int(settings["linear"]["n_outputs"])
    if order <= n_outputs:
        return SINDy(library=clone(library), optimizer=optimizer, differentiation=differentiation, dt=dt,
                     input_hold=hold, input_delay=delay, refine=refine)
    hidden = LatentHiddenState(n_latent=order - n_outputs, order=1, driver="input", start="subspace",
                               block_rows=rows)
    return HiddenStateSINDy(hidden=hidden, library=clone(library), optimizer=optimizer,
                            differentiation=differentiation, dt=dt, input_hold=hold, input_delay=delay,
                            random_state=random_state, refine=refine, initial_state=START, show_progress_bar=False)


def linear_base_index(rows, mean):
    """Index of the best-validating linear base among the candidates ``rows`` (errors ``mean``), or None."""
    base = [i for i, r in enumerate(rows) if r["family"] == LINEAR_FAMILY and np.isfinite(mean[i])]
    return min(base, key=lambda i: mean[i]) if base else None


def linear_base_rule(best, rows, mean, std, n_blocks):
    """``(index, reason)``: the parsimony rule's pick ``best``, or the linear base when ``best`` is nonlinear and
    validates no better than the linear base by more than its standard error (its spread over the blocks over
    ``sqrt(n_blocks)``).

    Examples
    --------
    >>> rows = [{"family": "order2", "library": "poly3"}, {"family": LINEAR_FAMILY, "library": "linear n=4 rows=40"}]
    >>> linear_base_rule(0, rows, [0.10, 0.11], [0.05, 0.01], 3)[0]
    1
    >>> linear_base_rule(0, rows, [0.05, 0.11], [0.05, 0.01], 3)[0]
    0
    """
    base = linear_base_index(rows, mean)
    if base is None or base == best or rows[best]["library"] == "linear":
        return best, "parsimony"
    se = float(std[best]) / np.sqrt(max(n_blocks, 1))
    if mean[best] < mean[base] - se:
        return best, f"nonlinear, better than the linear base by more than its standard error ({se:.3g})"
    return base, (f"the linear base: the nonlinear pick ({rows[best]['family']}, {rows[best]['library']}) validates "
                  f"no better by more than its standard error ({se:.3g})")
