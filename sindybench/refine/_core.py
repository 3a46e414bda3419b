"""Output-error refinement: least squares on the open-loop simulation error.

:func:`refine_simulation_error` is the functional core. The model is
``x' = Theta([x, u]) C`` with a coefficient matrix ``C`` made of three parts:
entries freed one by one (the sparse support found by STLS), *physical
parameters* that enter through a map ``values -> C`` (e.g. ``m, c, k`` in
``v' = (u - c v - k y - z) / m``, or the tanks' ``k1, k2``), and constants.
The initial state, hidden states included, may be free too. The residual is
the simulated output minus the measured one, scaled by the output's spread;
:func:`scipy.optimize.least_squares` (trust-region reflective, bounds for the
physical parameters and the states) minimizes it with the exact Jacobian of
:func:`~sindybench.refine.simulate_sensitivity` for compiled models and a
2-point finite-difference Jacobian for Python right-hand sides. The map
``values -> C`` is differentiated by central differences: it is algebraic
(no simulation), so this is exact to rounding.

Multiple shooting (``n_segments > 1``) cuts the record into segments, each
with its own free initial state, and adds the mismatch between a segment's
final state and the next one's initial state to the residual (weighted by
``continuity_weight`` over the state's spread): long or unstable records no
longer make the cost surface a maze of local minima.

Several records (``u`` and ``y`` lists, ``x0`` one row per record) share the
coefficients and physical parameters, each with its own free initial state;
each record's residuals are scaled by its own spread (or by ``output_scale``)
and stacked, and so are the rows of the Jacobian.

A trial step whose simulation diverges gets a large finite residual (the
optimizer rejects it and shrinks its trust region); NaN never reaches the
optimizer. A starting model that diverges is refused with a
:class:`~sindybench.simulate.SimulationError`.
"""

import logging
import warnings

import numpy as np
from scipy.optimize import least_squares
from sklearn.exceptions import ConvergenceWarning

from .._validation import check_bounds, check_integer, check_positive, check_signal, is_records
from ..libraries import evaluate_terms
from ..simulate import TermsRHS
from ._result import RefinementResult
from ._problem import Physical, _build, _output_jacobian

__all__ = ["Physical", "RefinementResult", "estimate_initial_state", "refine_simulation_error", "solve"]

logger = logging.getLogger(__name__)

def _contributions(terms, C, x, u, free, rows):
    """RMS of each free entry's term times its coefficient, relative to its state's derivative RMS.

    ``x`` and ``u``: the trajectory and inputs (of all records, stacked).
    """
    theta = evaluate_terms(terms, np.hstack([x, u]))
    rhs = theta @ C
    scale = np.sqrt(np.mean(rhs[rows] ** 2, axis=0))
    out = []
    for j, i in free:
        part = np.sqrt(np.mean((theta[rows, j] * C[j, i]) ** 2))
        out.append(part / scale[i] if scale[i] > 0 else 0.0)
    return np.array(out)


def refine_simulation_error(terms, coef, u, y, dt, *, x0, output_index=(0,), free=None, physical=None,
                            free_x0=None, make_rhs=None, n_segments=1, continuity_weight=1.0, prune=0.0,
                            n_substeps=1, method="rk4", input_hold="zoh", bounds=None, max_abs=np.inf,
                            max_nfev=100, ftol=1e-8, xtol=1e-8, gtol=1e-8, x0_bounds=None, output_scale=None,
                            warn_budget=True):
    """Refine a model's coefficients and initial state by open-loop simulation error.

    Parameters
    ----------
    terms : sequence of term tuples or None
        Terms of ``Z = [x, u]``, one per row of ``coef``; None for a Python
        right-hand side (then give ``make_rhs`` or ``physical.make_rhs``).
    coef : array-like of shape (n_terms, n_states)
        Starting coefficients, without the physical part (which
        ``physical.coef(values)`` adds).
    u : array-like of shape (n_samples, n_inputs), or list
    y : array-like of shape (n_samples, n_outputs), or list of ndarray
        Measured outputs: the states ``output_index``. Lists of arrays (``u``
        and ``y`` alike) are several records of one system: the coefficients
        and physical parameters are shared, each record has its own initial
        state (free as one record's), its residuals are scaled by its own
        output spread, and the records' residuals (and the Jacobian's rows)
        are stacked in record order.
    dt : float
    x0 : array-like of shape (n_states,), or (n_records, n_states)
        Starting initial state (hidden states included); one per record
        with several records.
    output_index : sequence of int, default=(0,)
    free : array-like of bool of shape (n_terms, n_states), optional
        Entries refined one by one; default: the nonzero entries of ``coef``.
    physical : Physical, optional
        Physical parameters refined through ``physical.coef``.
    free_x0 : sequence of int, optional
        States whose initial value is refined; default: all.
    make_rhs : callable, optional
        ``make_rhs(C) -> f(x, u)`` for Python right-hand sides without
        physical parameters.
    n_segments : int, default=1
        Multiple-shooting segments (1 = single shooting; one record only).
    continuity_weight : float, default=1.0
        Weight of the continuity residuals (per state spread) relative to the
        output residuals (per output spread).
    prune : float, default=0.0
        After a refinement, free entries whose term contributes less than
        ``prune`` times the RMS of its state's derivative along the simulated
        trajectory are set to zero and the model is refined again (until
        nothing more is pruned).
    n_substeps, method, input_hold, bounds, max_abs
        Simulation settings, as in :func:`sindybench.simulate.simulate`.
    max_nfev : int, default=100
        Budget of simulations per refinement round.
    ftol, xtol, gtol : float, default=1e-8
        Stopping tolerances of :func:`scipy.optimize.least_squares`.
    x0_bounds : (lower, upper), optional
        Box bounds of the free initial states (scalars or one per state),
        within the simulation ``bounds``; default: those alone.
    output_scale : array-like of shape (n_outputs,), optional
        Scale of each output's residuals; default: its standard deviation
        over the record (1 where it is zero).
    warn_budget : bool, default=True
        Warn (:class:`~sklearn.exceptions.ConvergenceWarning`) when the last
        round stops on ``max_nfev``; the record says so either way
        (``budget_exhausted``).

    Returns
    -------
    RefinementResult
        With the Jacobian of the output residuals at the optimum, from which
        :meth:`RefinementResult.covariance` gives the covariance of the
        free parameters.

    Raises
    ------
    SimulationError
        When the starting model's simulation diverges.

    Examples
    --------
    Recover ``x' = -a x + b u`` from a biased start:

    >>> from sindybench.libraries import POW
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> terms = [((0, POW, 1, 0),), ((1, POW, 1, 0),)]
    >>> u = np.sign(np.sin(np.arange(400) * 0.05))[:, None]
    >>> y = simulate(TermsRHS([[-1.0], [2.0]], terms, 1), [0.5], u, 0.05)
    >>> res = refine_simulation_error(terms, [[-0.8], [1.7]], u, y, 0.05, x0=[0.0])
    >>> np.round(res.coef.ravel(), 6).tolist(), round(float(res.x0[0]), 6), res.jacobian
    ([-1.0, 2.0], 0.5, 'sensitivity')
    >>> res.parameters, res.standard_errors().shape  # exact data: errors ~ 0
    ((('coef', 0, 0), ('coef', 1, 0), ('x0', 0)), (3,))

    Two records, one initial state each:

    >>> y2 = simulate(TermsRHS([[-1.0], [2.0]], terms, 1), [-1.0], -u, 0.05)
    >>> res = refine_simulation_error(terms, [[-0.8], [1.7]], [u, -u], [y, y2], 0.05, x0=[[0.0], [0.0]])
    >>> np.round(res.coef.ravel(), 6).tolist(), np.round(res.initial_states.ravel(), 6).tolist()
    ([-1.0, 2.0], [0.5, -1.0])
    >>> res.parameters[2:]
    (('x0', 0, 0), ('x0', 0, 1))
    """
    coef = np.asarray(coef, dtype=float)
    if coef.ndim == 1:
        coef = coef.reshape(-1, 1)
    n_states = coef.shape[1]
    us, ys, x0s = _check_records(u, y, x0, n_states)
    y = ys[0]
    output_index = tuple(int(i) for i in output_index)
    if any(y_r.shape[1] != y.shape[1] for y_r in ys):
        raise ValueError(f"the records' y have {[y_r.shape[1] for y_r in ys]} columns; expected the same number.")
    if len(output_index) != y.shape[1] or min(output_index) < 0 or max(output_index) >= n_states:
        raise ValueError(
            f"output_index={output_index} does not match y with {y.shape[1]} columns and {n_states} states; "
            "expected one state index per output column."
        )
    if terms is None and make_rhs is None and (physical is None or physical.make_rhs is None):
        raise ValueError("terms is None; give make_rhs (or physical.make_rhs) for a Python right-hand side.")
    free = (coef != 0) if free is None else np.asarray(free, dtype=bool)
    if free.shape != coef.shape:
        raise ValueError(f"free has shape {free.shape}; expected {coef.shape} (the shape of coef).")
    free_x0 = np.arange(n_states) if free_x0 is None else np.asarray(free_x0, dtype=np.int64).reshape(-1)
    if free_x0.size and (free_x0.min() < 0 or free_x0.max() >= n_states or np.unique(free_x0).size < free_x0.size):
        raise ValueError(f"free_x0 = {free_x0.tolist()}; expected distinct state indices in [0, {n_states - 1}].")
    n_segments = check_integer(n_segments, "n_segments", high=max(1, us[0].shape[0] // 10))
    if n_segments > 1 and len(us) > 1:
        raise ValueError(f"multiple shooting (n_segments={n_segments}) takes one record; got {len(us)} records. "
                         "Expected n_segments=1 with several records.")
    check_positive(continuity_weight, "continuity_weight")
    prune = check_positive(prune, "prune", strict=False)
    max_nfev = check_integer(max_nfev, "max_nfev")
    lo, hi = check_bounds(bounds, n_states)
    x0_lo, x0_hi = check_bounds(x0_bounds, n_states, name="x0_bounds")
    x0_lo, x0_hi = np.maximum(lo, x0_lo), np.minimum(hi, x0_hi)
    if np.any(x0_lo[free_x0] > x0_hi[free_x0]):
        raise ValueError(f"x0_bounds = {x0_bounds!r} leave no initial state within the simulation bounds {bounds!r}.")
    if output_scale is not None:
        given = output_scale
        output_scale = np.asarray(output_scale, dtype=float).reshape(-1)
        if output_scale.size == 1:
            output_scale = np.full(len(output_index), output_scale[0])
        if output_scale.size != len(output_index) or not np.all(np.isfinite(output_scale) & (output_scale > 0)):
            raise ValueError(f"output_scale = {given!r}; expected one finite number > 0 per output "
                             f"({len(output_index)}).")
    settings = dict(n_substeps=n_substeps, method=method, input_hold=input_hold, bounds=bounds, max_abs=max_abs)
    sim = {"settings": settings, "make_rhs": make_rhs}

    def build(coef, free, physical, x0s, carry):
        problem, xs = _build(terms, coef, free, physical, x0s, free_x0, us, ys, dt, output_index, sim, n_segments,
                             continuity_weight, lo, hi)
        return problem, xs

    return solve(build, terms, coef, free, physical, x0s, us, ys, bounds=(lo, hi, x0_lo, x0_hi), prune=prune,
                 output_scale=output_scale, max_nfev=max_nfev, tols=(ftol, xtol, gtol), warn_budget=warn_budget)


def solve(build, terms, coef, free, physical, x0s, us, ys, *, bounds, prune, output_scale, max_nfev, tols,
          warn_budget):
    """The refinement rounds shared by the criteria: least squares, prune, refine again; a :class:`RefinementResult`.

    ``build(coef, free, physical, x0s, carry) -> (problem, trajectories)`` makes one
    round's problem (:class:`~sindybench.refine._problem._Problem` or a
    criterion's subclass) and the starting model's trajectories;
    ``problem.trajectories(p)`` gives those of ``p`` (the open-loop
    simulation, or the predictor's predictions), from which the reported
    costs and the pruned terms' contributions are computed; ``carry`` is
    what the last round hands to the next (``problem.carry(p)``: the
    predictor's gain; None in the first round).
    """
    lo, hi, x0_lo, x0_hi = bounds
    ftol, xtol, gtol = tols
    pruned, nfev, njev, initial_cost, carry = [], 0, 0, None, None
    while True:
        problem, x = build(coef, free, physical, x0s, carry)
        if output_scale is not None:
            problem.scale_outputs(output_scale)
        if initial_cost is None:
            initial_cost = problem.output_cost(x)
        p0 = problem.pack()
        if p0.size == 0:
            raise ValueError("nothing to refine: no free coefficient, physical parameter or initial state.")
        lower, upper = problem.bounds(lo, hi, x0_lo, x0_hi)
        p0 = np.clip(p0, lower, upper)
        jac = problem.jacobian if problem.compiled else "2-point"
        fit = least_squares(problem.residuals, p0, jac=jac, bounds=(lower, upper), method="trf", x_scale="jac",
                            max_nfev=max_nfev, ftol=ftol, xtol=xtol, gtol=gtol)
        nfev, njev = nfev + fit.nfev, njev + (fit.njev or 0)
        p = fit.x
        coef_all = problem.matrix(p)
        x0s, carry = problem.record_starts(p), problem.carry(p)
        if physical is not None:
            physical = physical._replace(values=p[: problem.n_phys])
        coef = coef_all - (physical.coef(physical.values) if physical is not None else 0.0)
        # output error: the returned model run open loop, the trajectory pruning looks at, and its cost (with
        # multiple shooting too, not the segmented cost); prediction error: the predictions
        x = problem.trajectories(p)
        if prune <= 0 or terms is None or not problem.free.size:
            break
        x_all = np.vstack(x)
        rows = np.all(np.isfinite(x_all), axis=1)
        small = _contributions(terms, coef_all, x_all, np.vstack(us), problem.free, rows) < prune
        if not small.any():
            break
        for j, i in problem.free[small]:
            coef[j, i] = 0.0
            free[j, i] = False
            pruned.append((int(j), int(i)))
        logger.debug("pruned %d terms; refining again", int(small.sum()))
    names = () if physical is None else physical.names
    phys = dict(zip(names, (float(v) for v in (physical.values if physical is not None else ()))))
    budget = int(fit.status) == 0
    if budget and warn_budget:
        warnings.warn(f"the refinement stopped on its evaluation budget (max_nfev={max_nfev}) before converging "
                      f"(cost {initial_cost:.4g} -> {problem.output_cost(x):.4g}); raise max_nfev "
                      "(refine__max_nfev) for a converged model.", ConvergenceWarning, stacklevel=2)
    jac, res, columns = _output_jacobian(problem, fit)
    extra = problem.result_fields(fit.x)
    return RefinementResult(coef=coef_all, physical=phys, x0=x0s[0], initial_cost=initial_cost,
                            cost=problem.output_cost(x), nfev=nfev, njev=njev, status=int(fit.status),
                            message=str(fit.message), jacobian="sensitivity" if problem.compiled else "2-point",
                            pruned=pruned, jac=jac, residuals=res, parameters=problem.parameters()[:columns],
                            values=fit.x[:columns].copy(), at_bound=fit.active_mask[:columns] != 0,
                            budget_exhausted=budget, n_outputs=ys[0].shape[1],
                            initial_states=np.array(x0s) if len(x0s) > 1 else None,
                            record_samples=tuple(y_r.shape[0] for y_r in ys) if len(ys) > 1 else None, **extra)


def _check_records(u, y, x0, n_states):
    """``(us, ys, x0s)``: lists with one entry per record (one record when ``y`` is not a list of arrays)."""
    if not is_records(y):
        u = np.ascontiguousarray(check_signal(u, "u"))
        y = check_signal(y, "y", n_samples=u.shape[0])
        x0 = np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape[0] != n_states:
            raise ValueError(f"x0 has {x0.shape[0]} entries; expected {n_states} (one per column of coef).")
        return [u], [y], [x0]
    n = len(y)
    if not isinstance(u, list) or len(u) != n:
        raise ValueError(f"y is a list of {n} records, so u must be a list of {n} input arrays (one per record); "
                         f"got {type(u).__name__}{f' of {len(u)}' if isinstance(u, list) else ''}.")
    try:
        x0s = np.asarray(x0, dtype=float)
    except (TypeError, ValueError):  # ragged rows
        x0s = np.asarray(x0, dtype=object)
    if x0s.shape != (n, n_states):
        raise ValueError(f"x0 has shape {x0s.shape}; expected ({n}, {n_states}): one initial state per record "
                         "(a list of arrays or a 2-D array).")
    for r in np.flatnonzero(~np.all(np.isfinite(x0s), axis=1))[:1]:
        raise ValueError(f"x0[{r}] (the start of record {r}) = {x0s[r].tolist()} contains NaN or inf; expected finite.")
    us, ys = [], []
    for r, (u_r, y_r) in enumerate(zip(u, y)):
        us.append(np.ascontiguousarray(check_signal(u_r, f"u[{r}]")))
        if us[-1].shape[1] != us[0].shape[1]:
            raise ValueError(f"u[{r}] has {us[-1].shape[1]} columns; expected {us[0].shape[1]} as in u[0] (the same "
                             "inputs in every record).")
        ys.append(check_signal(y_r, f"y[{r}]", n_samples=us[-1].shape[0]))
    return us, ys, [x0s[r].copy() for r in range(n)]


def estimate_initial_state(rhs, u, y, dt, *, x0, output_index=(0,), free_x0=None, x0_bounds=None, output_scale=None,
                           n_substeps=1, method="rk4", input_hold="zoh", bounds=None, max_abs=np.inf, max_nfev=50,
                           ftol=1e-8, xtol=1e-8, gtol=1e-8):
    """Initial state that best simulates the first output samples ``y`` (only ``x0`` free).

    The same least squares as :func:`refine_simulation_error` with the
    coefficients held: exact sensitivities for a :class:`TermsRHS`, finite
    differences for a Python right-hand side. It is the one initial-state
    estimator of the package: ``HiddenStateSINDy`` refines a strategy's first
    guess with it wherever the strategy's
    :meth:`~sindybench.hidden.HiddenStrategy.initial_fit` asks for it, and
    ``initial_state="fit"`` uses it for every model.

    Parameters
    ----------
    rhs : TermsRHS or callable
    u : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
    dt : float
    x0 : array-like of shape (n_states,)
        Starting guess (e.g. a strategy's heuristic).
    output_index, free_x0, x0_bounds, output_scale
        As in :func:`refine_simulation_error`: the states that are outputs,
        the states that are estimated (default: all), box bounds of those
        (e.g. ``(0.0, None)`` for a level) and the residuals' scale.
    n_substeps, method, input_hold, bounds, max_abs
        Simulation settings, as in :func:`refine_simulation_error`.
    max_nfev : int, default=50
        Budget of simulations.
    ftol, xtol, gtol : float, default=1e-8
        Stopping tolerances of :func:`scipy.optimize.least_squares`.

    Returns
    -------
    ndarray of shape (n_states,)

    Raises
    ------
    SimulationError
        When the simulation from the guess ``x0`` diverges within the samples.

    Notes
    -----
    The trust region of :func:`scipy.optimize.least_squares` starts at the
    size of the free part of ``x0``: free states that all start near zero
    (e.g. an empty tank on its bound) need tight tolerances (``1e-12``) for
    the steps to grow instead of stopping on ``ftol``.

    Examples
    --------
    >>> from sindybench.libraries import POW
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> rhs = TermsRHS.from_equations([{((1, POW, 1, 0),): 1.0}, {((0, POW, 1, 0),): -4.0}])  # y'' = -4 y
    >>> y = simulate(rhs, [1.0, 0.5], np.zeros((20, 0)), 0.05)[:, :1]
    >>> np.round(estimate_initial_state(rhs, np.zeros((20, 0)), y, 0.05, x0=[0.9, 0.0]), 6).tolist()
    [1.0, 0.5]

    With ``y(0)`` held at 0.9 and the velocity kept within ``[0, 0.2]``, it stops at its bound:

    >>> x0 = estimate_initial_state(rhs, np.zeros((20, 0)), y, 0.05, x0=[0.9, 0.1], free_x0=[1],
    ...                             x0_bounds=([None, 0.0], [None, 0.2]))
    >>> np.round(x0, 6).tolist()
    [0.9, 0.2]
    """
    if isinstance(rhs, TermsRHS):
        terms, coef, make = rhs.terms, rhs.coef, None
        free = np.zeros_like(coef, dtype=bool)
    else:
        n = np.asarray(x0).reshape(-1).shape[0]
        terms, coef, make = None, np.zeros((0, n)), (lambda C: rhs)
        free = np.zeros((0, n), dtype=bool)
    res = refine_simulation_error(terms, coef, u, y, dt, x0=x0, output_index=output_index, free=free,
                                  free_x0=free_x0, make_rhs=make, n_substeps=n_substeps, method=method,
                                  input_hold=input_hold, bounds=bounds, max_abs=max_abs, max_nfev=max_nfev,
                                  ftol=ftol, xtol=xtol, gtol=gtol, x0_bounds=x0_bounds, output_scale=output_scale,
                                  warn_budget=False)
    return res.x0
