"""The record of a refinement: refined model, costs, and the Jacobian at the optimum."""

from typing import NamedTuple

import numpy as np

from ._covariance import parameter_covariance

__all__ = ["RefinementResult"]


class RefinementResult(NamedTuple):
    """Outcome of :func:`refine_simulation_error`.

    Attributes
    ----------
    coef : ndarray of shape (n_terms, n_states)
        The refined coefficient matrix (physical part included).
    physical : dict
        Refined physical parameters by name.
    x0 : ndarray of shape (n_states,)
        Refined initial state (with several records, the first record's).
    initial_cost, cost : float
        Half the mean squared scaled output error of an open-loop simulation
        of the whole record (of every record) before and after, scaled by
        the output's standard deviation or by ``output_scale``; with multiple
        shooting too, ``cost`` is that of the returned model run from its
        initial state.
    nfev, njev : int
        Model simulations and Jacobian evaluations.
    status : int
        :func:`scipy.optimize.least_squares` status (> 0: converged).
    message : str
    jacobian : {"sensitivity", "2-point"}
    pruned : list of (int, int)
        ``(term, state)`` entries set to zero by pruning.
    jac : ndarray of shape (n_samples * n_outputs, n_parameters) or None
        Jacobian of the output residuals ``r = (y_sim - y) / std(y) /
        sqrt(n_samples * n_outputs)`` (rows sample by sample) at the returned
        parameters. With single shooting it is the Jacobian
        :func:`scipy.optimize.least_squares` returns at the optimum; with
        multiple shooting it is that of the returned model simulated open
        loop from its initial state (the output residuals only: the
        continuity residuals and the later segments' starts are not
        parameters of the returned model).
    residuals : ndarray of shape (n_samples * n_outputs,) or None
        Those output residuals.
    parameters : tuple
        The columns of ``jac``: ``("physical", name)``, ``("coef", term,
        state)``, ``("x0", state)`` (several records: ``("x0", state,
        record)``).
    values : ndarray of shape (n_parameters,) or None
        Their refined values.
    at_bound : ndarray of bool of shape (n_parameters,) or None
        Parameters that ended on a bound.
    budget_exhausted : bool
        The last round stopped on its evaluation budget (``max_nfev``)
        before meeting ``ftol`` or ``xtol`` (a
        :class:`~sklearn.exceptions.ConvergenceWarning` was issued).
    n_outputs : int
        Outputs (rows of ``jac`` per sample).
    initial_states : ndarray of shape (n_records, n_states) or None
        With several records: the refined initial state of each record
        (``x0`` is the first row); None for one record.
    gain : ndarray of shape (n_states, n_outputs) or None
        Prediction error (:func:`~sindybench.refine.refine_prediction_error`):
        the predictor's observer gain at the optimum; None for output error.
    horizon : int or None
        Prediction error: the steps ahead of the fitted predictions; None for
        output error. With prediction error, ``initial_cost``, ``cost``,
        ``jac`` and ``residuals`` are those of the predictions, and the
        free gain entries are columns ``("gain", state, output)`` of ``jac``.
    record_samples : tuple of int or None
        With several records: the samples of each record, in the order of
        the rows of ``jac`` (the ``"hac"`` covariance sums lagged products
        within a record only); None for one record.
    residual_test : ResidualTest or None
        The whiteness and input-independence tests of ``residuals``, set by
        the estimator that ran the refinement (which has the inputs);
        ``standard_errors`` warns when they fail.
    """

    coef: np.ndarray
    physical: dict
    x0: np.ndarray
    initial_cost: float
    cost: float
    nfev: int
    njev: int
    status: int
    message: str
    jacobian: str
    pruned: list
    jac: np.ndarray = None
    residuals: np.ndarray = None
    parameters: tuple = ()
    values: np.ndarray = None
    at_bound: np.ndarray = None
    budget_exhausted: bool = False
    n_outputs: int = 1
    initial_states: np.ndarray = None
    record_samples: tuple = None
    gain: np.ndarray = None
    horizon: int = None
    residual_test: object = None

    def summary(self):
        """JSON-able record (no arrays; the covariances, ``"white"`` and ``"hac"``, as nested lists)."""
        out = {"initial_cost": float(self.initial_cost), "cost": float(self.cost), "nfev": int(self.nfev),
               "njev": int(self.njev), "status": int(self.status), "message": str(self.message),
               "jacobian": self.jacobian, "physical": {k: float(v) for k, v in self.physical.items()},
               "pruned": [[int(j), int(i)] for j, i in self.pruned]}
        if self.jac is not None:
            out["budget_exhausted"] = bool(self.budget_exhausted)
            out["covariance"] = {kind: self.covariance(kind).to_dict() for kind in ("white", "hac")}
        if self.gain is not None:
            out["criterion"] = {"name": "prediction error", "horizon": int(self.horizon),
                                "gain": np.asarray(self.gain, dtype=float).tolist()}
        if self.residual_test is not None:
            out["residual_test"] = self.residual_test.to_dict()
        if self.initial_states is not None:
            out["initial_states"] = np.asarray(self.initial_states, dtype=float).tolist()
        return out

    def covariance(self, kind="white", *, lags=None):
        """Covariance of the refined parameters at the optimum.

        Parameters
        ----------
        kind : {"white", "hac"}, default="white"
            ``"white"``: independent residuals; ``"hac"``: Newey-West
            estimate for residuals correlated in time (see
            :func:`~sindybench.uncertainty.parameter_covariance`).
        lags : int, optional
            Lags of the ``"hac"`` estimate.

        Returns
        -------
        ParameterCovariance
        """
        if self.jac is None:
            raise ValueError("this refinement record keeps no Jacobian; expected a record of "
                             "refine_simulation_error.")
        return parameter_covariance(self.jac, self.residuals, self.parameters, self.values,
                                    n_outputs=self.n_outputs, kind=kind, lags=lags, at_bound=self.at_bound,
                                    blocks=self.record_samples)

    def standard_errors(self, kind="white"):
        """Standard errors of :attr:`parameters` (see :meth:`covariance`)."""
        return self.covariance(kind).standard_errors()

    def confidence_intervals(self, alpha=0.05, kind="white"):
        """``(lower, upper)`` of the ``1 - alpha`` intervals of :attr:`parameters`."""
        return self.covariance(kind).confidence_intervals(alpha)
