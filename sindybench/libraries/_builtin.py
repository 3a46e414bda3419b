"""Built-in, compilable libraries: polynomial, thresholded square root,
absolute-value products, Coulomb friction, and a fixed list of terms."""

from collections import Counter
from itertools import combinations, combinations_with_replacement

import numpy as np

from .._validation import check_bool, check_integer, check_positive
from ..io import register_model
from ._base import BaseLibrary, canonical_term, check_variables
from ._terms import ABS_POW, POW, SIGN, SQRT, STEP, check_terms

__all__ = [
    "AbsProductLibrary",
    "FrictionLibrary",
    "IndicatorLibrary",
    "PolynomialLibrary",
    "SqrtLibrary",
    "TermsLibrary",
]


def _per_variable(value, n, name):
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.ndim != 1 or arr.size not in (1, n):
        raise ValueError(f"{name} has {arr.size} entries; expected a scalar or {n} (one per selected variable).")
    if np.any(np.isnan(arr)):
        raise ValueError(f"{name} contains NaN; expected numbers (inf allowed).")
    return np.broadcast_to(arr, (n,))


class PolynomialLibrary(BaseLibrary):
    """Monomials of the selected columns up to a total degree.

    Parameters
    ----------
    degree : int, default=2
        Highest total degree.
    include_bias : bool, default=True
        Include the constant term ``1``.
    interaction_only : bool, default=False
        Only products of distinct variables (no ``x0^2``).
    variables : sequence of int, optional
        Columns of ``Z = [states, inputs]`` to use; default all.

    Attributes
    ----------
    terms_ : list of tuple
        One term per output column, ordered by degree (as scikit-learn's
        ``PolynomialFeatures``).
    n_features_in_ : int
    n_output_features_ : int

    Examples
    --------
    >>> import numpy as np
    >>> lib = PolynomialLibrary(degree=2).fit(np.zeros((1, 2)))
    >>> lib.get_feature_names_out(["y0", "u0"]).tolist()
    ['1', 'y0', 'u0', 'y0^2', 'y0 u0', 'u0^2']
    >>> lib.transform([[2.0, 3.0]])
    array([[1., 2., 3., 4., 6., 9.]])
    """

    def __init__(self, *, degree=2, include_bias=True, interaction_only=False, variables=None):
        self.degree = degree
        self.include_bias = include_bias
        self.interaction_only = interaction_only
        self.variables = variables

    def _make_terms(self, n_features):
        degree = check_integer(self.degree, "degree", low=0)
        check_bool(self.include_bias, "include_bias")
        check_bool(self.interaction_only, "interaction_only")
        cols = sorted(check_variables(self.variables, n_features))
        terms = [()] if self.include_bias else []
        pick = combinations if self.interaction_only else combinations_with_replacement
        for d in range(1, degree + 1):
            for combo in pick(cols, d):
                terms.append(tuple((c, POW, float(k), 0.0) for c, k in sorted(Counter(combo).items())))
        return terms


class SqrtLibrary(BaseLibrary):
    """Thresholded square roots ``sqrt(clip(z, lower, upper))`` of the selected columns.

    The clip keeps the root real when a level goes slightly negative (noise,
    simulation overshoot) and models an overflowing tank at ``upper``.

    Parameters
    ----------
    lower : float or sequence of float, default=0.0
        Lower clip value (must be >= 0), per selected variable or shared.
    upper : float or sequence of float, default=inf
        Upper clip value, per selected variable or shared.
    variables : sequence of int, optional
        Columns of ``Z`` to use; default all.

    Examples
    --------
    >>> import numpy as np
    >>> lib = SqrtLibrary(upper=4.0).fit(np.zeros((1, 2)))
    >>> lib.get_feature_names_out(["x1", "x2"]).tolist()
    ['sqrt(x1)', 'sqrt(x2)']
    >>> lib.transform([[-1.0, 9.0]])
    array([[0., 2.]])
    """

    def __init__(self, *, lower=0.0, upper=np.inf, variables=None):
        self.lower = lower
        self.upper = upper
        self.variables = variables

    def _make_terms(self, n_features):
        cols = check_variables(self.variables, n_features)
        lower = _per_variable(self.lower, len(cols), "lower")
        upper = _per_variable(self.upper, len(cols), "upper")
        if np.any(lower < 0):
            raise ValueError(f"lower must be >= 0 (the root of a negative number is not real); got {self.lower!r}.")
        if np.any(lower >= upper):
            raise ValueError(f"lower must be < upper; got lower={self.lower!r}, upper={self.upper!r}.")
        return [((c, SQRT, float(lo), float(hi)),) for c, lo, hi in zip(cols, lower, upper)]


class IndicatorLibrary(BaseLibrary):
    """Regime indicators ``[lower <= z <= upper]`` of the selected columns, alone and times others.

    A hard nonlinearity often switches a flow on in one regime only: the
    cascaded tanks' upper tank spills into the lower one while it is full,
    i.e. while its (bounded) level sits at the top. With
    ``lower=10, times=[u]`` the library holds ``[x1>=10]`` and
    ``[x1>=10] u``, so the lower tank's equation can learn the spill flow
    (``k u - k' sqrt(10)`` while full) and the refinement can fit it.

    Parameters
    ----------
    variables : sequence of int
        Columns of ``Z`` whose regime is indicated.
    lower, upper : float, default=-inf, inf
        The regime ``lower <= z <= upper`` (at least one finite).
    times : sequence of int, optional
        Columns multiplied by each indicator (each product is a term too).

    Examples
    --------
    >>> import numpy as np
    >>> lib = IndicatorLibrary(variables=[0], lower=10.0, times=[1]).fit(np.zeros((1, 2)))
    >>> lib.get_feature_names_out(["x1", "u"]).tolist()
    ['[x1>=10]', '[x1>=10] u']
    >>> lib.transform([[10.0, 2.0], [9.0, 2.0]])
    array([[1., 2.],
           [0., 0.]])
    """

    def __init__(self, *, variables=None, lower=-np.inf, upper=np.inf, times=None):
        self.variables = variables
        self.lower = lower
        self.upper = upper
        self.times = times

    def _make_terms(self, n_features):
        if self.variables is None:
            raise ValueError("variables is None; expected the columns of Z whose regime is indicated.")
        cols = check_variables(self.variables, n_features)
        times = [] if self.times is None else check_variables(self.times, n_features, name="times")
        lo, hi = float(self.lower), float(self.upper)
        if np.isnan(lo) or np.isnan(hi) or not lo < hi or (np.isinf(lo) and np.isinf(hi)):
            raise ValueError(
                f"lower={self.lower!r}, upper={self.upper!r}; expected lower < upper with at least one finite."
            )
        terms = []
        for c in cols:
            step = (c, STEP, lo, hi)
            terms.append((step,))
            terms.extend(canonical_term((step, (t, POW, 1.0, 0.0))) for t in times)
        return terms


_ABS_PRODUCTS = {
    "x|y|": lambda i, j, p: ((i, POW, 1.0, 0.0), (j, ABS_POW, p, 0.0)),
    "|x|y": lambda i, j, p: ((i, ABS_POW, p, 0.0), (j, POW, 1.0, 0.0)),
    "|x||y|": lambda i, j, p: ((i, ABS_POW, p, 0.0), (j, ABS_POW, p, 0.0)),
    "xy": lambda i, j, p: ((i, POW, 1.0, 0.0), (j, POW, 1.0, 0.0)),
}


class AbsProductLibrary(BaseLibrary):
    """Products with absolute values for pairs of columns, as in hysteresis models.

    For each pair ``(x, y)`` of columns the library holds the chosen
    products among ``x|y|``, ``|x|y``, ``|x||y|`` and ``xy``; with
    ``include_abs`` also ``|x|`` for every column that appears in a pair. The
    Bouc-Wen hysteretic force obeys ``z' = a y' - b |y'| z - c y' |z|``: with
    the pair (z, y') the library holds ``z |y'|`` and ``|z| y'``.

    Parameters
    ----------
    pairs : sequence of (int, int), optional
        Column pairs of ``Z``; default all pairs ``i < j`` of ``variables``.
        A pair ``(i, i)`` gives ``x|x|`` (duplicate terms are dropped).
    products : sequence of str, optional
        Which products to build, among ``"x|y|"``, ``"|x|y"``, ``"|x||y|"``, ``"xy"``;
        default ``("x|y|", "|x|y", "|x||y|")``.
    include_abs : bool, default=False
        Also include ``|x|`` alone for each column in a pair.
    abs_power : float, default=1.0
        Exponent of every absolute-value factor (``|x|^p``).
    variables : sequence of int, optional
        Columns used to build the default pairs; must be None when ``pairs`` is given.

    Examples
    --------
    >>> import numpy as np
    >>> lib = AbsProductLibrary(pairs=[(0, 1)], include_abs=True).fit(np.zeros((1, 2)))
    >>> lib.get_feature_names_out(["z", "v"]).tolist()
    ['z |v|', '|z| v', '|z| |v|', '|z|', '|v|']
    >>> lib.transform([[2.0, -3.0]])
    array([[ 6., -6.,  6.,  2.,  3.]])
    """

    def __init__(self, *, pairs=None, products=("x|y|", "|x|y", "|x||y|"), include_abs=False, abs_power=1.0,
                 variables=None):
        self.pairs = pairs
        self.products = products
        self.include_abs = include_abs
        self.abs_power = abs_power
        self.variables = variables

    def _check_pairs(self, n_features):
        if self.pairs is None:
            cols = check_variables(self.variables, n_features)
            pairs = list(combinations(cols, 2))
            if not pairs:
                raise ValueError(
                    f"AbsProductLibrary needs two variables for its pairs; got {cols} (n_features = {n_features})."
                )
            return pairs
        if self.variables is not None:
            raise ValueError("give either pairs or variables, not both; variables only build the default pairs.")
        try:
            pairs = [tuple(p) for p in self.pairs]
        except TypeError as exc:
            raise ValueError(f"pairs must be a sequence of (int, int); got {self.pairs!r}.") from exc
        if not pairs or any(len(p) != 2 for p in pairs):
            raise ValueError(f"pairs must be a non-empty sequence of (int, int); got {self.pairs!r}.")
        for p in pairs:
            check_variables(p if p[0] != p[1] else p[:1], n_features, name="pairs")
        return [(int(i), int(j)) for i, j in pairs]

    def _make_terms(self, n_features):
        pairs = self._check_pairs(n_features)
        check_bool(self.include_abs, "include_abs")
        p = check_positive(self.abs_power, "abs_power")
        if isinstance(self.products, str) or not self.products:
            raise ValueError(f"products must be a non-empty sequence of strings; got {self.products!r}.")
        unknown = [k for k in self.products if k not in _ABS_PRODUCTS]
        if unknown:
            raise ValueError(f"products contains {unknown}; expected entries among {sorted(_ABS_PRODUCTS)}.")
        terms, seen = [], set()
        candidates = [_ABS_PRODUCTS[k](i, j, p) for i, j in pairs for k in self.products]
        if self.include_abs:
            cols = list(dict.fromkeys(c for pair in pairs for c in pair))
            candidates += [((c, ABS_POW, p, 0.0),) for c in cols]
        for term in candidates:
            key = canonical_term(term)
            if key not in seen:
                seen.add(key)
                terms.append(term)
        return terms


class FrictionLibrary(BaseLibrary):
    """Coulomb friction ``sign(v)`` of the selected columns (velocities), optionally times ``|v|^p``.

    Dry friction opposes the motion with a force of constant size:
    ``F = -F_c sign(v)``. Viscous friction ``-b v`` is a linear term (in
    :class:`PolynomialLibrary`); join both with ``+`` (a term already held by an
    earlier library is dropped). ``powers`` adds the terms
    ``sign(v) |v|^p``, a velocity-dependent friction (``p = 2``: quadratic
    drag ``v |v|``). ``sign(0) = 0``, and the simulators treat ``sign`` as a
    function of the state like any other (no stick phase is modelled).

    Parameters
    ----------
    variables : sequence of int, optional
        Columns of ``Z = [states, inputs]`` holding velocities; default all.
    powers : sequence of float > 0, default=()
        Exponents ``p`` of the extra terms ``sign(v) |v|^p``.

    Examples
    --------
    >>> import numpy as np
    >>> lib = FrictionLibrary(variables=[1], powers=[2.0]).fit(np.zeros((1, 3)))
    >>> lib.get_feature_names_out(["y", "v", "u"]).tolist()
    ['sign(v)', 'sign(v) |v|^2']
    >>> lib.transform([[0.0, -3.0, 1.0], [0.0, 0.0, 1.0]])
    array([[-1., -9.],
           [ 0.,  0.]])
    """

    def __init__(self, *, variables=None, powers=()):
        self.variables = variables
        self.powers = powers

    def _make_terms(self, n_features):
        cols = check_variables(self.variables, n_features)
        if isinstance(self.powers, str):
            raise ValueError(f"powers must be a sequence of numbers > 0; got {self.powers!r}.")
        try:
            powers = [check_positive(p, "powers") for p in self.powers]
        except TypeError as exc:
            raise ValueError(f"powers must be a sequence of numbers > 0; got {self.powers!r}.") from exc
        terms = [((c, SIGN, 0.0, 0.0),) for c in cols]
        terms += [((c, SIGN, 0.0, 0.0), (c, ABS_POW, float(p), 0.0)) for p in powers for c in cols]
        return terms


class TermsLibrary(BaseLibrary):
    """A library made of a given list of terms (e.g. a fitted model's ``terms_``).

    Parameters
    ----------
    terms : sequence of tuple
        Terms as described in :mod:`sindybench.libraries._terms`, or their
        JSON form (lists); column indices refer to ``Z``.

    Examples
    --------
    >>> import numpy as np
    >>> lib = TermsLibrary(terms=[[], [[0, 0, 2, 0]]]).fit(np.zeros((1, 1)))
    >>> lib.get_feature_names_out().tolist()
    ['1', 'x0^2']
    """

    def __init__(self, *, terms=None):
        self.terms = terms

    def _make_terms(self, n_features):
        if self.terms is None:
            raise ValueError("terms is None; expected a sequence of terms.")
        return check_terms(self.terms, n_features)


register_model(PolynomialLibrary)
register_model(SqrtLibrary)
register_model(AbsProductLibrary)
register_model(TermsLibrary)
register_model(IndicatorLibrary)
register_model(FrictionLibrary)
