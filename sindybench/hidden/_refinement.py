"""Simulation-error refinement and initial states of a fitted ``HiddenStateSINDy`` candidate.

The estimator's model is ``[learned rows | fixed rows]`` over the terms
``library terms + strategy fixed terms``, its :class:`~sindybench.dynamics.Dynamics`;
:func:`refinement_problem` says once what a refinement frees in it (a
:class:`~sindybench.refine.FreeParameters`): the learned block's entries
that :meth:`HiddenStrategy.refine_free` names, and the strategy's physical
parameters (:meth:`HiddenStrategy.refinable`) with their map into the fixed
rows, the :class:`~sindybench.refine.CoefficientMap` of
:meth:`HiddenStrategy.physical_map` (Python fixed rows take the values
through their ``with_params``). Only a strategy that declares neither is
called back (its ``structure``) per evaluation.
"""

import logging
import numbers
from dataclasses import replace

import numpy as np

from ..refine import CoefficientMap, FreeParameters, LeastSquares, Physical, estimate_initial_state
from ..simulate import SimulationError
from ._base import InitialFit

__all__ = ["initial_state", "refine_guess", "refined_values", "refinement_problem", "start_prior"]

logger = logging.getLogger(__name__)

_FIT_TOL = 1e-12  # tolerances of a strategy's initial-state fit: a short window, converged to the optimum
_FIT_NFEV = 100  # its budget of simulations per free state
#: the outputs' noise level of initial_state="prior" (relative to their spread) when the model has no refinement
PRIOR_NOISE = 0.05
_PRIOR_NOISE_FLOOR = 1e-6  # ... and its floor (a refinement that fits exact data to rounding)


class _FixedBlock:
    """``values -> C`` with the strategy's fixed rows for these physical values (learned block zero).

    The fallback for a strategy without :meth:`HiddenStrategy.physical_map`: it
    calls the strategy's ``structure`` at every evaluation.
    """

    def __init__(self, hidden, params, names, n_lib, n_outputs, n_inputs):
        self.hidden, self.params, self.names = hidden, params, names
        self.n_lib, self.n_outputs, self.n_inputs = n_lib, n_outputs, n_inputs

    def structure(self, values):
        params = {**self.params, **{k: float(v) for k, v in zip(self.names, values)}}
        return self.hidden.structure(params, n_outputs=self.n_outputs, n_inputs=self.n_inputs)

    def __call__(self, values):
        s = self.structure(values)
        out = np.zeros((self.n_lib + len(s.fixed_terms), s.n_states))
        fixed = s.fixed_coef.copy()
        fixed[:, list(s.learned)] = 0.0
        out[self.n_lib :] = fixed
        return out


class _StructureRows:
    """``make_rhs(C, values)``: ``dynamics`` with the Python fixed rows of ``structure(values)`` (the fallback)."""

    def __init__(self, block, dynamics):
        self.block, self.dynamics = block, dynamics

    def __call__(self, C, values):
        return replace(self.dynamics, fixed_rhs=self.block.structure(values).fixed_rhs).rhs_for(C)


def refinement_problem(cand, hidden, n_outputs, n_inputs):
    """What a refinement of ``cand.dynamics`` frees, and where it starts: ``{"free": FreeParameters, "x0": ...}``.

    ``x0`` holds the first state of each training record, shape (n_records, n_states).
    The keyword arguments of ``DynamicsEstimator._run_refinement`` on ``cand.dynamics``.
    """
    s, dyn = cand.structure, cand.dynamics
    learned = list(s.learned)
    n_lib = cand.coef.shape[0]
    names = tuple(k for k in hidden.refinable(cand.params)
                  if isinstance(cand.params.get(k), numbers.Real) and not isinstance(cand.params[k], bool))
    free = np.zeros(np.shape(dyn.coef), dtype=bool)
    free[:n_lib, learned] = hidden.refine_free(cand.coef, getattr(cand.library, "terms_", None),
                                               n_outputs=n_outputs, n_inputs=n_inputs)
    physical = None
    if names:
        values = np.array([float(cand.params[k]) for k in names])
        declared = hidden.physical_map(cand.params, n_outputs=n_outputs, n_inputs=n_inputs)
        make_rhs = None
        if declared is not None:
            coef = declared.placed(names, n_lib)
        elif not s.fixed_terms:  # the values enter no term: a block of zeros
            coef = CoefficientMap((0, s.n_states), (), names, n_lib)
        else:
            coef = _FixedBlock(hidden, cand.params, names, n_lib, n_outputs, n_inputs)
        if s.fixed_rhs is not None and not hasattr(s.fixed_rhs, "with_params"):  # Python rows of unknown form
            make_rhs = _StructureRows(_FixedBlock(hidden, cand.params, names, n_lib, n_outputs, n_inputs), dyn)
        physical = Physical(names=names, values=values, lower=np.where(values > 0, 0.0, -np.inf),
                            upper=np.full(len(names), np.inf), coef=coef, make_rhs=make_rhs)
    x0 = np.array([np.asarray(d.states[0], dtype=float) for d in cand.designs])  # one start per record
    return dict(free=FreeParameters(coef=free, physical=physical), x0=x0)


def refined_values(cand, result):
    """``(params, coef, x0s)`` of the candidate after the refinement ``result``; ``x0s`` (n_records, n_states)."""
    learned = list(cand.structure.learned)
    x0s = result.initial_states if result.initial_states is not None else result.x0[None]  # one record: no list kept
    return {**cand.params, **result.physical}, result.coef[: cand.coef.shape[0], learned].copy(), x0s


def refine_guess(fit, dynamics, x0, X, y_init):
    """A strategy's guess ``x0`` refined as its :class:`~sindybench.hidden.InitialFit` ``fit`` says.

    Least squares of the simulation of the first ``fit.n_samples`` samples
    (:func:`~sindybench.refine.estimate_initial_state`), each output's
    residuals scaled by its largest magnitude there, tolerances 1e-12. The
    guess stands when the window has fewer than 2 samples, no state is free,
    or its simulation diverges within the window (the simulation that
    follows then diverges too: a failed validation trial, NaN in ``predict``).
    """
    n_states = x0.shape[0]
    free = _check_fit(fit, n_states)
    n = min(int(fit.n_samples), len(y_init), len(X))
    if n < 2 or free.size == 0:
        return x0
    y = np.asarray(y_init[:n], dtype=float)
    peak = np.max(np.abs(y), axis=0)
    scale = np.where(peak > 0, peak, 1.0)
    try:
        solver = LeastSquares(max_nfev=_FIT_NFEV * free.size, ftol=_FIT_TOL, xtol=_FIT_TOL, gtol=_FIT_TOL,
                              x0_bounds=fit.bounds, output_scale=scale)
        return estimate_initial_state(dynamics, X[:n], y, x0=x0, free_x0=free, solver=solver)
    except SimulationError as exc:
        logger.debug("initial state: the guess is kept (%s)", exc)
        return x0


def _check_fit(fit, n_states):
    """The free states of a strategy's ``InitialFit``; a ``ValueError`` that says what is wrong with it."""
    if not isinstance(fit, InitialFit):
        raise ValueError(f"the strategy's initial_fit returned {fit!r}; expected an InitialFit or None.")
    if isinstance(fit.n_samples, bool) or not isinstance(fit.n_samples, numbers.Integral) or fit.n_samples < 1:
        raise ValueError(f"InitialFit.n_samples = {fit.n_samples!r}; expected an integer >= 1.")
    free = np.arange(n_states) if fit.free is None else np.asarray(fit.free).reshape(-1)
    if (free.size and not np.issubdtype(free.dtype, np.integer)) or np.any((free < 0) | (free >= n_states)) \
            or np.unique(free).size < free.size:
        raise ValueError(f"InitialFit.free = {fit.free!r}; expected distinct state indices in [0, {n_states - 1}].")
    return free.astype(np.int64)


def start_prior(dynamics, x0, X, noise):
    """``(prior, solver)`` of ``initial_state="prior"``: where the states of this record lie, and the noise level.

    The model's own simulation of the inputs ``X`` from the guess ``x0``,
    without its first fifth (the guess's transient), says where the states
    of this record lie: the prior's mean and covariance are those of its
    states (the distribution a state of the record is drawn from before
    its outputs are seen). The outputs' noise level is ``noise``
    (relative; None: :data:`PRIOR_NOISE`) times their spread there.
    ``(None, None)`` (no prior: the plain least squares) when fewer than two
    samples of it are finite or its states do not move.

    Examples
    --------
    >>> from sindybench.dynamics import Dynamics
    >>> from sindybench.libraries import POW
    >>> dyn = Dynamics.from_terms([((0, POW, 1, 0),), ((1, POW, 1, 0),)], [[-1.0], [1.0]], dt=0.1)  # x' = -x + u
    >>> u = np.sin(0.5 * 0.1 * np.arange(2000))[:, None]
    >>> (mean, cov), solver = start_prior(dyn, [5.0], u, 0.1)  # a guess far off: its transient is left out
    >>> np.round(mean, 2).tolist(), np.round(np.sqrt(cov), 2).tolist(), np.round(solver.output_scale, 3).tolist()
    ([0.0], [[0.64]], [0.064])
    """
    with np.errstate(all="ignore"):
        x = dynamics.simulate(X, x0, on_divergence="nan")
    x = x[x.shape[0] // 5 :]
    x = x[np.all(np.isfinite(x), axis=1)]
    if x.shape[0] < 2:
        return None, None
    cov = np.atleast_2d(np.cov(x, rowvar=False))
    if not np.any(np.diag(cov) > 0):
        return None, None
    spread = np.std(x[:, list(dynamics.output_index)], axis=0)
    scale = max(float(PRIOR_NOISE if noise is None else noise), _PRIOR_NOISE_FLOOR) * np.where(spread > 0, spread, 1.0)
    return (np.mean(x, axis=0), cov), LeastSquares(max_nfev=50, output_scale=scale)


def initial_state(mode, fit, dynamics, x0, X, y_init, noise=None):
    """The initial state of a simulation of ``X`` from a strategy's guess ``x0`` and the first outputs ``y_init``.

    ``mode``: ``"strategy"``: the guess refined as the strategy's
    :class:`~sindybench.hidden.InitialFit` ``fit`` says (:func:`refine_guess`;
    None: not refined); ``"fit"``: that, then least squares of the simulation
    of the first ``len(y_init)`` samples (all states free, exact sensitivities
    when compiled); ``"prior"``: the same least squares with a Gaussian prior
    of where the states of ``X`` lie (:func:`start_prior`; ``noise``: the outputs' noise level
    relative to their spread), well posed when the samples are too few to
    tell every state; ``"periodic"``: ``X`` is one period of a periodic input;
    simulate two periods from the guess and start from the state reached (the
    periodic steady state), without using ``y_init``. When the model's simulation from the guess diverges within
    ``y_init`` (the least squares cannot start), the guess stands: the simulation that follows diverges too (NaN
    from ``predict``, a :class:`~sindybench.SimulationError` from ``simulate``).
    """
    if fit is not None and mode != "periodic":
        x0 = refine_guess(fit, dynamics, x0, X, y_init)
    if mode in ("fit", "prior"):
        n = min(len(y_init), len(X))
        if n < 2:
            return x0
        prior, solver = start_prior(dynamics, x0, X, noise) if mode == "prior" else (None, None)
        try:
            return estimate_initial_state(dynamics, X[:n], y_init[:n], x0=x0, solver=solver, prior=prior)
        except SimulationError as exc:  # the model diverges within y_init: its simulation diverges as predict says
            logger.debug("initial state: the least squares cannot start, the guess is kept (%s)", exc)
            return x0
    if mode == "periodic":
        period = np.vstack([X, X[:1]])
        for _ in range(2):
            x = dynamics.simulate(period, x0, on_divergence="raise")
            x0 = x[-1]
        return x0
    return x0
