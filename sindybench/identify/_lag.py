"""The lag family of ``identify``: a sparse polynomial NARX (:class:`~sindybench.LagSINDy`) and the rule between it
and the continuous-time equations.

The family's estimator runs its own search inside ``fit`` (its output orders and its number of terms, chosen by
the free run of the fit record's last fifth) and its own refinement by simulation error, so it skips the
screening on a pruning path. The rule: a lag model is returned only when it validates better than the
equation the search would return without it by more than its standard error; on a tie the equation wins (it is
what a physicist reads).
"""

import numpy as np
from sklearn.base import clone

from .._lag_sindy import LagSINDy
from ..optimizers import ForwardOLS
from ..refine import OutputErrorRefinement

__all__ = ["LAG_FAMILY", "equation_or_lag", "make_lag"]

LAG_FAMILY = "lag"
#: the largest output order searched; the input's window is one sample longer, led by one sample (u[k+1])
LAG_MAX = 3
#: the numbers of terms searched with the orders (sparsest first: the first wins a tie; with the intercept
#: within identify's default max_terms=15)
LAG_TERMS = (8, 14)
_LAG_REFINEMENT = {"max_nfev": 30, "max_samples": 5000}


def make_lag(structure, library, dt):
    """The lag family's estimator: greedy term selection on the next output, its orders and terms searched in fit.

    The input's window holds ``u[k+1]`` (a lead of one sample: the sampled input's next value, which tells
    what a smooth input did between the samples) down to ``u[k - LAG_MAX + 1]``, shifted by the structure's
    input delay.

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary
    >>> model = make_lag({"input_delay": 0}, PolynomialLibrary(degree=3), 0.1)
    >>> model.input_delay, model.input_lags, model.param_grid
    (-1, 4, {'n_terms': [8, 14]})
    """
    return LagSINDy(library=clone(library), optimizer=ForwardOLS(n_terms=LAG_TERMS[0], center=True),
                    normalize=False, output_lags="auto", input_lags=LAG_MAX + 1, max_lags=LAG_MAX, dt=dt,
                    input_delay=structure["input_delay"] - 1, target="next",
                    param_grid={"n_terms": list(LAG_TERMS)},
                    refine=OutputErrorRefinement(**_LAG_REFINEMENT))


def equation_or_lag(equation, lag, mean, std, n_blocks):
    """``(index, reason)``: the lag candidate ``lag`` when it validates better than the equation ``equation`` by
    more than its standard error (its spread over the blocks over ``sqrt(n_blocks)``), else the equation.

    ``equation`` is the pick of the continuous-time candidates (the parsimony rule and the linear base's
    rule), ``lag`` the lag candidate of least mean error; either may be None (no such candidate).

    Examples
    --------
    >>> equation_or_lag(0, 1, [0.10, 0.09], [0.03, 0.03], 3)[0]  # better by 0.01 < 0.03 / sqrt(3): a tie
    0
    >>> equation_or_lag(0, 1, [0.10, 0.05], [0.03, 0.03], 3)[0]
    1
    """
    if lag is None or not np.isfinite(mean[lag]):
        return equation, None
    se = float(std[lag]) / np.sqrt(max(n_blocks, 1))
    if equation is None or not np.isfinite(mean[equation]) or mean[lag] < mean[equation] - se:
        return lag, f"the lag model: it validates better than the equation by more than its standard error ({se:.3g})"
    return equation, (f"the equation: the lag model validates no better by more than its standard error "
                      f"({se:.3g})")
