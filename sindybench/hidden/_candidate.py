"""The functional core of :class:`~sindybench.HiddenStateSINDy`: one candidate model for given physical parameters.

:func:`fit_candidate` runs the strategy's design on each record, the library and the sparse
optimizer (:func:`~sindybench._regression.fit_sparse`, the regression step of
``SINDy`` too) and assembles the candidate's :class:`~sindybench.dynamics.Dynamics`;
:func:`candidate_initial_state` starts a simulation of new data from its
first output samples.
"""

from typing import NamedTuple

import numpy as np

from .._validation import check_signal
from ..dynamics import Dynamics, assemble
from ._base import Design, ModelView, Structure
from ._derivative import Derivative
from ._refinement import initial_state
from ._regressions import fit_regression

__all__ = ["Candidate", "candidate_initial_state", "fit_candidate", "structure_dynamics"]


class Candidate(NamedTuple):
    """One fitted model for given physical parameters.

    ``coef`` has shape (n_library_terms, n_learned). ``designs`` holds every
    training record's design (one for one record); ``design`` is the first.
    """

    params: dict
    structure: Structure
    library: object
    optimizer: object
    differentiation: object
    coef: np.ndarray
    derivative: Derivative
    designs: tuple
    dynamics: Dynamics

    @property
    def design(self):
        """The first record's :class:`~sindybench.hidden.Design`."""
        return self.designs[0]


def structure_dynamics(structure, library, coef, simulation):
    """The :class:`~sindybench.dynamics.Dynamics` of a strategy's ``structure`` with the learned ``coef``.

    ``simulation``: ``dt``, ``n_substeps``, ``input_hold`` and ``max_abs``, and optionally
    ``method`` (default ``"rk4"``) and ``bounds`` (None: the structure's).
    """
    s = structure
    settings = {"method": "rk4", **simulation}
    bounds = settings.pop("bounds", None)
    return assemble(library, coef, n_states=s.n_states, learned=s.learned, fixed_terms=s.fixed_terms,
                    fixed_coef=s.fixed_coef, fixed_rhs=s.fixed_rhs, output_index=s.output_index,
                    state_names=s.state_names, bounds=s.bounds if bounds is None else bounds, **settings)


def fit_candidate(hidden, params, library, optimizer, derivative, Xs, ys, n_rows, simulation, *, normalize=False):
    """Fit the candidate of ``hidden`` with physical ``params`` on the first ``n_rows`` samples of each record.

    The strategy's design (hidden-state reconstruction, ``Design.rows``,
    feature filter) runs on each record alone, so nothing is differentiated,
    filtered or reconstructed across the seam between two records; the
    regression rows of all records are stacked into one regression.

    Parameters
    ----------
    hidden : HiddenStrategy
    params : dict
        All physical parameters (:meth:`HiddenStrategy.resolve_params`).
    library, optimizer : unfitted clones
        Fitted here.
    derivative : Derivative
    Xs : list of ndarray of shape (n_samples_r, n_inputs)
        One input array per record (a list of one for one record).
    ys : list of ndarray of shape (n_samples_r, n_outputs)
    n_rows : list of int
        The regression uses the first ``n_rows[r]`` samples of record ``r``
        (and the strategy's ``Design.rows``).
    simulation : dict
        ``dt``, ``n_substeps``, ``input_hold``, ``max_abs`` (and ``method``, ``bounds``) of the
        candidate's dynamics.
    normalize : bool, default=False
        Centre and scale the regression (see :func:`~sindybench._regression.fit_sparse`).

    Returns
    -------
    Candidate
    """
    structure = hidden.structure(params, n_outputs=ys[0].shape[1], n_inputs=Xs[0].shape[1])
    parts = []
    for i, (X, y, n) in enumerate(zip(Xs, ys, n_rows)):
        try:
            parts.append(_record_design(hidden, structure, params, derivative, X, y, n, simulation["dt"]))
        except ValueError as exc:
            if len(ys) == 1:
                raise
            raise ValueError(f"record {i}: {exc}") from exc
    designs = tuple(p[0] for p in parts)
    filters = [d.feature_filter for d in designs]
    if len(filters) == 1 or all(f is None for f in filters):
        feature_filter = filters[0]
    else:
        feature_filter = _RecordFilters(filters, [len(y) for y in ys])
    library, optimizer, coef = fit_regression(
        library, optimizer, np.hstack([np.vstack([p[1] for p in parts]), np.vstack(Xs)]),
        np.vstack([p[2] for p in parts]), rows=np.concatenate([p[3] for p in parts]), feature_filter=feature_filter,
        what="library output Theta([x, u])", normalize=normalize)
    support = hidden.coef_support(getattr(library, "terms_", None), n_outputs=ys[0].shape[1],
                                  n_inputs=Xs[0].shape[1])
    if support is not None:  # terms a row may not have (the strategy's structure): 0
        coef = np.where(support, coef, 0.0)
    return Candidate(params=params, structure=structure, library=library, optimizer=optimizer,
                     differentiation=derivative.differentiation, coef=coef, derivative=derivative, designs=designs,
                     dynamics=structure_dynamics(structure, library, coef, simulation))


def _record_design(hidden, structure, params, derivative, X, y, n_rows, dt):
    """The strategy's design of one record, its checked states and targets, and its regression rows."""
    design = hidden.design(X, y, dt, derivative=derivative, params=params)
    states = check_signal(design.states, "strategy states", n_samples=y.shape[0])
    targets = check_signal(design.targets, "strategy targets", n_samples=y.shape[0])
    if states.shape[1] != structure.n_states or targets.shape[1] != len(structure.learned):
        raise ValueError(
            f"the strategy returned states {states.shape} and targets {targets.shape}; expected "
            f"{structure.n_states} state columns and {len(structure.learned)} target columns."
        )
    rows = np.zeros(y.shape[0], dtype=bool)
    rows[:n_rows] = True
    if design.rows is not None:
        keep = np.zeros(y.shape[0], dtype=bool)
        keep[design.rows] = True
        rows &= keep
    return design, states, targets, rows


class _RecordFilters:
    """``theta -> theta`` with each record's feature filter applied to its own block of rows (None: unfiltered)."""

    def __init__(self, filters, lengths):
        self.filters, self.lengths = filters, lengths

    def __call__(self, theta):
        out, start = [], 0
        for f, n in zip(self.filters, self.lengths):
            block = theta[start : start + n]
            out.append(block if f is None else np.asarray(f(block), dtype=float).reshape(block.shape))
            start += n
        return np.vstack(out)


def candidate_initial_state(hidden, cand, X, y_init, mode="strategy", noise=None):
    """Initial state of a simulation of ``X`` from its first outputs ``y_init``.

    The one place where a simulation of new data is started, in the search
    (validation scores) and in ``predict``: the strategy's first guess
    (:meth:`~sindybench.hidden.HiddenStrategy.initial_state`), refined as its
    :meth:`~sindybench.hidden.HiddenStrategy.initial_fit` says by
    :func:`sindybench.refine.estimate_initial_state`, then set as ``mode``
    says (``"fit"``: the same estimator with every state free; ``"prior"``: that with a prior of where the states of
    ``X`` lie and the outputs' relative noise level ``noise`` (None: ``PRIOR_NOISE``); ``"periodic"``:
    the state reached after two periods of the input, see
    :func:`~sindybench.hidden._refinement.initial_state`).
    """
    dyn = cand.dynamics
    n = min(X.shape[0], y_init.shape[0])
    view = ModelView(rhs=dyn.rhs, simulate=lambda x0, u: dyn.simulate(u, x0, on_divergence="nan"),
                     n_substeps=dyn.n_substeps)
    x0 = hidden.initial_state(X[:n], y_init[:n], dyn.dt, derivative=cand.derivative, params=cand.params,
                              model=view)
    x0 = np.asarray(x0, dtype=float).reshape(-1)
    if x0.shape[0] != dyn.n_states or not np.all(np.isfinite(x0)):
        raise ValueError(f"the strategy's initial state {x0!r} is not {dyn.n_states} finite numbers.")
    fit = hidden.initial_fit(cand.params, n_outputs=y_init.shape[1], n_inputs=X.shape[1])
    return initial_state(mode, fit, dyn, x0, X, y_init[:n], noise)
