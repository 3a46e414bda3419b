"""What a refinement frees in a :class:`~sindybench.dynamics.Dynamics`, and the settings of its least squares.

A refinement criterion (:func:`~sindybench.refine.refine_simulation_error`,
:func:`~sindybench.refine.refine_prediction_error`) takes a ``Dynamics`` and a
:class:`FreeParameters` description: which coefficient entries are free one by
one, which *physical parameters* enter the coefficient matrix through a map
(:class:`Physical`; a strategy's map may be declared as a
:class:`CoefficientMap`), and which initial states are free.
:class:`ParametrizedDynamics` is the view that the criteria work on: the
coefficient matrix and the right-hand side of a parameter vector. It is the
one place that decides whether a refinement runs compiled (exact
sensitivities) or on the Python path (finite differences). The knobs of the
least squares (:class:`LeastSquares`) and of multiple shooting
(:class:`Shooting`) are grouped settings.
"""

from dataclasses import replace
from typing import Callable, NamedTuple

import numpy as np

from ..dynamics import TermsRHS

__all__ = ["CoefficientMap", "FreeParameters", "LeastSquares", "ParametrizedDynamics", "Physical", "Shooting"]


class Physical(NamedTuple):
    """Physical parameters entering the coefficient matrix through a map.

    Attributes
    ----------
    names : tuple of str
    values : ndarray of shape (n_physical,)
        Starting values (those of the ``Dynamics`` being refined).
    lower, upper : ndarray of shape (n_physical,)
        Bounds of the refined values.
    coef : callable
        ``coef(values) -> ndarray (n_terms, n_states)``, the physical part of
        the coefficient matrix (e.g. a :class:`CoefficientMap`).
    make_rhs : callable or None
        ``make_rhs(C, values) -> f(x, u)``: a right-hand side written in
        Python (the refinement then runs on the Python path). None: the
        ``Dynamics`` rebuilds its own right-hand side (its Python fixed rows
        take the values through ``fixed_rhs.with_params``).
    """

    names: tuple
    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    coef: Callable
    make_rhs: Callable = None


class FreeParameters(NamedTuple):
    """Which parts of a ``Dynamics`` a refinement frees.

    Attributes
    ----------
    coef : array-like of bool of shape (n_terms, n_states) or None
        Entries refined one by one; None: the nonzero entries of the
        coefficients without the physical part.
    physical : Physical or None
        Physical parameters refined through their map.
    x0 : sequence of int or None
        States whose initial value is refined; None: all of them.

    Examples
    --------
    >>> FreeParameters(x0=[1]).x0
    [1]
    """

    coef: np.ndarray = None
    physical: Physical = None
    x0: tuple = None


class LeastSquares(NamedTuple):
    """Settings of the least squares (:func:`scipy.optimize.least_squares`) of a refinement.

    Attributes
    ----------
    max_nfev : int, default=100
        Budget of simulations per refinement round.
    ftol, xtol, gtol : float, default=1e-8
        Stopping tolerances.
    x0_bounds : (lower, upper) or None
        Box bounds of the free initial states (scalars or one per state),
        within the simulation bounds; default: those alone.
    output_scale : array-like of shape (n_outputs,) or None
        Scale of each output's residuals; default: the criterion's own.
    warn_budget : bool, default=True
        Warn (``ConvergenceWarning``) when the last round stops on ``max_nfev``.

    Examples
    --------
    >>> LeastSquares(max_nfev=20).ftol
    1e-08
    """

    max_nfev: int = 100
    ftol: float = 1e-8
    xtol: float = 1e-8
    gtol: float = 1e-8
    x0_bounds: tuple = None
    output_scale: np.ndarray = None
    warn_budget: bool = True


class Shooting(NamedTuple):
    """Multiple shooting: ``n_segments`` segments, their continuity residuals weighted by ``continuity_weight``.

    ``n_segments=1`` is single shooting; the weight is relative to the
    output residuals (continuity per state spread, outputs per output spread).

    Examples
    --------
    >>> Shooting(5)
    Shooting(n_segments=5, continuity_weight=1.0)
    """

    n_segments: int = 1
    continuity_weight: float = 1.0


def check_settings(value, kind, name, example):
    """``value`` if it is a ``kind`` (a grouped setting); a ``TypeError`` that says how to write one otherwise."""
    if not isinstance(value, kind):
        raise TypeError(f"{name} must be a sindybench.refine.{kind.__name__} (e.g. {kind.__name__}({example})) or "
                        f"None; got {type(value).__name__}.")
    return value


class CoefficientMap:
    """``values -> C``: entries ``scale * prod(numerator) / prod(denominator)`` of named physical parameters.

    A strategy declares with it how its physical parameters enter its fixed
    rows, once; the refinement then evaluates the map without calling the
    strategy back.

    Parameters
    ----------
    shape : (n_rows, n_states)
    entries : sequence of (row, state, scale, numerator names, denominator names)
    names : sequence of str
        The order of ``values`` in :meth:`__call__`.
    offset : int, default=0
        Rows of zeros above the entries (the library's terms) in :meth:`__call__`.

    Examples
    --------
    ``v' = (u - c v) / m`` over the terms ``(v, u)``:

    >>> rows = CoefficientMap((2, 1), [(0, 0, -1.0, ("c",), ("m",)), (1, 0, 1.0, (), ("m",))], ("m", "c"))
    >>> rows.matrix({"m": 2.0, "c": 1.0}).ravel().tolist(), rows([4.0, 1.0]).ravel().tolist()
    ([-0.5, 0.5], [-0.25, 0.25])
    """

    def __init__(self, shape, entries, names=(), offset=0):
        self.shape, self.entries, self.names, self.offset = tuple(shape), tuple(entries), tuple(names), int(offset)

    def matrix(self, params):
        """The ``(n_rows, n_states)`` block for the parameters ``params`` (a dict name -> number)."""
        missing = sorted({n for _, _, _, num, den in self.entries for n in (*num, *den)} - set(params))
        if missing:
            raise ValueError(f"the coefficient map needs the parameters {missing}; got {sorted(params)}.")
        out = np.zeros(self.shape)
        for row, state, scale, numerator, denominator in self.entries:
            value = scale
            for name in numerator:
                value = value * float(params[name])
            for name in denominator:
                value = value / float(params[name])
            out[row, state] = value
        return out

    def placed(self, names, offset):
        """This map with ``values`` in the order ``names`` and ``offset`` zero rows above."""
        return CoefficientMap(self.shape, self.entries, names, offset)

    def __call__(self, values):
        block = self.matrix(dict(zip(self.names, values)))
        if not self.offset:
            return block
        return np.vstack([np.zeros((self.offset, self.shape[1])), block])


class ParametrizedDynamics:
    """A ``Dynamics`` seen as a function of a parameter vector: the view every refinement criterion works on.

    ``p`` starts with the physical values, then the free coefficient entries
    (row-major order of the ``free`` mask); :meth:`matrix` and :meth:`rhs`
    give the model of that part. :attr:`compiled` is the one place deciding
    between exact sensitivities (a compiled model of terms without a Python
    ``make_rhs``) and the Python path.

    Parameters
    ----------
    dynamics : Dynamics
        The starting model (its coefficients include the physical part).
    free : FreeParameters, optional

    Examples
    --------
    >>> from sindybench.dynamics import Dynamics, POW
    >>> dyn = Dynamics.from_terms([((0, POW, 1, 0),), ((1, POW, 1, 0),)], [[-1.0], [2.0]], dt=0.1)
    >>> view = ParametrizedDynamics(dyn)
    >>> view.compiled, view.free.tolist(), view.matrix(np.array([-0.5, 1.0])).ravel().tolist()
    (True, [[0, 0], [1, 0]], [-0.5, 1.0])
    """

    def __init__(self, dynamics, free=None, *, coef=None):
        free = FreeParameters() if free is None else check_settings(free, FreeParameters, "free", "coef=mask")
        self.dynamics, self.physical = dynamics, free.physical
        n_states = dynamics.n_states
        if coef is None:  # the coefficients without the physical part
            coef = np.asarray(dynamics.coef, dtype=float)
            if self.physical is not None:
                coef = coef - self.physical.coef(self.physical.values)
        self.coef = coef
        mask = (coef != 0) if free.coef is None else np.asarray(free.coef, dtype=bool)
        if mask.shape != coef.shape:
            raise ValueError(f"free has shape {mask.shape}; expected {coef.shape} (the shape of coef).")
        self.mask = mask
        self.free = np.argwhere(mask)  # (n_free, 2) of (term, state)
        free_x0 = np.arange(n_states) if free.x0 is None else np.asarray(free.x0, dtype=np.int64).reshape(-1)
        if free_x0.size and (free_x0.min() < 0 or free_x0.max() >= n_states
                             or np.unique(free_x0).size < free_x0.size):
            raise ValueError(f"free_x0 = {free_x0.tolist()}; expected distinct state indices in [0, {n_states - 1}].")
        self.free_x0 = free_x0
        self.n_phys = 0 if self.physical is None else len(self.physical.names)
        self.n_model = self.n_phys + len(self.free)
        self.compiled = dynamics.compiled and (self.physical is None or self.physical.make_rhs is None)
        rows = getattr(dynamics.fixed_rhs, "with_params", None)
        self._rows = rows if self.n_phys and self.physical.make_rhs is None else None

    @property
    def terms(self):
        """The terms of a compiled model (None on the Python path)."""
        return self.dynamics.terms if self.compiled else None

    def rounded(self, coef, mask, physical):
        """The view of the next refinement round: constant ``coef``, free ``mask``, ``physical`` values."""
        free = FreeParameters(coef=mask, physical=physical, x0=self.free_x0)
        return ParametrizedDynamics(self.dynamics, free, coef=coef)

    def start(self):
        """The model part of ``p`` at the start: physical values, then the free entries."""
        parts = [] if self.physical is None else [np.asarray(self.physical.values, dtype=float)]
        parts.append(self.coef[self.free[:, 0], self.free[:, 1]])
        return np.concatenate(parts)

    def model_bounds(self):
        """Lower and upper bounds of the model part of ``p``."""
        n_free = len(self.free)
        lower, upper = [np.full(n_free, -np.inf)], [np.full(n_free, np.inf)]
        if self.physical is not None:
            lower.insert(0, np.asarray(self.physical.lower, dtype=float))
            upper.insert(0, np.asarray(self.physical.upper, dtype=float))
        return np.concatenate(lower), np.concatenate(upper)

    def matrix(self, p):
        """The full coefficient matrix of the model part ``p``."""
        C = self.coef.copy()
        C[self.free[:, 0], self.free[:, 1]] = p[self.n_phys : self.n_model]
        if self.physical is not None:
            C = C + self.physical.coef(p[: self.n_phys])
        return C

    def directions(self, p):
        """dC/dp for the model parameters (physical by central differences of the algebraic map)."""
        D = np.zeros((self.n_model,) + self.coef.shape)
        v = np.asarray(p[: self.n_phys], dtype=float)
        for k in range(self.n_phys):
            step = 1e-6 * max(abs(v[k]), 1e-3)
            hi, lo = v.copy(), v.copy()
            hi[k] += step
            lo[k] -= step
            D[k] = (self.physical.coef(hi) - self.physical.coef(lo)) / (2 * step)
        for e, (j, i) in enumerate(self.free):
            D[self.n_phys + e, j, i] = 1.0
        return D

    def rhs(self, p):
        """The right-hand side of the model part ``p``: compiled, or the Python path's (the model's own if held)."""
        if self.n_model == 0 and self.physical is None:
            return self.dynamics.rhs
        C = self.matrix(p)
        if self.compiled:
            return TermsRHS(C, self.dynamics.terms, self.dynamics.n_states)
        if self.physical is not None and self.physical.make_rhs is not None:
            return self.physical.make_rhs(C, p[: self.n_phys])
        if self._rows is not None:  # Python fixed rows that take the physical values
            values = {name: float(v) for name, v in zip(self.physical.names, p[: self.n_phys])}
            return replace(self.dynamics, fixed_rhs=self._rows(values)).rhs_for(C)
        return self.dynamics.rhs_for(C)

    def physical_part(self, values):
        """The physical part of the coefficient matrix (0 without physical parameters)."""
        return self.physical.coef(values) if self.physical is not None else 0.0
