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

from .._limits import shown
from .._validation import check_bounds, check_integer, check_positive, check_signal, is_records
from ..dynamics import Dynamics
from ..libraries import evaluate_terms
from ._parametrized import FreeParameters, LeastSquares, ParametrizedDynamics, Shooting, check_settings
from ._problem import _build, _output_jacobian
from ._result import RefinementResult

__all__ = ["estimate_initial_state", "refine_simulation_error", "solve"]

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


def refine_simulation_error(dynamics, u, y, *, x0, free=None, shooting=None, prune=0.0, solver=None):
    """Refine a model's coefficients and initial state by open-loop simulation error.

    Parameters
    ----------
    dynamics : Dynamics
        The starting model; its ``dt``, ``output_index`` and simulation
        settings are those of the refinement. Its coefficients include the
        physical part (``free.physical.coef(free.physical.values)``).
    u : array-like of shape (n_samples, n_inputs), or list
    y : array-like of shape (n_samples, n_outputs), or list of ndarray
        Measured outputs: the states ``dynamics.output_index``. Lists of arrays
        (``u`` and ``y`` alike) are several records of one system: the
        coefficients and physical parameters are shared, each record has its
        own initial state (free as one record's), its residuals are scaled by
        its own output spread, and the records' residuals (and the Jacobian's
        rows) are stacked in record order.
    x0 : array-like of shape (n_states,), or (n_records, n_states)
        Starting initial state (hidden states included); one per record
        with several records.
    free : FreeParameters, optional
        The free coefficient entries (default: the nonzero ones), the
        physical parameters and their map (default: none), the free initial
        states (default: all).
    shooting : Shooting, optional
        Multiple shooting: ``n_segments`` (1 = single shooting; one record
        only) and the weight of the continuity residuals (per state spread)
        relative to the output residuals (per output spread).
    prune : float, default=0.0
        After a refinement, free entries whose term contributes less than
        ``prune`` times the RMS of its state's derivative along the simulated
        trajectory are set to zero and the model is refined again (until
        nothing more is pruned).
    solver : LeastSquares, optional
        Budget of simulations per round, tolerances, bounds of the free
        initial states (within the simulation ``bounds``), the residuals'
        scale (default: each output's standard deviation over its record, 1
        where it is zero) and whether to warn
        (:class:`~sklearn.exceptions.ConvergenceWarning`) when the last round
        stops on its budget (the record says so either way,
        ``budget_exhausted``).

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

    >>> from sindybench.dynamics import Dynamics
    >>> from sindybench.libraries import POW
    >>> terms = [((0, POW, 1, 0),), ((1, POW, 1, 0),)]
    >>> u = np.sign(np.sin(np.arange(400) * 0.05))[:, None]
    >>> y = Dynamics.from_terms(terms, [[-1.0], [2.0]], dt=0.05).simulate(u, [0.5])
    >>> start = Dynamics.from_terms(terms, [[-0.8], [1.7]], dt=0.05)
    >>> res = refine_simulation_error(start, u, y, x0=[0.0])
    >>> np.round(res.coef.ravel(), 6).tolist(), round(float(res.x0[0]), 6), res.jacobian
    ([-1.0, 2.0], 0.5, 'sensitivity')
    >>> res.parameters, res.standard_errors().shape  # exact data: errors ~ 0
    ((('coef', 0, 0), ('coef', 1, 0), ('x0', 0)), (3,))

    Two records, one initial state each:

    >>> y2 = Dynamics.from_terms(terms, [[-1.0], [2.0]], dt=0.05).simulate(-u, [-1.0])
    >>> res = refine_simulation_error(start, [u, -u], [y, y2], x0=[[0.0], [0.0]])
    >>> np.round(res.coef.ravel(), 6).tolist(), np.round(res.initial_states.ravel(), 6).tolist()
    ([-1.0, 2.0], [0.5, -1.0])
    >>> res.parameters[2:]
    (('x0', 0, 0), ('x0', 0, 1))
    """
    return _refine(dynamics, u, y, x0=x0, free=free, shooting=shooting, prune=prune, solver=solver)


def _refine(dynamics, u, y, *, x0, free, shooting, prune, solver, prior=None):
    """:func:`refine_simulation_error`; with ``prior`` ``(centre, root)``, the rows ``root @ (x0 - centre)`` of
    the free initial states are added to the residuals (one record, single shooting)."""
    view = ParametrizedDynamics(_check_dynamics(dynamics), free)
    shooting = Shooting() if shooting is None else check_settings(shooting, Shooting, "shooting", "n_segments=5")
    solver = LeastSquares() if solver is None else check_settings(solver, LeastSquares, "solver", "max_nfev=50")
    us, ys, x0s = _check_records(u, y, x0, dynamics.n_states)
    _check_outputs(ys, dynamics)
    n_segments = check_integer(shooting.n_segments, "n_segments", high=max(1, us[0].shape[0] // 10))
    if n_segments > 1 and len(us) > 1:
        raise ValueError(f"multiple shooting (n_segments={n_segments}) takes one record; got {len(us)} records. "
                         "Expected n_segments=1 with several records.")
    check_positive(shooting.continuity_weight, "continuity_weight")
    prune = check_positive(prune, "prune", strict=False)
    box = _box(dynamics, view.free_x0, solver.x0_bounds)
    output_scale = _check_output_scale(solver.output_scale, len(dynamics.output_index))
    shooting = Shooting(n_segments, shooting.continuity_weight)

    def build(view, x0s, carry):
        problem, xs = _build(view, x0s, us, ys, shooting, box[0], box[1])
        problem.prior = prior
        return problem, xs

    return solve(build, view, x0s, us, ys, bounds=box, prune=prune, solver=solver._replace(output_scale=output_scale))


def _check_dynamics(dynamics):
    if not isinstance(dynamics, Dynamics):
        raise TypeError(f"dynamics must be a sindybench.dynamics.Dynamics (an estimator's dynamics_, or "
                        f"Dynamics.from_terms); got {type(dynamics).__name__}.")
    return dynamics


def _check_outputs(ys, dynamics):
    """The records' ``y`` have one column per output of ``dynamics``."""
    widths = [y_r.shape[1] for y_r in ys]
    if any(w != widths[0] for w in widths):
        raise ValueError(f"the records' y have {widths} columns; expected the same number.")
    if widths[0] != len(dynamics.output_index):
        raise ValueError(f"output_index={tuple(dynamics.output_index)} does not match y with {widths[0]} columns and "
                         f"{dynamics.n_states} states; expected one state index per output column.")


def _box(dynamics, free_x0, x0_bounds):
    """``(lo, hi, x0_lo, x0_hi)``: the simulation bounds and those of the free initial states within them."""
    n_states, bounds = dynamics.n_states, dynamics.bounds
    lo, hi = check_bounds(bounds, n_states)
    x0_lo, x0_hi = check_bounds(x0_bounds, n_states, name="x0_bounds")
    x0_lo, x0_hi = np.maximum(lo, x0_lo), np.minimum(hi, x0_hi)
    if np.any(x0_lo[free_x0] > x0_hi[free_x0]):
        raise ValueError(f"x0_bounds = {x0_bounds!r} leave no initial state within the simulation bounds {bounds!r}.")
    return lo, hi, x0_lo, x0_hi


def _check_output_scale(output_scale, n_outputs):
    if output_scale is None:
        return None
    given = output_scale
    output_scale = np.asarray(output_scale, dtype=float).reshape(-1)
    if output_scale.size == 1:
        output_scale = np.full(n_outputs, output_scale[0])
    if output_scale.size != n_outputs or not np.all(np.isfinite(output_scale) & (output_scale > 0)):
        raise ValueError(f"output_scale = {given!r}; expected one finite number > 0 per output ({n_outputs}).")
    return output_scale


def solve(build, view, x0s, us, ys, *, bounds, prune, solver):
    """The refinement rounds shared by the criteria: least squares, prune, refine again; a :class:`RefinementResult`.

    ``build(view, x0s, carry) -> (problem, trajectories)`` makes one round's
    problem (:class:`~sindybench.refine._problem._Problem` or a criterion's
    subclass) for the :class:`ParametrizedDynamics` ``view`` and the starting
    model's trajectories; ``problem.trajectories(p)`` gives those of ``p``
    (the open-loop simulation, or the predictor's predictions), from which
    the reported costs and the pruned terms' contributions are computed;
    ``carry`` is what the last round hands to the next (``problem.carry(p)``:
    the predictor's gain; None in the first round). ``solver``: a
    :class:`LeastSquares`.
    """
    lo, hi, x0_lo, x0_hi = bounds
    max_nfev = check_integer(solver.max_nfev, "max_nfev")
    output_scale = solver.output_scale
    coef, free, physical = view.coef, view.mask.copy(), view.physical
    terms = view.terms
    pruned, nfev, njev, initial_cost, carry = [], 0, 0, None, None
    while True:
        problem, x = build(view, x0s, carry)
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
                            max_nfev=max_nfev, ftol=solver.ftol, xtol=solver.xtol, gtol=solver.gtol)
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
        view = view.rounded(coef, free, physical)
        logger.debug("pruned %d terms; refining again", int(small.sum()))
    names = () if physical is None else physical.names
    phys = dict(zip(names, (float(v) for v in (physical.values if physical is not None else ()))))
    budget = int(fit.status) == 0
    if budget and solver.warn_budget:
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
        try:
            x0 = np.asarray(x0, dtype=float).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"x0 must be {n_states} real number(s) (the initial state); got {shown(x0)} "
                             f"({exc}).") from None
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


def estimate_initial_state(dynamics, u, y, *, x0, free_x0=None, solver=None, prior=None):
    """Initial state that best simulates the first output samples ``y`` (only ``x0`` free).

    The same least squares as :func:`refine_simulation_error` with the
    coefficients held: exact sensitivities for a compiled ``Dynamics``,
    finite differences on the Python path; the model runs as
    ``dynamics.rhs`` with the ``dynamics``' settings. It is the one
    initial-state estimator of the package: ``HiddenStateSINDy`` refines a
    strategy's first guess with it wherever the strategy's
    :meth:`~sindybench.hidden.HiddenStrategy.initial_fit` asks for it, and
    ``initial_state="fit"`` uses it for every model.

    Parameters
    ----------
    dynamics : Dynamics
    u : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
        The first samples of the outputs ``dynamics.output_index``.
    x0 : array-like of shape (n_states,)
        Starting guess (e.g. a strategy's heuristic).
    free_x0 : sequence of int, optional
        The states that are estimated (default: all).
    solver : LeastSquares, optional
        Default ``LeastSquares(max_nfev=50)``; its ``x0_bounds`` (e.g.
        ``(0.0, None)`` for a level) and ``output_scale`` as in
        :func:`refine_simulation_error`; it never warns on its budget.
    prior : tuple (mean, covariance), optional
        A Gaussian prior of the initial state: ``mean`` of shape
        (n_states,), ``covariance`` of shape (n_states, n_states), in the
        states' units, weighed against the output residuals scaled by
        ``solver.output_scale`` (give the outputs' noise level there). The least
        squares then gives the most probable state: ``sum ||(y_sim - y) /
        output_scale||^2 + (x0 - mean)^T covariance^-1 (x0 - mean)``
        (the free states' block of the covariance; eigenvalues below
        ``1e-12`` times the largest are raised to it). A start window too
        short to observe every state (few samples, many states) is then
        well posed: what the samples do not tell stays near ``mean``. For a
        linear model this is the RTS smoother's first state with no process
        noise (:func:`~sindybench.estimation.smooth_initial_state`).

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
    >>> from sindybench.dynamics import Dynamics
    >>> from sindybench.libraries import POW
    >>> dyn = Dynamics.from_terms([((1, POW, 1, 0),), ((0, POW, 1, 0),)], [[1.0, 0.0], [0.0, -4.0]], dt=0.05,
    ...                           output_index=(0,))  # y'' = -4 y
    >>> y = dyn.simulate(np.zeros((20, 0)), [1.0, 0.5])[:, :1]
    >>> np.round(estimate_initial_state(dyn, np.zeros((20, 0)), y, x0=[0.9, 0.0]), 6).tolist()
    [1.0, 0.5]

    With ``y(0)`` held at 0.9 and the velocity kept within ``[0, 0.2]``, it stops at its bound:

    >>> x0 = estimate_initial_state(dyn, np.zeros((20, 0)), y, x0=[0.9, 0.1], free_x0=[1],
    ...                             solver=LeastSquares(x0_bounds=([None, 0.0], [None, 0.2])))
    >>> np.round(x0, 6).tolist()
    [0.9, 0.2]

    Two samples with noise of 0.01 on the second: the free least squares
    puts the noise into the velocity (0.3 for 0.1); a prior of spread 0.1
    around rest (noise level 0.01, ``output_scale``) keeps it near what is known:

    >>> y2 = dyn.simulate(np.zeros((2, 0)), [1.0, 0.1])[:, :1] + [[0.0], [0.01]]
    >>> np.round(estimate_initial_state(dyn, np.zeros((2, 0)), y2, x0=[1.0, 0.0]), 3).tolist()
    [1.0, 0.3]
    >>> x0 = estimate_initial_state(dyn, np.zeros((2, 0)), y2, x0=[1.0, 0.0], solver=LeastSquares(output_scale=0.01),
    ...                             prior=([1.0, 0.0], np.diag([0.01, 0.01])))
    >>> np.round(x0, 3).tolist()
    [1.007, 0.034]
    """
    solver = LeastSquares(max_nfev=50) if solver is None else check_settings(solver, LeastSquares, "solver",
                                                                             "max_nfev=50")
    free = FreeParameters(coef=np.zeros(np.shape(dynamics.coef), dtype=bool), x0=free_x0)
    if prior is not None:
        n_states = _check_dynamics(dynamics).n_states
        free_idx = np.arange(n_states) if free_x0 is None else np.asarray(free_x0, dtype=np.int64).reshape(-1)
        prior = _prior_rows(prior, n_states, free_idx)
    res = _refine(dynamics, u, y, x0=x0, free=free, shooting=None, prune=0.0,
                  solver=solver._replace(warn_budget=False), prior=prior)
    return res.x0


def _prior_rows(prior, n_states, free):
    """``(centre, root)`` of a prior ``(mean, covariance)`` on the ``free`` states: ``root.T @ root`` inverts the
    covariance's free block (eigenvalues floored at 1e-12 times the largest)."""
    try:
        mean, cov = prior
        mean = np.asarray(mean, dtype=float).reshape(-1)
        cov = np.asarray(cov, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"prior must be a pair (mean, covariance) of real arrays; got {shown(prior)}.") from None
    if mean.shape != (n_states,) or cov.shape != (n_states, n_states):
        raise ValueError(f"prior has a mean of shape {mean.shape} and a covariance of shape {cov.shape}; expected "
                         f"({n_states},) and ({n_states}, {n_states}) (one entry per state).")
    if not (np.all(np.isfinite(mean)) and np.all(np.isfinite(cov))) or not np.allclose(cov, cov.T):
        raise ValueError("prior: expected a finite mean and a finite, symmetric covariance.")
    w, v = np.linalg.eigh(cov[np.ix_(free, free)])
    if w.size and w[-1] <= 0:
        raise ValueError(f"prior: the covariance of the free states has no positive eigenvalue (largest {w[-1]:.3g}); "
                         "expected a positive semi-definite covariance with some spread.")
    w = np.maximum(w, 1e-12 * (w[-1] if w.size else 1.0))
    return mean[free], (v / np.sqrt(w)).T
