"""Standard errors and confidence intervals of a fitted estimator's refined parameters, by name.

An estimator refined with :class:`~sindybench.refine.OutputErrorRefinement`
keeps in ``refinement_["covariance"]`` the covariance of its free parameters
(:class:`~sindybench.uncertainty.ParameterCovariance`, one per kind) and in
``refinement_["residual_test"]`` the test of its residuals, on which the
intervals warn (:func:`warn_model_error`). The functions
here name those parameters after the estimator's equation rows
(``_equation_rows()``, the same rows ``equations()`` prints), so that they
work with every estimator without knowing it:

* a physical parameter by its name (``"k1"``, ``"m"``);
* a coefficient as ``"<state>': <feature>"`` (``"x1': sqrt(x1)"``);
* an initial state as ``"<state>(0)"`` (with several records,
  ``"<state>(0) [record <i>]"``).
"""

import warnings

import numpy as np

from .._covariance import ParameterCovariance, parameter_names
from .._residual_tests import ModelErrorWarning, ResidualTest

__all__ = ["coef_errors", "confidence_intervals", "model_covariance", "standard_errors", "warn_model_error"]

_ASSUMES = {
    "white": "white residuals (independent measurement noise) and the right model structure",
    "hac": "the right model structure (residuals independent of the input; noise correlated in time is allowed)",
}


def warn_model_error(record, kind, stacklevel=3):
    """Warn (:class:`ModelErrorWarning`) when the refinement's residual test contradicts what ``kind`` assumes.

    ``"white"`` intervals need white residuals independent of the input,
    ``"hac"`` intervals residuals independent of the input. Returns the
    warning's text, or None (no test recorded, or it passed).
    """
    data = (record or {}).get("residual_test")
    if data is None:
        return None
    test = ResidualTest.from_dict(data)
    if test.independent and (test.white or kind == "hac"):
        return None
    text = (f"the refinement's residuals are {test.message()}: these {kind!r} intervals assume {_ASSUMES[kind]}, "
            "so they are too narrow. " + ("kind='hac' allows residuals correlated in time. " if kind == "white" else "")
            + "Under model error no parameter interval holds: check the structure (residual_analysis), and for "
            "predictions use a calibrated band (conformal_calibration).")
    warnings.warn(text, ModelErrorWarning, stacklevel=stacklevel)
    return text

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
    warn_model_error(record, kind, stacklevel=5)  # the caller of the estimator's method
    return ParameterCovariance.from_dict(record["covariance"][kind])


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
