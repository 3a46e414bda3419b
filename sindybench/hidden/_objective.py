"""The inner search's objective: the validation error of the candidate fitted with a trial's values."""

import logging

import numpy as np

from ..metrics import nrmse
from ..simulate import SimulationError
from ._candidate import candidate_initial_state

__all__ = ["SEARCH_PENALTY", "SearchObjective", "validation_error"]

logger = logging.getLogger(__name__)

SEARCH_PENALTY = 1e3
"""Validation score of a diverged or failed candidate (scores are normalized RMSEs)."""

VALIDATIONS = ("block", "continued", "full")


def validation_error(hidden, cand, X, y, n_fit, validation):
    """Normalized RMSE (:func:`~sindybench.metrics.nrmse`) of the candidate's simulation.

    ``validation``: ``"block"`` simulates ``X[n_fit:]`` from the strategy's
    initial state; ``"continued"`` and ``"full"`` simulate the whole record
    from the first training state and score the block or everything.
    :data:`SEARCH_PENALTY` when the simulation diverges.
    """
    if validation == "block":
        X, y = X[n_fit:], y[n_fit:]
        x0 = candidate_initial_state(hidden, cand, X, y)
    else:
        x0 = np.asarray(cand.design.states[0], dtype=float)
    y_sim = cand.dynamics.simulate(X, x0, on_divergence="nan")[:, list(cand.structure.output_index)]
    if not np.all(np.isfinite(y_sim)):
        return SEARCH_PENALTY
    if validation == "continued":
        y_sim, y = y_sim[n_fit:], y[n_fit:]
    return nrmse(y, y_sim)


class SearchObjective:
    """``values -> validation error`` of the candidate ``fit(values)``; :data:`SEARCH_PENALTY` if it fails."""

    def __init__(self, fit, hidden, X, y, n_fit, validation):
        self.fit, self.hidden, self.X, self.y, self.n_fit, self.validation = fit, hidden, X, y, n_fit, validation

    def __call__(self, values):
        try:
            cand = self.fit(values)
            return validation_error(self.hidden, cand, self.X, self.y, self.n_fit, self.validation)
        except (SimulationError, ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
            logger.debug("bad trial %s: %s", values, exc)
            return SEARCH_PENALTY
