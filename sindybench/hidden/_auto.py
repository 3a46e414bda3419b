"""The settings :class:`~sindybench.HiddenStateSINDy` decides on its own validation block (``"auto"`` values).

``library="auto"``, ``input_hold="auto"`` and ``refine="auto"`` are the
estimator's defaults since version 0.2, ``differentiation="auto"`` (the
record's bandwidth chooses a Savitzky-Golay window once per fit, see
:func:`~sindybench.differentiation.data_differentiation`) since 0.3 (see the
user guide's "Defaults"):

* :func:`auto_grid`: the candidate settings of a fit that searches nothing
  else, every input hold (zero-order and linear) with every degree of the
  strategy's default polynomial library from 1 up to its own; each candidate
  is fitted without the validation block and scored by the open-loop
  simulation of that block, as a trial of the inner search is
  (:class:`~sindybench.hidden._objective.SearchObjective`). When the inner
  search runs (a strategy's open physical guess, ``search_params``), the hold
  is one more dimension of that search instead and the library is the
  strategy's default;
* :func:`candidate_settings`: the library and the hold of one candidate;
* :func:`auto_refinement`: ``refine="auto"`` refines by simulation error when
  the model is compiled (exact sensitivities) and skips it otherwise (a Python
  right-hand side refines by finite differences, hundreds of times slower); a
  model the strategy cannot refine (a latent state without its gauge term) is
  kept as fitted, the reason in ``refinement_["message"]``.
"""

import logging

import numpy as np
from sklearn.base import clone

from .._base import check_refinement
from ..libraries import PolynomialLibrary, as_library
from ..refine import OutputErrorRefinement
from ..search import SEARCH_PENALTY
from ._objective import SearchObjective

logger = logging.getLogger(__name__)

__all__ = ["AUTO", "HOLDS", "auto_grid", "auto_refinement", "candidate_settings", "check_refine_param", "decide",
           "is_auto"]

AUTO = "auto"
HOLDS = ("zoh", "linear")
#: the key of a candidate's library degree in ``best_params_`` and ``search_results_``
DEGREE = "library__degree"


def is_auto(value):
    """Whether a parameter's value is ``"auto"`` (decided inside ``fit``)."""
    return isinstance(value, str) and value == AUTO


def check_refine_param(value, name):
    """``refine``: ``"auto"`` or what :func:`sindybench._base.check_refinement` accepts."""
    return value if is_auto(value) else check_refinement(value, name)


def _auto_degrees(estimator, hidden):
    """The degrees compared for ``library="auto"``: 1 .. the default library's, or ``(None,)`` for no choice."""
    if not is_auto(estimator.library):
        return (None,)
    default = hidden.default_library()
    degree = getattr(default, "degree", None)
    if type(default) is not PolynomialLibrary or isinstance(degree, bool) or not isinstance(degree, int):
        return (None,)
    return tuple(range(1, degree + 1)) if degree > 1 else (None,)


def auto_grid(estimator, hidden, n_inputs, *, searched):
    """The candidate settings of the ``"auto"`` parameters, each a dict of ``best_params_`` entries.

    Parameters
    ----------
    estimator : HiddenStateSINDy
    hidden : HiddenStrategy
        The fitted clone of the strategy (its ``default_library()``).
    n_inputs : int
        With no input the hold makes no difference and ``"zoh"`` is taken.
    searched : bool
        Whether the inner search runs (then only the hold is left to it and
        the grid is the one default entry).

    Returns
    -------
    list of dict
        Empty when no parameter is ``"auto"``; otherwise the candidates, the
        last one the fallback (linear hold, the default library's own degree)
        used when the record is too short for a validation block or every
        candidate fails.

    Examples
    --------
    >>> from sindybench.hidden import DerivativeHiddenState, HiddenStateSINDy
    >>> auto_grid(HiddenStateSINDy(), DerivativeHiddenState(), 1, searched=False)
    [{'input_hold': 'zoh', 'library__degree': 1}, {'input_hold': 'linear', 'library__degree': 1}, \
{'input_hold': 'zoh', 'library__degree': 2}, {'input_hold': 'linear', 'library__degree': 2}]
    >>> auto_grid(HiddenStateSINDy(input_hold="zoh", library=None), DerivativeHiddenState(), 1, searched=False)
    []
    """
    auto_hold = is_auto(estimator.input_hold)
    holds = (HOLDS if n_inputs else ("zoh",)) if auto_hold else (None,)
    degrees = (None,) if searched else _auto_degrees(estimator, hidden)
    if searched:
        holds = (None,)  # the search decides the hold (one more dimension)
    grid = [{k: v for k, v in (("input_hold", h), (DEGREE, d)) if v is not None} for d in degrees for h in holds]
    return [] if grid == [{}] else grid


def candidate_settings(estimator, hidden, values):
    """``(library, input_hold, other_values)`` of one candidate: ``values`` without the ``"auto"`` entries.

    The library is the estimator's (None: the strategy's default; ``"auto"``:
    the default at ``values["library__degree"]`` when given), unfitted and
    not yet cloned; the hold is ``values["input_hold"]`` when given, else the
    estimator's (``"auto"`` without a decision: ``"linear"``).

    Examples
    --------
    >>> from sindybench.hidden import DerivativeHiddenState, HiddenStateSINDy
    >>> lib, hold, rest = candidate_settings(HiddenStateSINDy(), DerivativeHiddenState(),
    ...                                      {"library__degree": 1, "input_hold": "zoh", "n_substeps": 2})
    >>> lib.degree, hold, rest
    (1, 'zoh', {'n_substeps': 2})
    """
    values = dict(values)
    hold = values.pop("input_hold", estimator.input_hold)
    degree = values.pop(DEGREE, None) if is_auto(estimator.library) else None
    library = estimator.library
    if library is None or is_auto(library):
        library = hidden.default_library()
        if degree is not None:
            library = clone(as_library(library)).set_params(degree=int(degree))
    return library, ("linear" if is_auto(hold) else hold), values


def auto_refinement(refine, dynamics):
    """The refinement to run: ``refine`` itself, or for ``"auto"`` an ``OutputErrorRefinement()`` of compiled models.

    Examples
    --------
    >>> class Compiled:
    ...     compiled = True
    >>> type(auto_refinement("auto", Compiled())).__name__, auto_refinement(None, Compiled())
    ('OutputErrorRefinement', None)
    """
    if not is_auto(refine):
        return refine
    return OutputErrorRefinement() if dynamics.compiled else None


def decide(estimator, grid, hidden, X, y, dt, derivative):
    """``(best_params, search_results, n_rows)``: the candidates of ``grid``, each scored on the validation block.

    Each candidate is ``estimator._candidate`` fitted without the validation
    block of each record and scored as a trial of the inner search. A record
    too short for a validation block, a fallback (the grid's last entry,
    tried first) that raises an error (a divergence is a score, not an error),
    or a grid whose every candidate diverges takes the fallback and all the
    rows; otherwise the rows are all of them with ``refit`` (the chosen
    settings are fitted again).
    """
    n = [y_r.shape[0] for y_r in y]
    try:
        n_fit = [n_r - estimator._n_validation(n_r) for n_r in n]
    except ValueError:
        return dict(grid[-1]), [], n
    if len(grid) == 1:
        return dict(grid[0]), [], n
    objective = SearchObjective(lambda values: estimator._candidate(hidden, values, X, y, dt, n_fit, derivative),
                                hidden, X, y, n_fit, estimator.validation)
    results = [None] * len(grid)
    with np.errstate(all="ignore"):
        for i in [len(grid) - 1, *range(len(grid) - 1)]:  # the fallback first: its error ends the decision
            results[i] = (dict(grid[i]), float(objective(grid[i])))
            if objective.first_error is not None and i == len(grid) - 1:
                logger.info("auto settings: the fallback %s failed (%s)", grid[i], objective.first_error)
                return dict(grid[i]), [], n  # the fit on all rows raises the error, as the defaults before 0.2 did
    best = min(range(len(grid)), key=lambda i: (results[i][1], -i))  # a tie: the later (richer) candidate
    if results[best][1] >= SEARCH_PENALTY:
        best = len(grid) - 1
    logger.info("auto settings: %s (validation %s)", grid[best], [round(r[1], 4) for r in results])
    return dict(grid[best]), results, (n if estimator.refit else n_fit)
