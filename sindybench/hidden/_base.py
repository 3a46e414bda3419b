"""The strategy protocol behind :class:`~sindybench.HiddenStateSINDy`.

A *hidden-state strategy* says how to turn measured outputs ``y`` and inputs ``u``
into a full state (observed + reconstructed hidden states), which state
derivatives the sparse regression learns, which rows of the model are fixed by
physics, and how to start a simulation on new data. ``HiddenStateSINDy`` does the
rest: differentiation, library, STLS, the search over the strategy's physical
guesses (Optuna TPE on a validation block), simulation and scoring.

Conventions
-----------
* State vector ``x`` of length ``n_states``; library input ``Z = [x, u]`` (states
  first, then inputs), exactly as in :mod:`sindybench.libraries` and
  :class:`sindybench.simulate.TermsRHS`. Term tuples index columns of ``Z``.
* ``learned``: indices of the states whose derivative the library fits (one STLS
  target per index). Every other state derivative is a *fixed row*: a linear
  combination of terms (``fixed_terms`` with ``fixed_coef``), e.g. the chain row
  ``y' = v`` or ``v' = (u - c v - k y - z) / m``. Fixed rows are part of the model
  by construction; they are never fitted and never overwritten after a fit.
* ``params``: a dict holding *all* physical parameters of the strategy (values
  given to the constructor, plus the searched ones for the current trial).

Writing a strategy
------------------
Subclass :class:`HiddenStrategy` (a scikit-learn ``BaseEstimator``: ``__init__``
only stores keyword arguments; physical guesses are constructor parameters,
``None`` meaning "search it within ``bounds``"). Set the class attribute
``_physical`` to the names of the searchable physical parameters and implement

``structure(params, *, n_outputs, n_inputs) -> Structure``
    number and names of the states, ``learned`` and ``output_index``, the fixed
    rows as terms, simulation bounds per state.
``design(u, y, dt, *, derivative, params) -> Design``
    the state trajectory on training data (hidden states reconstructed) and the
    targets (time derivatives of the ``learned`` states), one column per entry of
    ``learned``, in that order.
``initial_state(u, y_init, dt, *, derivative, params, model) -> ndarray``
    a first guess of the initial state (length ``n_states``) for a simulation of
    new data, from its first output samples ``y_init`` (and inputs ``u``, same
    length): a heuristic such as a local polynomial fit, a steady state or a
    grid search. It optimizes nothing itself:
``initial_fit(params, *, n_outputs, n_inputs) -> InitialFit or None``
    says how that guess is refined (default None: it is final). An
    :class:`InitialFit` names the window of first samples to match, the states
    that are free and box bounds for them; ``HiddenStateSINDy`` then refines the
    guess with the one initial-state estimator of the package,
    :func:`sindybench.refine.estimate_initial_state` (least squares of the
    simulated outputs, exact sensitivities on the compiled path), in the search
    (validation scores) and in ``predict`` alike.

The optional hooks, each with a default in :class:`HiddenStrategy` (this is every
method ``HiddenStateSINDy`` calls on a strategy, besides scikit-learn's ``get_params``):

``default_library()``
    the library used when the estimator's ``library=None`` (default: polynomials of degree 2).
``search_space()``, ``resolve_params(values)``
    the searched physical parameters and all of them for one trial (defaults: the
    ``_physical`` names that are ``None``, ranges from ``bounds``).
``refinable(params)``
    the physical parameters that a simulation-error refinement may move (default:
    every ``_physical`` one).
``refine_free(coef, terms, *, n_outputs, n_inputs)``
    which learned coefficients that refinement frees (default: the nonzero ones;
    the latent strategy keeps each row's gauge coefficient fixed).
``coef_support(terms, *, n_outputs, n_inputs)``
    which learned coefficients may be nonzero at all, a boolean (n_terms,
    n_learned), or None (default: every one): the rest are set to 0 after the
    equation-error fit and never freed by the refinement (e.g. the latent
    strategy's cascade, whose latent rows have no output terms).
``physical_map(params, *, n_outputs, n_inputs)``
    how those parameters enter the fixed rows, declared once: a
    :class:`~sindybench.refine.CoefficientMap` (entries ``scale * prod / prod`` of
    named parameters over ``fixed_terms``), so that the refinement evaluates it
    without calling the strategy back (default: None; the refinement then calls
    ``structure`` at every evaluation). Python fixed rows take new values through
    their own ``with_params`` (``ParametricHiddenState``'s do).
``gauge()``
    for strategies whose hidden states have no unit of their own: how their scale is
    fixed, in words, one line per state; the estimator adds the lines to
    ``equations()`` (default: ``""``, nothing to say).
``_validate()``
    parameter checks, called at the start of ``fit`` (raise ``ValueError``).
``_validate_data(u, y)``
    checks that need the training data, e.g. a call of a user function on the
    first sample; called right after ``_validate()``.

``derivative(a, order=1)`` is a callable bound to the estimator's fitted
differentiation method and ``dt``: it returns the ``order``-th time derivative of
``a`` (shape ``(n,)`` or ``(n, k)``, same shape back). ``model`` is a
:class:`ModelView` of the fitted model (``rhs(x, u)`` for one state, and
``simulate(x0, u)`` for a full open-loop run that returns NaN after a
divergence), for strategies that estimate hidden initial states by matching the
model (e.g. the tanks' grid search against ``y'(0)``).

Example: a Bouc-Wen structure (states ``(y, v, z)``, ``v = y'``; z reconstructed
as ``u - c v - k y - m y''``; ``z'`` learned) would return
``Structure(n_states=3, learned=(2,), output_index=(0,),
fixed_terms=[((1, POW, 1, 0),), ((0, POW, 1, 0),), ((1, POW, 1, 0),),
((2, POW, 1, 0),), ((3, POW, 1, 0),)], fixed_coef=...)`` where column 0 of
``fixed_coef`` holds the chain row ``y' = v`` and column 1 the force balance, and
``design`` returns ``states = [y, y', z]`` and ``targets = z'``.
"""

from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np
from sklearn.base import BaseEstimator

from ..search import as_dimension

__all__ = ["Design", "HiddenStrategy", "InitialFit", "ModelView", "Structure", "linear_term"]


def linear_term(col):
    """The term ``Z[:, col]`` (one factor, power 1).

    Examples
    --------
    >>> linear_term(2)
    ((2, 0, 1, 0),)
    """
    return ((int(col), 0, 1, 0),)


@dataclass
class Structure:
    """What a strategy's model looks like for given physical parameters.

    Parameters
    ----------
    n_states : int
        Length of the state vector ``x``.
    learned : tuple of int
        States whose derivative the library fits (in the order of the targets).
    output_index : tuple of int
        States that are the measured outputs, in the column order of ``y``.
    fixed_terms : list of term tuples
        Terms on ``Z = [x, u]`` used by the fixed rows.
    fixed_coef : ndarray of shape (len(fixed_terms), n_states)
        Coefficients of the fixed rows; columns of ``learned`` states are zero.
    state_names : list of str
        Names used by ``equations()``.
    bounds : tuple (lower, upper) of ndarray of shape (n_states,), or None
        Simulation bounds per state (``-inf``/``inf`` for unbounded).
    fixed_rhs : callable or None
        Optional ``f(x, u) -> dxdt`` (length ``n_states``, learned entries ignored)
        for fixed rows that are not expressible as terms (Python callables).
        When given it replaces ``fixed_terms``/``fixed_coef`` and the model is
        simulated on the slow Python path unless the strategy handles it.
    """

    n_states: int
    learned: tuple
    output_index: tuple
    fixed_terms: list = field(default_factory=list)
    fixed_coef: np.ndarray = None
    state_names: list = None
    bounds: tuple = None
    fixed_rhs: Callable = None

    def __post_init__(self):
        self.learned = tuple(int(i) for i in self.learned)
        self.output_index = tuple(int(i) for i in self.output_index)
        if self.fixed_coef is None:
            self.fixed_coef = np.zeros((len(self.fixed_terms), self.n_states))
        self.fixed_coef = np.asarray(self.fixed_coef, dtype=float).reshape(len(self.fixed_terms), self.n_states)
        if self.state_names is None:
            self.state_names = [f"x{i}" for i in range(self.n_states)]


class Design(NamedTuple):
    """Regression data produced by a strategy on one block of data.

    Attributes
    ----------
    states : ndarray of shape (n_samples, n_states)
        Observed and reconstructed hidden states.
    targets : ndarray of shape (n_samples, len(learned))
        Time derivatives of the learned states.
    rows : slice or ndarray of bool or None
        Rows used for the regression (e.g. to drop derivative edge effects);
        None = all rows.
    feature_filter : callable or None
        ``f(theta) -> theta`` applied to the library features of the whole
        block (n_samples, n_features) before the rows are taken, to smooth them
        like the targets (filtered regression, see ``BoucWenHiddenState``);
        None = raw features.
    """

    states: np.ndarray
    targets: np.ndarray
    rows: object = None
    feature_filter: Callable = None


class ModelView(NamedTuple):
    """The fitted model as seen by ``HiddenStrategy.initial_state``.

    Attributes
    ----------
    rhs : callable
        ``rhs(x, u) -> dxdt`` for one state ``x`` (n_states,) and input ``u`` (n_inputs,).
    simulate : callable
        ``simulate(x0, u) -> x`` (n_samples, n_states), NaN after a divergence.
    n_substeps : int
        Integration sub-steps per sample of ``simulate`` (what a run costs).
    """

    rhs: Callable
    simulate: Callable
    n_substeps: int = 1


def positive_dimension(spec, name, *, note=""):
    """``spec`` read as a log-scaled dimension (:func:`~sindybench.search.as_dimension`) of positive values only."""
    dim = as_dimension(spec, name=name, real=True, log=True)
    low = dim.support()[0]
    if not low > 0:
        raise ValueError(f"{name} = {spec!r} reaches {low!r}; expected positive values only{note}.")
    return dim


def with_defaults(bounds, defaults=None):
    """A strategy's ``bounds`` dict (None: empty) over ``defaults``; anything but a dict is a ``ValueError``."""
    if bounds is not None and not isinstance(bounds, dict):
        raise ValueError(f"bounds must be a dict name -> dimension (LogUniform(low, high), ...) or (low, high[, log]), "
                         f"or None; got {bounds!r}.")
    return {**(defaults or {}), **(bounds or {})}


def bounds_space(strategy, names, bounds, *, positive=False):
    """The parameters among ``names`` that ``strategy`` leaves None (searched), with their dimensions from ``bounds``.

    ``positive``: ``(low, high)`` is log-scaled and the values must be
    positive (:func:`positive_dimension`). A key of ``bounds`` that is not
    one of the strategy's physical parameters (``_physical``) is an error
    naming the accepted ones: a misspelled key would otherwise leave the
    default range searched.
    """
    bounds = with_defaults(bounds)
    accepted = tuple(strategy._physical)
    unknown = [key for key in bounds if key not in accepted]
    if unknown:
        raise ValueError(f"bounds has the unknown key {unknown[0]!r}; {type(strategy).__name__} accepts "
                         f"{', '.join(map(repr, accepted))}.")
    space = {}
    for name in names:
        if getattr(strategy, name) is not None:
            continue
        if name not in bounds:
            raise ValueError(
                f"{name}=None asks for a search but bounds has no entry {name!r}; "
                f"expected bounds={{{name!r}: (low, high)}} or a fixed value."
            )
        where = f"bounds[{name!r}]"
        if positive:
            space[name] = positive_dimension(bounds[name], where, note=f" ({name} > 0)")
        else:
            space[name] = as_dimension(bounds[name], name=where, real=True)
    return space


class InitialFit(NamedTuple):
    """How a strategy's first guess of the initial state is refined (see :meth:`HiddenStrategy.initial_fit`).

    ``HiddenStateSINDy`` refines the guess by
    :func:`sindybench.refine.estimate_initial_state`: least squares between the
    model's simulation from the initial state and the first ``n_samples``
    output samples (residuals scaled by each output's largest magnitude there),
    over the ``free`` states within ``bounds``, converged tightly.

    Attributes
    ----------
    n_samples : int
        The first samples of ``y_init`` that the simulation matches (fewer when
        ``y_init`` is shorter; no refinement with fewer than 2).
    free : tuple of int or None, default=None
        The states that are estimated; the others keep the guess. None: all.
    bounds : (lower, upper) or None, default=None
        Box bounds of the initial states (scalars or one entry per state, None
        entries unbounded), within the model's simulation bounds; e.g.
        ``(0.0, None)`` for a level.

    Examples
    --------
    >>> InitialFit(10, free=(1,), bounds=(0.0, 10.0))
    InitialFit(n_samples=10, free=(1,), bounds=(0.0, 10.0))
    """

    n_samples: int
    free: tuple = None
    bounds: tuple = None


class HiddenStrategy(BaseEstimator):
    """Base class of hidden-state strategies (see the module docstring).

    Subclasses define ``_physical`` (names of searchable constructor parameters)
    and, when any of them may be ``None``, a ``bounds`` constructor parameter: a
    dict ``name -> dimension`` (``Uniform``, ``LogUniform``, ``Normal``,
    ``LogNormal`` of :mod:`sindybench.search`), or the older ``(low, high)`` /
    ``(low, high, log)``.
    """

    _physical = ()

    def default_library(self):
        """The library used when ``HiddenStateSINDy(library=None)``."""
        from ..libraries import PolynomialLibrary

        return PolynomialLibrary(degree=2)

    def _validate(self):
        """Check constructor parameters; raise ``ValueError`` with a clear message."""
        self.search_space()  # a bad range raises here
        for name in self._physical:
            value = getattr(self, name)
            if value is not None and not np.all(np.isfinite(np.asarray(value, dtype=float))):
                raise ValueError(f"{name} must be finite or None (searched); got {value!r}.")

    def _validate_data(self, u, y):
        """Checks that need the training inputs ``u`` and outputs ``y`` (2-D); raise ``ValueError``."""

    def search_space(self):
        """Searched physical parameters: ``name -> dimension`` (see :mod:`sindybench.search`).

        The default lists the ``_physical`` parameters that are ``None``, with
        their range from ``self.bounds`` (read by :func:`~sindybench.search.as_dimension`).
        """
        return bounds_space(self, self._physical, getattr(self, "bounds", None))

    def resolve_params(self, values=None):
        """All physical parameters: constructor values, ``values`` for the searched ones."""
        values = {} if values is None else dict(values)
        params = {}
        for name in self._physical:
            fixed = getattr(self, name)
            if fixed is not None:
                params[name] = fixed
            elif name in values:
                params[name] = values[name]
            else:
                raise ValueError(f"no value for the searched parameter {name!r}.")
        return params

    def refinable(self, params):
        """Names of the physical parameters that enter the fixed rows (refined by simulation error).

        The default: the numeric ``_physical`` parameters. Initial states are
        not listed here; the refinement frees the whole initial state anyway.
        """
        return tuple(name for name in self._physical if name in params)

    def physical_map(self, params, *, n_outputs, n_inputs):
        """How the refinable physical parameters enter the fixed rows: a :class:`~sindybench.refine.CoefficientMap`.

        Declared once, so that a refinement evaluates it without calling the
        strategy back. The default: None (the refinement then calls
        :meth:`structure` at every evaluation when the fixed rows have terms).
        """
        return None

    def coef_support(self, terms, *, n_outputs, n_inputs):
        """Entries of the learned coefficients (n_terms, n_learned) that may be nonzero; None: every one.

        ``terms`` are the library's terms (None for a Python library).
        """
        return None

    def refine_free(self, coef, terms, *, n_outputs, n_inputs):
        """Entries of the learned coefficients (n_terms, n_learned) that a refinement frees.

        The default: the nonzero ones (the equation-error fit's support).
        ``terms`` are the library's terms (None for a Python library).
        """
        return coef != 0

    def gauge(self, model=None):
        """How the scale of hidden states without units is fixed, one line per state (default: ``""``).

        ``model``, a fitted estimator of this strategy, lets the answer state
        what that fit holds (see :meth:`LatentHiddenState.gauge`).
        """
        return ""

    def structure(self, params, *, n_outputs, n_inputs):
        """The model structure for ``params`` (see :class:`Structure`)."""
        raise NotImplementedError

    def design(self, u, y, dt, *, derivative, params):
        """States and regression targets on training data (see :class:`Design`)."""
        raise NotImplementedError

    def initial_state(self, u, y_init, dt, *, derivative, params, model):
        """First guess of the initial state for simulating new data from its first samples ``y_init``."""
        raise NotImplementedError

    def initial_fit(self, params, *, n_outputs, n_inputs):
        """How the guess of :meth:`initial_state` is refined: an :class:`InitialFit`, or None (the guess is final).

        Parameters
        ----------
        params : dict
            All physical parameters (see :meth:`resolve_params`).
        n_outputs, n_inputs : int
            Columns of ``y`` and ``u``.

        Returns
        -------
        InitialFit or None
            The default: None.
        """
        return None
