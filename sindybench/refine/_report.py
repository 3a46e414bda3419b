"""Standard errors and confidence intervals of a fitted estimator's refined parameters, by name.

An estimator refined with :class:`~sindybench.refine.OutputErrorRefinement`
keeps in ``refinement_["covariance"]`` the covariance of its free parameters
(:class:`~sindybench.refine.ParameterCovariance`, one per kind). The functions
here name those parameters after the estimator's equation rows
(``_equation_rows()``, the same rows ``equations()`` prints), so that they
work with every estimator without knowing it:

* a physical parameter by its name (``"k1"``, ``"m"``);
* a coefficient as ``"<state>': <feature>"`` (``"x1': sqrt(x1)"``);
* an initial state as ``"<state>(0)"`` (with several records,
  ``"<state>(0) [record <i>]"``).
"""

import numpy as np

from ._covariance import ParameterCovariance

__all__ = ["UncertaintyMixin", "check_refinement_record", "coef_errors", "confidence_intervals", "model_covariance",
           "standard_errors"]


def model_covariance(model, kind="white"):
    """The :class:`ParameterCovariance` of a refined estimator (``refinement_``).

    Raises
    ------
    ValueError
        When the model was not refined, its refinement was skipped, or it
        was saved before covariances were recorded.
    """
    from sklearn.utils.validation import check_is_fitted

    check_is_fitted(model)
    record = getattr(model, "refinement_", None)
    if not record or "covariance" not in record:
        why = ("it was fitted without refine" if not record else
               f"its refinement was skipped ({record.get('message')})" if record.get("status") == -1 else
               "its record has no covariance (a model file written before covariances were recorded)")
        raise ValueError(f"no parameter covariance: {why}; expected a model fitted with "
                         "refine=OutputErrorRefinement().")
    if kind not in record["covariance"]:
        raise ValueError(f"kind must be one of {sorted(record['covariance'])}; got {kind!r}.")
    return ParameterCovariance.from_dict(record["covariance"][kind])


def _index(value, high, what):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value < high:
        raise ValueError(f"{what} must be an integer in [0, {high - 1}]; got {value!r}.")
    return int(value)


def parameter_names(parameters, rows):
    """Readable names of covariance parameters, given the estimator's equation rows.

    Raises
    ------
    ValueError
        For an entry that names no parameter of these rows (a tampered record).
    """
    out = []
    for j, q in enumerate(parameters):
        where = f"parameters[{j}] = {list(q)!r}"
        kind = q[0] if len(q) else None
        if kind == "physical" and len(q) == 2 and isinstance(q[1], str):
            out.append(q[1])
        elif kind == "coef" and len(q) == 3:
            row = rows[_index(q[2], len(rows), f"{where}: the row")]
            if row.coef is None:
                raise ValueError(f"{where}: row {row.name!r} is fixed by a function; it has no coefficients.")
            out.append(f"{row.name}': {row.features[_index(q[1], len(row.features), f'{where}: the term')]}")
        elif kind == "x0" and len(q) in (2, 3):
            name = rows[_index(q[1], len(rows), f"{where}: the state")].name
            out.append(f"{name}(0)" if len(q) == 2 else f"{name}(0) [record {_index(q[2], 2**31, where)}]")
        else:
            raise ValueError(f"{where}: expected ('physical', name), ('coef', term, row) or ('x0', state[, record]).")
    return out


def check_refinement_record(model, where="fitted.refinement"):
    """Check a loaded estimator's refinement record against the estimator (a model file's ``refinement``).

    Each covariance must name parameters this model has (by its equation
    rows), each once, with finite values, a symmetric finite matrix with a
    nonnegative diagonal (variances), ``1 <= dof`` and ``0 <= rank <= n``.
    (Its values are not compared with the model's: a refined model whose
    coefficients were edited after the fit saves and loads.)

    Raises
    ------
    ValueError
        Naming the field and what was wrong.
    """
    record = getattr(model, "refinement_", None)
    if not record or "covariance" not in record:
        return
    covariances = record["covariance"]
    if not isinstance(covariances, dict):
        raise ValueError(f"{where}.covariance: expected a dict kind -> covariance; got {type(covariances).__name__}.")
    rows = model._equation_rows()
    for kind, data in covariances.items():
        field = f"{where}.covariance.{kind}"
        try:
            cov = ParameterCovariance.from_dict(data)
            names = parameter_names(cov.parameters, rows)
        except (ValueError, TypeError, KeyError, IndexError) as exc:
            raise ValueError(f"{field}: {exc}") from exc
        n = len(names)
        problem = None
        if cov.kind != kind:
            problem = f"kind is {cov.kind!r} under the key {kind!r}"
        elif not (np.all(np.isfinite(cov.values)) and np.all(np.isfinite(cov.matrix)) and np.all(np.isfinite(cov.sigma))):
            problem = "values, matrix and sigma must be finite"
        elif np.any(np.diag(cov.matrix) < 0) or not np.allclose(cov.matrix, cov.matrix.T, rtol=1e-9, atol=0.0):
            problem = "the matrix must be symmetric with a nonnegative diagonal (variances)"
        elif cov.dof < 1 or not 0 <= cov.rank <= n or np.any(cov.sigma < 0):
            problem = f"dof = {cov.dof} (expected >= 1), rank = {cov.rank} (expected in [0, {n}]), sigma >= 0"
        elif len(set(names)) != n:
            problem = "a parameter is listed twice"
        elif any(q[0] == "physical" and q[1] not in (getattr(model, "params_", None) or {}) for q in cov.parameters):
            problem = f"a physical parameter is not one of the model's {sorted(getattr(model, 'params_', None) or {})}"
        if problem:
            raise ValueError(f"{field}: {problem}; expected the record of this model's refinement.")


def standard_errors(model, kind="white"):
    """Standard errors of a refined estimator's free parameters, by name (dict of float).

    Examples
    --------
    >>> from sindybench import SINDy, STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> from sindybench.refine import OutputErrorRefinement
    >>> t = np.arange(0, 5, 0.01)
    >>> y = np.exp(-2 * t)[:, None] + 0.001 * np.random.default_rng(0).normal(size=(500, 1))
    >>> model = SINDy(library=PolynomialLibrary(degree=1), optimizer=STLS(threshold=0.1), dt=0.01,
    ...               refine=OutputErrorRefinement()).fit(None, y)
    >>> errors = standard_errors(model)
    >>> sorted(errors), bool(errors["y0': y0"] < 0.01)
    (["y0': y0", 'y0(0)'], True)
    >>> low, high = confidence_intervals(model)["y0': y0"]
    >>> bool(low < -2.0 < high)
    True
    """
    cov = model_covariance(model, kind)
    return dict(zip(parameter_names(cov.parameters, model._equation_rows()), cov.standard_errors().tolist()))


def confidence_intervals(model, alpha=0.05, kind="white"):
    """``{name: (lower, upper)}``: the ``1 - alpha`` intervals of a refined estimator's free parameters."""
    cov = model_covariance(model, kind)
    lower, upper = cov.confidence_intervals(alpha)
    names = parameter_names(cov.parameters, model._equation_rows())
    return {name: (float(a), float(b)) for name, a, b in zip(names, lower, upper)}


def coef_errors(model, kind="white"):
    """Standard error of each coefficient of each equation row (NaN where the coefficient is not free)."""
    rows = model._equation_rows()
    out = [np.full(len(row.features), np.nan) for row in rows]
    cov = model_covariance(model, kind)
    for q, se in zip(cov.parameters, cov.standard_errors()):
        if q[0] == "coef":
            out[int(q[2])][int(q[1])] = se
    return out


class UncertaintyMixin:
    """``standard_errors()`` and ``confidence_intervals()`` for estimators with ``refinement_`` and equation rows."""

    def standard_errors(self, kind="white"):
        """Standard errors of the refined parameters (needs ``refine``).

        From the Jacobian of the simulation at the refined optimum and the
        residual variance (see :doc:`/uncertainty`).

        Parameters
        ----------
        kind : {"white", "hac"}, default="white"
            ``"white"`` assumes independent residuals; ``"hac"`` (Newey-West)
            allows residuals correlated in time.

        Returns
        -------
        dict
            ``{name: standard error}``: physical parameters by name,
            coefficients as ``"<state>': <feature>"``, initial states as
            ``"<state>(0)"``.
        """
        return standard_errors(self, kind)

    def confidence_intervals(self, alpha=0.05, kind="white"):
        """Two-sided ``1 - alpha`` confidence intervals of the refined parameters (needs ``refine``).

        Parameters
        ----------
        alpha : float, default=0.05
        kind : {"white", "hac"}, default="white"
            As in :meth:`standard_errors`.

        Returns
        -------
        dict
            ``{name: (lower, upper)}``, named as in :meth:`standard_errors`.
        """
        return confidence_intervals(self, alpha, kind)

    def _coef_errors(self):
        return coef_errors(self)
