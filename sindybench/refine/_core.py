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

A trial step whose simulation diverges gets a large finite residual (the
optimizer rejects it and shrinks its trust region); NaN never reaches the
optimizer. A starting model that diverges is refused with a
:class:`~sindybench.simulate.SimulationError`.
"""

import copy
import logging
import warnings
from typing import Callable, NamedTuple

import numpy as np
from scipy.optimize import least_squares
from sklearn.exceptions import ConvergenceWarning

from .._validation import check_bounds, check_integer, check_positive, check_signal, is_records
from ..libraries import evaluate_terms
from ..simulate import SimulationError, TermsRHS, simulate
from ._result import RefinementResult
from ._sensitivity import simulate_sensitivity

__all__ = ["Physical", "RefinementResult", "estimate_initial_state", "refine_simulation_error"]

logger = logging.getLogger(__name__)

_DIVERGED = 1e3  # residual (in output spreads) of a diverged sample


class Physical(NamedTuple):
    """Physical parameters entering the coefficient matrix through a map.

    Attributes
    ----------
    names : tuple of str
    values : ndarray of shape (n_physical,)
        Starting values.
    lower, upper : ndarray of shape (n_physical,)
        Bounds of the refined values.
    coef : callable
        ``coef(values) -> ndarray (n_terms, n_states)``, added to the constant
        coefficients.
    make_rhs : callable or None
        For Python-path models: ``make_rhs(C, values) -> f(x, u)``.
    """

    names: tuple
    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    coef: Callable
    make_rhs: Callable = None


class _Problem:
    """Parameter vector ``p = (physical, free coefficients, free x0 of each record, segment starts)``.

    ``x0s``, ``us`` and ``ys`` hold one entry per record; each record's
    residuals are scaled by its own output spread and the records' residuals
    are stacked in record order. Multiple shooting (``segments``) takes one
    record.
    """

    def __init__(self, terms, coef, free, physical, x0s, free_x0, us, ys, dt, output_index, sim, segments):
        self.terms, self.coef, self.physical = terms, coef, physical
        self.free = np.argwhere(free)  # (n_free, 2) of (term, state)
        self.x0s, self.free_x0 = x0s, np.asarray(free_x0, dtype=np.int64)
        self.us, self.ys, self.dt, self.sim = us, ys, dt, sim
        self.x0, self.u, self.y = x0s[0], us[0], ys[0]  # the first record (multiple shooting's one record)
        self.n_records = len(us)
        self.oidx = np.asarray(output_index, dtype=np.int64)
        self.n_states = coef.shape[1]
        self.n_phys = 0 if physical is None else len(physical.names)
        self.n_model = self.n_phys + len(self.free)
        self.n_x0 = self.free_x0.size * self.n_records
        self.segments = segments
        self.y_scales = []
        for y_r in ys:
            spread = np.std(y_r, axis=0)
            self.y_scales.append(np.where(spread > 0, spread, 1.0))
        self.y_scale = self.y_scales[0]
        self.n_res = sum(y_r.size for y_r in ys)
        # multiple shooting: the later segments' free initial states and the continuity weights (see _build)
        self.x_segments, self.weight = [], np.ones(self.n_states)
        self.compiled = terms is not None and (physical is None or physical.make_rhs is None)

    # ------------------------------------------------------------- vectors
    def parameters(self):
        """Descriptions of the entries of ``p``: physical, coefficient, initial state, segment starts."""
        out = [] if self.physical is None else [("physical", str(n)) for n in self.physical.names]
        out += [("coef", int(j), int(i)) for j, i in self.free]
        if self.n_records == 1:
            out += [("x0", int(i)) for i in self.free_x0]
        else:  # ("x0", state, record)
            out += [("x0", int(i), r) for r in range(self.n_records) for i in self.free_x0]
        out += [("segment", s + 1, i) for s in range(len(self.x_segments)) for i in range(self.n_states)]
        return tuple(out)

    def pack(self):
        parts = [] if self.physical is None else [np.asarray(self.physical.values, dtype=float)]
        parts.append(self.coef[self.free[:, 0], self.free[:, 1]])
        parts.extend(x0[self.free_x0] for x0 in self.x0s)
        parts.extend(self.x_segments)
        return np.concatenate(parts)

    def bounds(self, lo, hi):
        n_free = len(self.free)
        lower = [np.full(n_free, -np.inf)] + [lo[self.free_x0]] * self.n_records + [lo] * len(self.x_segments)
        upper = [np.full(n_free, np.inf)] + [hi[self.free_x0]] * self.n_records + [hi] * len(self.x_segments)
        if self.physical is not None:
            lower.insert(0, np.asarray(self.physical.lower, dtype=float))
            upper.insert(0, np.asarray(self.physical.upper, dtype=float))
        return np.concatenate(lower), np.concatenate(upper)

    def matrix(self, p):
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

    def record_starts(self, p):
        """Initial state of each record."""
        out, k = [], self.n_model
        for x0 in self.x0s:
            x0 = x0.copy()
            x0[self.free_x0] = p[k : k + self.free_x0.size]
            out.append(x0)
            k += self.free_x0.size
        return out

    def starts(self, p):
        """Initial state of each segment (of the first record)."""
        n0 = self.n_model + self.n_x0
        out = [self.record_starts(p)[0]]
        for s in range(len(self.x_segments)):
            out.append(p[n0 + s * self.n_states : n0 + (s + 1) * self.n_states])
        return out

    def rhs(self, p):
        C = self.matrix(p)
        if self.compiled:
            return TermsRHS(C, self.terms, self.n_states)
        return self.physical.make_rhs(C, p[: self.n_phys]) if self.physical is not None else self.sim["make_rhs"](C)

    # ----------------------------------------------------------- residuals
    def open_loop(self, p):
        """Each whole record simulated from its start (NaN after a divergence); a list."""
        rhs = self.rhs(p)
        with np.errstate(all="ignore"):
            return [simulate(rhs, x0, u, self.dt, on_divergence="nan", **self.sim["settings"])
                    for x0, u in zip(self.record_starts(p), self.us)]

    def output_cost(self, xs):
        """Half the mean squared scaled output error of the trajectories ``xs`` (diverged samples penalized)."""
        r = np.concatenate([((x[:, self.oidx] - y) / scale).ravel()
                            for x, y, scale in zip(xs, self.ys, self.y_scales)]) / np.sqrt(self.n_res)
        r = np.where(np.isfinite(r), r, _DIVERGED / np.sqrt(self.n_res))
        return 0.5 * float(r @ r)

    def _segment_residuals(self, x, seg, x_next):
        a, b = seg
        r = ((x[: b - a, self.oidx] - self.y[a:b]) / self.y_scale).ravel()
        c = (x[-1] - x_next) * self.weight if x_next is not None else np.zeros(0)
        return r, c

    def residuals(self, p):
        if self.n_records > 1:
            out = np.concatenate([((x[:, self.oidx] - y) / scale).ravel()
                                  for x, y, scale in zip(self.open_loop(p), self.ys, self.y_scales)])
            out = out / np.sqrt(self.n_res)
            return np.where(np.isfinite(out), out, _DIVERGED / np.sqrt(self.n_res))
        rhs = self.rhs(p)
        starts = self.starts(p)
        res, cont = [], []
        for s, (a, b) in enumerate(self.segments):
            last = b + 1 if s + 1 < len(self.segments) else b
            with np.errstate(all="ignore"):
                x = simulate(rhs, starts[s], self.u[a:last], self.dt, on_divergence="nan", **self.sim["settings"])
            r, c = self._segment_residuals(x, (a, b), starts[s + 1] if s + 1 < len(self.segments) else None)
            res.append(r)
            cont.append(c)
        out = np.concatenate(res + cont) / np.sqrt(self.n_res)
        return np.where(np.isfinite(out), out, _DIVERGED / np.sqrt(self.n_res))

    def jacobian(self, p):
        """Exact Jacobian from the forward sensitivities (compiled models)."""
        if self.n_records > 1:
            return self._records_jacobian(p)
        rhs, D, starts = self.rhs(p), self.directions(p), self.starts(p)
        n, n_out = self.n_states, self.oidx.size
        n_seg = len(self.segments)
        q = p.size
        J_out = np.zeros((self.n_res, q))
        J_cont = np.zeros(((n_seg - 1) * n, q))
        n0 = self.n_model
        for s, (a, b) in enumerate(self.segments):
            last = b + 1 if s + 1 < n_seg else b
            free = self.free_x0 if s == 0 else np.arange(n)
            x, S, S_end = simulate_sensitivity(rhs, starts[s], self.u[a:last], self.dt, directions=D, free_x0=free,
                                               output_index=self.oidx, on_divergence="nan", **self.sim["settings"])
            if not np.all(np.isfinite(S)):
                raise SimulationError("the sensitivities of an accepted refinement step are not finite.", step=-1)
            cols = np.r_[np.arange(self.n_model),
                         (n0 + np.arange(self.free_x0.size)) if s == 0
                         else n0 + self.free_x0.size + (s - 1) * n + np.arange(n)]
            rows = slice(a * n_out, b * n_out)
            J_out[rows, cols] = (S[: b - a] / self.y_scale[None, :, None]).reshape((b - a) * n_out, -1)
            if s + 1 < n_seg:
                crow = slice(s * n, (s + 1) * n)
                J_cont[crow, cols] = S_end * self.weight[:, None]
                nxt = n0 + self.free_x0.size + s * n
                J_cont[crow, nxt : nxt + n] -= np.diag(self.weight)
        return np.vstack([J_out, J_cont]) / np.sqrt(self.n_res)

    def _records_jacobian(self, p):
        """The output rows of every record, stacked; a record's rows see its own initial state only."""
        rhs, D = self.rhs(p), self.directions(p)
        J = np.zeros((self.n_res, p.size))
        row, n_free = 0, self.free_x0.size
        for r, (x0, u, scale) in enumerate(zip(self.record_starts(p), self.us, self.y_scales)):
            _, S, _ = simulate_sensitivity(rhs, x0, u, self.dt, directions=D, free_x0=self.free_x0,
                                           output_index=self.oidx, on_divergence="nan", **self.sim["settings"])
            if not np.all(np.isfinite(S)):
                raise SimulationError(f"the sensitivities of an accepted refinement step are not finite "
                                      f"(record {r}).", step=-1)
            cols = np.r_[np.arange(self.n_model), self.n_model + r * n_free + np.arange(n_free)]
            m = S.shape[0] * S.shape[1]
            J[row : row + m, cols] = (S / scale[None, :, None]).reshape(m, -1)
            row += m
        return J / np.sqrt(self.n_res)


def _segments(n, n_segments):
    edges = np.linspace(0, n, n_segments + 1).round().astype(int)
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


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
                            max_nfev=100, ftol=1e-8, xtol=1e-8, warn_budget=True):
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
    ftol, xtol : float, default=1e-8
        Stopping tolerances of :func:`scipy.optimize.least_squares`.
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
    settings = dict(n_substeps=n_substeps, method=method, input_hold=input_hold, bounds=bounds, max_abs=max_abs)
    sim = {"settings": settings, "make_rhs": make_rhs}

    pruned, nfev, njev, initial_cost = [], 0, 0, None
    while True:
        problem, x = _build(terms, coef, free, physical, x0s, free_x0, us, ys, dt, output_index, sim, n_segments,
                            continuity_weight, lo, hi)
        if initial_cost is None:
            initial_cost = problem.output_cost(x)
        p0 = problem.pack()
        if p0.size == 0:
            raise ValueError("nothing to refine: no free coefficient, physical parameter or initial state.")
        lower, upper = problem.bounds(lo, hi)
        p0 = np.clip(p0, lower, upper)
        jac = problem.jacobian if problem.compiled else "2-point"
        fit = least_squares(problem.residuals, p0, jac=jac, bounds=(lower, upper), method="trf", x_scale="jac",
                            max_nfev=max_nfev, ftol=ftol, xtol=xtol)
        nfev, njev = nfev + fit.nfev, njev + (fit.njev or 0)
        p = fit.x
        coef_all = problem.matrix(p)
        x0s = problem.record_starts(p)
        if physical is not None:
            physical = physical._replace(values=p[: problem.n_phys])
        coef = coef_all - (physical.coef(physical.values) if physical is not None else 0.0)
        # the returned model run open loop: the trajectory pruning looks at, and its cost (with multiple
        # shooting too, not the segmented cost)
        x = problem.open_loop(p)
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
    return RefinementResult(coef=coef_all, physical=phys, x0=x0s[0], initial_cost=initial_cost,
                            cost=problem.output_cost(x), nfev=nfev, njev=njev, status=int(fit.status),
                            message=str(fit.message), jacobian="sensitivity" if problem.compiled else "2-point",
                            pruned=pruned, jac=jac, residuals=res, parameters=problem.parameters()[:columns],
                            values=fit.x[:columns].copy(), at_bound=fit.active_mask[:columns] != 0,
                            budget_exhausted=budget, n_outputs=len(output_index),
                            initial_states=np.array(x0s) if len(x0s) > 1 else None,
                            record_samples=tuple(y_r.shape[0] for y_r in ys) if len(ys) > 1 else None)


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


def _output_jacobian(problem, fit):
    """Jacobian and residuals of the output residuals at the optimum, and the number of its columns.

    Single shooting: those of the optimizer. Multiple shooting: the returned
    model run open loop (one simulation with sensitivities, or one per
    parameter by forward differences on the Python path); the later
    segments' starts and the continuity residuals drop out.
    """
    columns = problem.n_model + problem.n_x0
    if len(problem.segments) == 1:
        return fit.jac, fit.fun[: problem.n_res], columns
    single = copy.copy(problem)
    single.segments, single.x_segments = [(0, problem.u.shape[0])], []
    p = fit.x[:columns]
    r = single.residuals(p)
    if single.compiled:
        return single.jacobian(p), r, columns
    J = np.empty((r.size, columns))
    for k in range(columns):
        step = np.sqrt(np.finfo(float).eps) * max(1.0, abs(p[k]))
        q = p.copy()
        q[k] += step
        J[:, k] = (single.residuals(q) - r) / step
    return J, r, columns


def _build(terms, coef, free, physical, x0s, free_x0, us, ys, dt, output_index, sim, n_segments, continuity_weight,
           lo, hi):
    """The problem of one refinement round and the starting model's open-loop trajectories (one per record).

    That simulation checks the start, scales the continuity residuals by
    the states' spread and starts the later segments of multiple shooting.
    """
    problem = _Problem(terms, coef, free, physical, x0s, free_x0, us, ys, dt, output_index, sim,
                       _segments(us[0].shape[0], n_segments))
    xs = problem.open_loop(problem.pack())
    for r, x_r in enumerate(xs):
        finite = np.all(np.isfinite(x_r), axis=1)
        if not finite.all():
            where = "the record" if len(xs) == 1 else f"record {r}"
            what = (f"cannot start multiple shooting: the starting model diverges on {where}." if n_segments > 1 else
                    f"cannot refine: the starting model's simulation diverges on {where}; "
                    "expected a model that simulates the training data.")
            raise SimulationError(what, step=int(np.argmin(finite)))
    x = xs[0]
    spread = np.std(x, axis=0)
    problem.weight = continuity_weight / np.where(spread > 0, spread, 1.0)
    problem.x_segments = [np.clip(x[a], lo, hi) for a, _ in problem.segments[1:]]
    return problem, xs


def estimate_initial_state(rhs, u, y, dt, *, x0, output_index=(0,), free_x0=None, n_substeps=1, method="rk4",
                           input_hold="zoh", bounds=None, max_abs=np.inf, max_nfev=50):
    """Initial state that best simulates the first output samples ``y`` (only ``x0`` free).

    The same least squares as :func:`refine_simulation_error` with the
    coefficients held: exact sensitivities for a :class:`TermsRHS`, finite
    differences for a Python right-hand side.

    Parameters
    ----------
    rhs : TermsRHS or callable
    u : array-like of shape (n_samples, n_inputs)
    y : array-like of shape (n_samples, n_outputs)
    dt : float
    x0 : array-like of shape (n_states,)
        Starting guess (e.g. a strategy's heuristic).
    output_index, free_x0, n_substeps, method, input_hold, bounds, max_abs, max_nfev
        As in :func:`refine_simulation_error`.

    Returns
    -------
    ndarray of shape (n_states,)

    Examples
    --------
    >>> from sindybench.libraries import POW
    >>> from sindybench.simulate import TermsRHS, simulate
    >>> rhs = TermsRHS.from_equations([{((1, POW, 1, 0),): 1.0}, {((0, POW, 1, 0),): -4.0}])  # y'' = -4 y
    >>> y = simulate(rhs, [1.0, 0.5], np.zeros((20, 0)), 0.05)[:, :1]
    >>> np.round(estimate_initial_state(rhs, np.zeros((20, 0)), y, 0.05, x0=[0.9, 0.0]), 6).tolist()
    [1.0, 0.5]
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
                                  warn_budget=False)
    return res.x0
