"""The inner search's objective: the validation error of the candidate fitted with a trial's values."""

import logging

import numpy as np

from ..metrics import nrmse
from ..search import SEARCH_PENALTY
from ..simulate import SimulationError
from ._candidate import candidate_initial_state

__all__ = ["SearchObjective", "validation_error"]

logger = logging.getLogger(__name__)

VALIDATIONS = ("block", "continued", "full")


def validation_error(hidden, cand, X, y, n_fit, validation):
    """Normalized RMSE (:func:`~sindybench.metrics.nrmse`) of the candidate's simulation.

    ``validation``: ``"block"`` simulates ``X[n_fit:]`` from the strategy's
    initial state; ``"continued"`` and ``"full"`` simulate the whole record
    from the first training state and score the block or everything.
    :data:`SEARCH_PENALTY` when the simulation diverges.

    ``X``, ``y`` and ``n_fit`` are lists, one entry per record (lists of one
    for one record); each record is simulated from its own start (its validation
    block's, or its first training state ``cand.designs[i].states[0]``) and
    the scored samples of all records are pooled into one normalized RMSE.
    """
    y_true, y_pred = [], []
    for X_r, y_r, n_r, design in zip(X, y, n_fit, cand.designs):
        if validation == "block":
            X_r, y_r = X_r[n_r:], y_r[n_r:]
            x0 = candidate_initial_state(hidden, cand, X_r, y_r)
        else:
            x0 = np.asarray(design.states[0], dtype=float)
        y_sim = cand.dynamics.simulate(X_r, x0, on_divergence="nan")[:, list(cand.structure.output_index)]
        if not np.all(np.isfinite(y_sim)):
            return SEARCH_PENALTY
        if validation == "continued":
            y_sim, y_r = y_sim[n_r:], y_r[n_r:]
        y_true.append(y_r)
        y_pred.append(y_sim)
    return nrmse(np.vstack(y_true), np.vstack(y_pred))


class SearchObjective:
    """``values -> validation error`` of the candidate ``fit(values)``; :data:`SEARCH_PENALTY` if it fails.

    ``X``, ``y`` and ``n_fit`` are lists, one entry per record (see :func:`validation_error`).
    """

    def __init__(self, fit, hidden, X, y, n_fit, validation):
        self.fit, self.hidden, self.X, self.y, self.n_fit, self.validation = fit, hidden, X, y, n_fit, validation
        self.first_error = None  # "Type: message" of the first failed trial, for the message when all fail

    def __call__(self, values):
        try:
            cand = self.fit(values)
            return validation_error(self.hidden, cand, self.X, self.y, self.n_fit, self.validation)
        except (SimulationError, ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
            logger.debug("bad trial %s: %s", values, exc)
            if self.first_error is None:
                self.first_error = f"{type(exc).__name__}: {exc}"
            return SEARCH_PENALTY
