"""Prediction-error refinement: least squares on the errors of a predictor that corrects the state from the outputs.

:func:`refine_prediction_error` is the functional core. It refines the same
free parameters as :func:`~sindybench.refine.refine_simulation_error`
(coefficients, physical parameters through their map, initial states) and,
by default, the gain ``K`` of the predictor in innovation form
(:mod:`sindybench.refine._predictor`)::

    x[t+1|t] = step(x[t|t-1] + K (y[t] - H x[t|t-1]), u[t])

with the exact Jacobian of the discrete predictor (the step's forward
sensitivities plus the correction's terms, compiled with numba). Because the
state is pulled towards the measurements at every sample, the criterion is
defined for models whose open-loop simulation diverges (an unstable plant in
closed loop, an integrator, a poor start), and its cost surface has none of
the long-record maze of output error. ``horizon = k`` fits the ``k``-step
predictions instead (``k`` at least the record's length is output error).

Why a constant gain and not the extended Kalman filter: the EKF's gain
depends on the parameters through the Riccati recursion, whose exact
gradient needs the second derivatives of the step; measured by
``benchmarks/bench_pem.py`` (5,000 samples, 7 coefficients), a least-squares
fit through the package's EKF with finite-difference gradients took 1.16 s
and ended 6.9 % from the truth, this predictor with exact sensitivities
0.28 s and 1.7 %. With a free constant gain the predictor family contains the
steady-state Kalman predictor of every model (for noise statistics that do
not vary in time), so the optimum is the same where the EKF's gain has
settled; the start of the gain is the steady-state Kalman gain of the
starting model linearized at its first state, for given or default noise
covariances.
"""

import numbers

import numpy as np
from scipy.linalg import solve_discrete_are

from .._validation import check_positive
from ..dynamics import SimulationError, step_jacobian
from ._core import _box, _check_dynamics, _check_outputs, _check_records, solve
from ._parametrized import LeastSquares, ParametrizedDynamics, check_settings
from ._predictor import predict_sensitivity
from ._problem import _DIVERGED, _Problem

__all__ = ["refine_prediction_error", "starting_gain"]


def _check_noise(noise, n_states, n_outputs):
    """``(Q, R)`` as arrays: Q positive semidefinite (n_states square), R positive definite (n_outputs square)."""
    if not isinstance(noise, (tuple, list)) or len(noise) != 2:
        raise ValueError(f"noise must be a pair (Q, R) of covariance matrices or None; got {noise!r}.")
    out = []
    for name, value, size, strict in (("Q", noise[0], n_states, False), ("R", noise[1], n_outputs, True)):
        a = np.asarray(value, dtype=float)
        if a.ndim == 1:
            a = np.diag(a)
        if a.shape != (size, size) or not np.all(np.isfinite(a)):
            raise ValueError(f"noise {name} has shape {a.shape}; expected a finite ({size}, {size}) matrix "
                             "(or its diagonal).")
        if not np.allclose(a, a.T, rtol=1e-10, atol=1e-14 * max(1.0, np.abs(a).max())):
            raise ValueError(f"noise {name} is not symmetric; expected a covariance matrix.")
        low = float(np.linalg.eigvalsh(a).min())
        tol = 1e-12 * max(1.0, np.abs(a).max())
        if low < -tol or (strict and low <= tol):
            raise ValueError(f"noise {name} has the eigenvalue {low:.3g}; expected a positive "
                             f"{'definite' if strict else 'semidefinite'} matrix.")
        out.append(a)
    return out


def starting_gain(rhs, x0, u, y, dt, *, output_index, noise=None, settings=None):
    """The start of the observer gain: a steady-state Kalman gain of the model linearized at ``x0``.

    ``noise = (Q, R)``: the process noise of one sample's step and the
    measurement noise; that gain is the start. Without ``noise``, ``R`` is
    (10 % of each output's spread)^2 and ``Q`` (1 %, 10 % or 100 % of each
    state's spread)^2 per sample (the spreads read from the predictor that
    resets the measured states to the measurements), and the start is the
    one of those three gains and that resetting gain (1 on the measured
    states, 0 elsewhere) whose one-step predictions of ``y`` are best: a
    weak gain lets a poor starting model drift away, a strong one follows
    the noise. A linearization without a stabilizing Riccati solution skips
    its gains.

    Returns
    -------
    ndarray of shape (n_states, n_outputs)
    """
    settings = settings or {}
    n, oidx = rhs.n_states, np.asarray(output_index, dtype=np.int64)
    H = np.zeros((oidx.size, n))
    H[np.arange(oidx.size), oidx] = 1.0
    reset = H.T.copy()

    def cost(K):
        x, _, _ = predict_sensitivity(rhs, x0, u, y, dt, gain=K, output_index=oidx, sensitivities=False, **settings)
        return x, float(np.mean((x[:, oidx] - y) ** 2)) if np.all(np.isfinite(x)) else np.inf

    x, reset_cost = cost(reset)
    if noise is None:
        spread = np.nanstd(x, axis=0) if np.isfinite(x).any() else np.ones(n)
        spread = np.where(np.isfinite(spread) & (spread > 0), spread, 1.0)
        y_spread = np.std(y, axis=0)
        R = np.diag((0.1 * np.where(y_spread > 0, y_spread, 1.0)) ** 2)
        covariances = [(np.diag((f * spread) ** 2), R) for f in (0.01, 0.1, 1.0)]
    else:
        covariances = [noise]
    try:
        _, A, _ = step_jacobian(rhs, x0, u[0], u[1] if u.shape[0] > 1 else u[0], dt, **settings)
    except SimulationError:
        return reset
    gains = []
    for Q, R in covariances:
        try:
            with np.errstate(all="ignore"):
                P = solve_discrete_are(A.T, H.T, Q, R)
                K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if np.all(np.isfinite(K)):
            gains.append(K)
    if noise is not None:
        return gains[0] if gains else reset
    costs = [cost(K)[1] for K in gains] + [reset_cost]
    return (gains + [reset])[int(np.argmin(costs))]


class _PredictionProblem(_Problem):
    """``p = (physical, free coefficients, free x0 of each record, gain entries)``; residuals: prediction errors."""

    def __init__(self, *args, gain, free_gain, horizon):
        super().__init__(*args)
        self.gain0 = np.asarray(gain, dtype=float)
        self.free_gain, self.horizon = free_gain, horizon
        self.n_gain = self.gain0.size if free_gain else 0
        self._pred_key = self._pred = None

    def parameters(self):
        n_out = self.oidx.size
        gain = [("gain", i, r) for i in range(self.n_states) for r in range(n_out)] if self.free_gain else []
        return super().parameters() + tuple(gain)

    def pack(self):
        return np.concatenate([super().pack(), self.gain0.ravel() if self.free_gain else np.zeros(0)])

    def bounds(self, lo, hi, x0_lo=None, x0_hi=None):
        lower, upper = super().bounds(lo, hi, x0_lo, x0_hi)
        return np.r_[lower, np.full(self.n_gain, -np.inf)], np.r_[upper, np.full(self.n_gain, np.inf)]

    def gain(self, p):
        if not self.free_gain:
            return self.gain0
        k = self.n_model + self.n_x0
        return p[k : k + self.n_gain].reshape(self.gain0.shape)

    def n_columns(self):
        return self.n_model + self.n_x0 + self.n_gain

    def carry(self, p):
        return self.gain(p).copy()

    def result_fields(self, p):
        _check_diverged(self, p, "the predictor at the optimum")
        return {"gain": self.gain(p).copy(), "horizon": self.horizon}

    def _predict(self, p, sensitivities):
        rhs = self.rhs(p)
        D = self.directions(p) if sensitivities else None
        out = []
        for x0, u, y in zip(self.record_starts(p), self.us, self.ys):
            out.append(predict_sensitivity(rhs, x0, u, y, self.dt, gain=self.gain(p), horizon=self.horizon,
                                           directions=D, free_x0=self.free_x0, free_gain=self.free_gain,
                                           output_index=self.oidx, sensitivities=sensitivities,
                                           **self.settings))
        return out

    def trajectories(self, p):
        """The predictions of each record (NaN where the predictor diverged); the last ones are reused."""
        key = p.tobytes()
        if self._pred_key != key:
            self._pred_key, self._pred = key, [x for x, _, _ in self._predict(p, False)]
        return self._pred

    def open_loop(self, p):
        return self.trajectories(p)

    def residuals(self, p):
        out = np.concatenate([((x[:, self.oidx] - y) / scale).ravel()
                              for x, y, scale in zip(self.trajectories(p), self.ys, self.y_scales)])
        out = out / np.sqrt(self.n_res)
        return np.where(np.isfinite(out), out, _DIVERGED / np.sqrt(self.n_res))

    def jacobian(self, p):
        J = np.zeros((self.n_res, p.size))
        row, n_free = 0, self.free_x0.size
        gain_cols = self.n_model + self.n_x0 + np.arange(self.n_gain)
        for r, ((x, S, bad), scale) in enumerate(zip(self._predict(p, True), self.y_scales)):
            if not np.all(np.isfinite(S)):
                where = f"sample {bad}" if bad >= 0 else "a multi-step branch"
                raise SimulationError(f"the predictor of an accepted refinement step diverges at {where}"
                                      f"{f' of record {r}' if self.n_records > 1 else ''}.", step=max(bad, -1))
            cols = np.r_[np.arange(self.n_model), self.n_model + r * n_free + np.arange(n_free), gain_cols]
            m = S.shape[0] * S.shape[1]
            J[row : row + m, cols] = (S / scale[None, :, None]).reshape(m, -1)
            row += m
        return J / np.sqrt(self.n_res)


def _check_diverged(problem, p, what):
    for r, x in enumerate(problem.trajectories(p)):
        bad = ~np.all(np.isfinite(x), axis=1)
        if bad.any():
            where = "" if problem.n_records == 1 else f" of record {r}"
            raise SimulationError(f"{what} diverges at sample {int(np.argmax(bad))}{where}; expected a predictor "
                                  "that follows the record (give a larger noise Q, i.e. a stronger starting "
                                  "gain, or a better starting model).", step=int(np.argmax(bad)))


def refine_prediction_error(dynamics, u, y, *, x0, free=None, horizon=1, gain=None, free_gain=True, noise=None,
                            prune=0.0, solver=None):
    """Refine a model by the errors of its ``horizon``-step predictions through a constant-gain observer.

    Parameters
    ----------
    dynamics : Dynamics
        The starting model, compiled (a model of terms: the predictor and its
        sensitivities run in numba); its ``dt``, ``output_index`` and
        simulation settings are those of the predictor.
    u, y, x0, free, prune, solver
        As in :func:`~sindybench.refine.refine_simulation_error`; ``x0`` is
        the first predicted state ``x[0|-1]`` (one per record). The
        residuals are scaled by ``solver.output_scale`` or, by default, by
        the RMS prediction error of the starting predictor (one number per
        output): one-step errors are often orders of magnitude below the
        output's spread, and the optimizer's tolerances are relative to this
        scale.
    horizon : int, default=1
        Steps ahead of the fitted predictions: 1 = one-step prediction
        error; larger values weigh the model's own dynamics more; at least
        the record's length = output error from ``x0``.
    gain : array-like of shape (n_states, n_outputs), optional
        The observer gain ``K`` (its start when ``free_gain``); default the
        steady-state Kalman gain of the starting model (:func:`starting_gain`).
    free_gain : bool, default=True
        Refine the gain with the model (it is then reported with the
        covariance as ``("gain", state, output)``).
    noise : (Q, R), optional
        Covariances (or their diagonals) of the process noise per sample
        (n_states square, positive semidefinite) and of the measurement
        noise (n_outputs square, positive definite) that give the default
        gain.

    Returns
    -------
    RefinementResult
        ``cost`` and ``initial_cost`` are those of the predictions (half the
        mean squared scaled prediction error: ``initial_cost`` is 0.5 with
        the default scale); ``gain`` and ``horizon`` say which predictor.

    Raises
    ------
    SimulationError
        When the starting predictor or the optimum's diverges (with the sample).
    ValueError
        For a ``horizon`` below 1 or beyond the record, a ``noise`` that is not
        a covariance, a model on the Python path.

    Examples
    --------
    ``x' = a x + b u`` with ``a = 1.5`` is unstable: its open-loop simulation
    leaves any record, its predictor does not.

    >>> from sindybench.dynamics import Dynamics
    >>> from sindybench.libraries import POW
    >>> terms = [((0, POW, 1, 0),), ((1, POW, 1, 0),)]
    >>> plant = Dynamics.from_terms(terms, [[1.5], [1.0]], dt=0.05)
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(400, 1))
    >>> x = np.zeros(400)
    >>> for k in range(399):  # the plant under the feedback u - 3 x
    ...     x[k + 1] = plant.simulate([[u[k, 0] - 3 * x[k]]] * 2, [x[k]])[1, 0]
    >>> v = u[:, 0] - 3 * x
    >>> start = Dynamics.from_terms(terms, [[1.2], [0.8]], dt=0.05)
    >>> res = refine_prediction_error(start, v[:, None], x[:, None], x0=[0.0])
    >>> np.round(res.coef.ravel(), 4).tolist(), res.horizon
    ([1.5, 1.0], 1)
    """
    view = ParametrizedDynamics(_check_dynamics(dynamics), free)
    if not view.compiled:
        raise ValueError("prediction-error refinement needs a compiled model (terms); got a Python right-hand side "
                         "(a model on the Python path, or a physical map with make_rhs). Expected a model over a "
                         "built-in or custom library whose terms numba compiles, or OutputErrorRefinement.")
    solver = LeastSquares() if solver is None else check_settings(solver, LeastSquares, "solver", "max_nfev=50")
    n_states = dynamics.n_states
    us, ys, x0s = _check_records(u, y, x0, n_states)
    _check_outputs(ys, dynamics)
    output_index = dynamics.output_index
    n_out = len(output_index)
    n_min = min(u_r.shape[0] for u_r in us)
    if isinstance(horizon, bool) or not isinstance(horizon, numbers.Integral) or not 1 <= horizon <= n_min:
        raise ValueError(f"horizon must be an integer in [1, {n_min}] (1 = one-step predictions, at most the "
                         f"record's {n_min} samples); got {horizon!r}.")
    horizon = int(horizon)
    prune = check_positive(prune, "prune", strict=False)
    settings = dynamics.settings
    box = _box(dynamics, view.free_x0, solver.x0_bounds)
    if noise is not None:
        noise = _check_noise(noise, n_states, n_out)
    if gain is not None:
        given, gain = gain, np.asarray(gain, dtype=float)
        if gain.shape != (n_states, n_out) or not np.all(np.isfinite(gain)):
            raise ValueError(f"gain has shape {np.shape(given)}; expected a finite ({n_states}, {n_out}) matrix.")
    output_scale = solver.output_scale
    if output_scale is not None:
        output_scale = np.broadcast_to(np.asarray(output_scale, dtype=float).reshape(-1), (n_out,)).copy()
        if not np.all(np.isfinite(output_scale) & (output_scale > 0)):
            raise ValueError(f"output_scale = {output_scale.tolist()}; expected finite numbers > 0.")
    held = {}

    def build(view, x0s, carry):
        def problem_of(K):
            return _PredictionProblem(view, x0s, us, ys, [(0, us[0].shape[0])], gain=K, free_gain=free_gain,
                                      horizon=horizon)

        problem = None if carry is None else problem_of(carry)  # after pruning: the last round's gain
        if problem is None or not all(np.all(np.isfinite(x)) for x in problem.trajectories(problem.pack())):
            K = gain
            if K is None:  # a fresh start of the gain (also when the pruned model diverges with the last one)
                K = starting_gain(view.rhs(view.start()), x0s[0], us[0], ys[0], dynamics.dt,
                                  output_index=output_index, noise=noise, settings=settings)
            problem = problem_of(K)
        _check_diverged(problem, problem.pack(), "the starting predictor")
        xs = problem.trajectories(problem.pack())
        if output_scale is None:  # the starting predictor's RMS error, held over the rounds (comparable costs)
            if "scale" not in held:
                err = np.vstack([x[:, problem.oidx] - y_r for x, y_r in zip(xs, ys)])
                rms = np.sqrt(np.mean(err ** 2, axis=0))
                held["scale"] = np.where(rms > 0, rms, problem.y_scale)
            problem.scale_outputs(held["scale"])
        return problem, xs

    return solve(build, view, x0s, us, ys, bounds=box, prune=prune, solver=solver._replace(output_scale=output_scale))
