"""The least-squares problem of one refinement round: parameters, residuals, exact Jacobian.

:class:`_Problem` packs the free coefficients, the physical parameters and the
free initial states (one per record, one per segment of multiple shooting) into
one vector, simulates the records and returns the scaled output residuals and
their Jacobian. :func:`~sindybench.refine.refine_simulation_error` drives it.
"""

import copy

import numpy as np

from ..simulate import SimulationError, simulate
from ._sensitivity import simulate_sensitivity

__all__ = []

_DIVERGED = 1e3  # residual (in output spreads) of a diverged sample


class _Problem:
    """Parameter vector ``p = (physical, free coefficients, free x0 of each record, segment starts)``.

    ``x0s``, ``us`` and ``ys`` hold one entry per record; each record's
    residuals are scaled by its own output spread and the records' residuals
    are stacked in record order. Multiple shooting (``segments``) takes one
    record.
    """

    def __init__(self, view, x0s, us, ys, segments):
        self.view, self.physical, self.free, self.free_x0 = view, view.physical, view.free, view.free_x0
        dyn = view.dynamics
        self.x0s, self.us, self.ys, self.dt, self.settings = x0s, us, ys, dyn.dt, dyn.settings
        self.x0, self.u, self.y = x0s[0], us[0], ys[0]  # the first record (multiple shooting's one record)
        self.n_records = len(us)
        self.oidx = np.asarray(dyn.output_index, dtype=np.int64)
        self.n_states = dyn.n_states
        self.n_phys, self.n_model = view.n_phys, view.n_model
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
        self.compiled = view.compiled
        self.prior = None  # (centre, root): the rows root @ (free x0 - centre) appended to the residuals (one record)
        self._rhs_key = self._rhs = None
        self._open_loop_key = self._open_loop = None

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
        parts = [self.view.start()]
        parts.extend(x0[self.free_x0] for x0 in self.x0s)
        parts.extend(self.x_segments)
        return np.concatenate(parts)

    def scale_outputs(self, scale):
        """Scale every record's residuals by ``scale`` (one number per output) instead of its spread."""
        self.y_scales = [scale] * self.n_records
        self.y_scale = scale

    def bounds(self, lo, hi, x0_lo=None, x0_hi=None):
        """Lower and upper bounds of ``p``; the initial states of every record within ``x0_lo``, ``x0_hi``."""
        x0_lo = lo if x0_lo is None else x0_lo
        x0_hi = hi if x0_hi is None else x0_hi
        m_lo, m_hi = self.view.model_bounds()
        lower = [m_lo] + [x0_lo[self.free_x0]] * self.n_records + [lo] * len(self.x_segments)
        upper = [m_hi] + [x0_hi[self.free_x0]] * self.n_records + [hi] * len(self.x_segments)
        return np.concatenate(lower), np.concatenate(upper)

    def matrix(self, p):
        return self.view.matrix(p)

    def directions(self, p):
        """dC/dp for the model parameters (see :meth:`ParametrizedDynamics.directions`)."""
        return self.view.directions(p)

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
        """The right-hand side for the model part of ``p``; the last one is reused while that part is unchanged."""
        key = p[: self.n_model].tobytes()
        if self._rhs_key != key:
            self._rhs_key, self._rhs = key, self.view.rhs(p)
        return self._rhs

    # ----------------------------------------------------------- residuals
    def open_loop(self, p):
        """Each whole record simulated from its start (NaN after a divergence); a list.

        The last one is reused while the model and initial states in ``p`` are
        unchanged: the optimizer's first residuals are those of the start
        :func:`_build` simulated, its last often those of the returned model,
        and :func:`_output_jacobian` runs that model again without the
        segment starts.
        """
        key = p[: self.n_model + self.n_x0].tobytes()
        if self._open_loop_key != key:
            rhs = self.rhs(p)
            with np.errstate(all="ignore"):
                xs = [simulate(rhs, x0, u, self.dt, on_divergence="nan", **self.settings)
                      for x0, u in zip(self.record_starts(p), self.us)]
            self._open_loop_key, self._open_loop = key, xs
        return self._open_loop

    def trajectories(self, p):
        """The trajectories the criterion reports on and pruning looks at: the records run open loop."""
        return self.open_loop(p)

    def n_columns(self):
        """Parameters of the returned model (the leading columns of ``p``): model and initial states."""
        return self.n_model + self.n_x0

    def carry(self, p):
        """What the next refinement round needs from this one's optimum beyond the model (nothing here)."""
        return None

    def result_fields(self, p):
        """Criterion-specific fields of the :class:`RefinementResult` (none for output error)."""
        return {}

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
        if len(self.segments) == 1:  # single shooting: the records open loop
            out = np.concatenate([((x[:, self.oidx] - y) / scale).ravel()
                                  for x, y, scale in zip(self.open_loop(p), self.ys, self.y_scales)])
            out = out / np.sqrt(self.n_res)
            return self._with_prior(p, np.where(np.isfinite(out), out, _DIVERGED / np.sqrt(self.n_res)))
        rhs = self.rhs(p)
        starts = self.starts(p)
        res, cont = [], []
        for s, (a, b) in enumerate(self.segments):
            last = b + 1 if s + 1 < len(self.segments) else b
            with np.errstate(all="ignore"):
                x = simulate(rhs, starts[s], self.u[a:last], self.dt, on_divergence="nan", **self.settings)
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
                                               output_index=self.oidx, on_divergence="nan", **self.settings)
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
        J = np.vstack([J_out, J_cont]) / np.sqrt(self.n_res)
        if self.prior is None:
            return J
        rows = np.zeros((self.prior[1].shape[0], q))
        rows[:, n0 : n0 + self.free_x0.size] = self.prior[1] / np.sqrt(self.n_res)
        return np.vstack([J, rows])

    def _with_prior(self, p, out):
        """The residuals ``out`` and, with a prior, its rows (per ``sqrt(n_res)``, as the output residuals)."""
        if self.prior is None:
            return out
        centre, root = self.prior
        x0 = p[self.n_model : self.n_model + self.free_x0.size]
        return np.r_[out, root @ (x0 - centre) / np.sqrt(self.n_res)]

    def _records_jacobian(self, p):
        """The output rows of every record, stacked; a record's rows see its own initial state only."""
        rhs, D = self.rhs(p), self.directions(p)
        J = np.zeros((self.n_res, p.size))
        row, n_free = 0, self.free_x0.size
        for r, (x0, u, scale) in enumerate(zip(self.record_starts(p), self.us, self.y_scales)):
            _, S, _ = simulate_sensitivity(rhs, x0, u, self.dt, directions=D, free_x0=self.free_x0,
                                           output_index=self.oidx, on_divergence="nan", **self.settings)
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


def _output_jacobian(problem, fit):
    """Jacobian and residuals of the output residuals at the optimum, and the number of its columns.

    Single shooting: those of the optimizer. Multiple shooting: the returned
    model run open loop (one simulation with sensitivities, or one per
    parameter by forward differences on the Python path); the later
    segments' starts and the continuity residuals drop out.
    """
    columns = problem.n_columns()
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


def _build(view, x0s, us, ys, shooting, lo, hi):
    """The problem of one refinement round and the starting model's open-loop trajectories (one per record).

    That simulation checks the start, scales the continuity residuals by
    the states' spread and starts the later segments of multiple shooting.
    With multiple shooting, a start whose simulation of the record diverges
    gets segments short enough to simulate (:func:`_adaptive_segments`).
    """
    n_segments, continuity_weight = shooting
    problem = _Problem(view, x0s, us, ys, _segments(us[0].shape[0], n_segments))
    xs = problem.open_loop(problem.pack())
    for r, x_r in enumerate(xs):
        finite = np.all(np.isfinite(x_r), axis=1)
        if not finite.all() and n_segments == 1:
            where = "the record" if len(xs) == 1 else f"record {r}"
            raise SimulationError(f"cannot refine: the starting model's simulation diverges on {where}; expected a "
                                  "model that simulates the training data (or multiple shooting, n_segments > 1, "
                                  "or PredictionErrorRefinement).", step=int(np.argmin(finite)))
    x = xs[0]
    if np.all(np.isfinite(x)):
        problem.x_segments = [np.clip(x[a], lo, hi) for a, _ in problem.segments[1:]]
    else:
        problem.segments, problem.x_segments, x = _adaptive_segments(problem, problem.pack(), lo, hi)
    spread = np.std(x, axis=0)
    problem.weight = continuity_weight / np.where(spread > 0, spread, 1.0)
    return problem, xs


def _adaptive_segments(problem, p, lo, hi):
    """Segments of the record short enough that the starting model simulates each one; their starts.

    From each segment's start, the model runs to the next of the planned
    edges; where its output leaves the measured one by more than the
    output's spread (or diverges), the segment ends there instead, and the
    next one starts from the state reached there with its measured outputs
    put back to the measurements.
    Returns ``(segments, later starts, the segments' trajectory)``.
    """
    u, y, oidx = problem.u, problem.y, problem.oidx
    n = u.shape[0]
    planned = [b for _, b in problem.segments]
    rhs, start = problem.rhs(p), problem.record_starts(p)[0]
    segments, starts, pieces, a = [], [], [], 0
    while a < n:
        b = next(e for e in planned if e > a)
        with np.errstate(all="ignore"):
            x = simulate(rhs, start, u[a : b + 1] if b < n else u[a:b], problem.dt, on_divergence="nan",
                         **problem.settings)
        with np.errstate(invalid="ignore"):
            far = ~(np.abs(x[:, oidx] - y[a : a + x.shape[0]]) <= problem.y_scale).all(axis=1)
        if far.any():  # the run leaves the record (or diverges): end the segment where it does
            if not np.all(np.isfinite(x[: min(2, x.shape[0])])):
                raise SimulationError(f"cannot start multiple shooting: the starting model diverges within one "
                                      f"sample of sample {a}, even from the measured outputs.", step=a + 1)
            b = min(b, a + max(1, int(np.argmax(far))))
            if b not in planned:
                planned = sorted(planned + [b])
        segments.append((a, b))
        pieces.append(x[: b - a])
        if b < n:
            nxt = x[b - a].copy()
            nxt[oidx] = y[b]
            starts.append(np.clip(nxt, lo, hi))
            start = starts[-1]
        a = b
    max_segments = max(1, n // 10)
    if len(segments) > max_segments:
        raise SimulationError(f"cannot start multiple shooting: the starting model needs {len(segments)} segments "
                              f"(more than {max_segments}, one per 10 samples) to simulate the record; expected a "
                              "model that simulates at least 10 samples at a time (or PredictionErrorRefinement).",
                              step=segments[-1][0])
    return segments, starts, np.vstack(pieces)
