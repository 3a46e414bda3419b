"""Latent states whose sparse equations are learned from the data: ``LatentHiddenState``.

The user gives the number of latent states and a library; every row of the
model (the measured outputs' and the latent states') is a sparse combination
of the library's terms over ``Z = [outputs, latents, inputs]``. A latent state
cannot be regressed on, so its equation is found by simulation error:

1. **Start** (equation error, searched on validation): the latent states are a
   chain of first-order lags driven by the first input,
   ``z0' = -z0 / tau + u0``, ``z1' = -z1 / tau + z0``, ...; the outputs' rows
   are regressed on ``[y, z, u]`` by the estimator's optimizer, and ``tau``
   is searched by ``HiddenStateSINDy``'s inner search (simulation error of the
   validation block), as any physical guess.
2. **Discover** (simulation error): the estimator's refinement
   (``refine=OutputErrorRefinement(prune=...)``) frees *every* term of the
   latent rows (not only the start's nonzero ones) beside the outputs' nonzero
   terms, fits them by the open-loop simulation error with exact
   sensitivities, then prunes the terms that contribute little and refits
   (sequential thresholding on the simulation-error problem). The pruning
   level is a hyperparameter (``refine__prune``), chosen on validation data
   with :func:`~sindybench.model_selection.tune` or a scikit-learn search.

**Gauge.** A latent state is defined only up to its scale: ``z -> s z`` gives
another model with the same outputs. The gauge is fixed by pinning the
coefficient of each latent row's driver (``u0`` for ``z0``, ``z(j-1)`` for
``zj``) at 1 during the refinement: the latent state is "in units of its
driver's integral". :meth:`LatentHiddenState.gauge` says so in words, and
gauge-free quantities (the poles and the static gain of the linearized model at
an operating point) come from :func:`latent_invariants`.
"""

import numbers

import numpy as np
from scipy.optimize import least_squares

from .._validation import check_bounds
from ..io import register_model
from ..libraries import POW, PolynomialLibrary
from ..simulate import TermsRHS, simulate
from ._base import Design, HiddenStrategy, Structure

__all__ = ["LatentHiddenState", "latent_invariants"]


class LatentHiddenState(HiddenStrategy):
    """Latent states with learned sparse equations (fitted by simulation error).

    Parameters
    ----------
    n_latent : int, default=1
        Number of latent states (``z0, z1, ...``).
    tau : float, optional
        Time constant of the starting lag chain; None = searched within
        ``bounds["tau"]`` (log scale).
    bounds : dict, default={"tau": (1e-3, 1e3, True)}
        Search range of ``tau`` (time units of ``dt``).
    latent_bounds : (float, float), optional
        Simulation bounds of every latent state (in the gauge's units), e.g.
        ``(0, inf)`` for a level that cannot go negative; None = unbounded.
    output_bounds : (float, float), optional
        Simulation bounds of the outputs (e.g. a sensor range).

    Notes
    -----
    Use it with ``refine=OutputErrorRefinement(prune=...)``: without a
    refinement the latent rows stay the starting linear lags. The library
    must contain the linear term of each latent row's driver (``u0``,
    ``z(j-1)``), whose coefficient fixes the gauge.

    Examples
    --------
    >>> s = LatentHiddenState(n_latent=1)
    >>> sorted(s.search_space())
    ['tau']
    >>> s.structure({"tau": 10.0}, n_outputs=1, n_inputs=1).state_names
    ['y0', 'z0']
    >>> print(s.gauge(n_outputs=1))
    z0: the coefficient of u0 in z0' is 1 (scale gauge)
    """

    _physical = ("tau",)

    def __init__(self, *, n_latent=1, tau=None, bounds=None, latent_bounds=None, output_bounds=None):
        self.n_latent = n_latent
        self.tau = tau
        self.bounds = bounds
        self.latent_bounds = latent_bounds
        self.output_bounds = output_bounds

    def _validate(self):
        if isinstance(self.n_latent, bool) or not isinstance(self.n_latent, numbers.Integral) or self.n_latent < 1:
            raise ValueError(f"n_latent must be an integer >= 1; got {self.n_latent!r}.")
        if self.tau is not None and (isinstance(self.tau, bool) or not isinstance(self.tau, numbers.Real)
                                     or not np.isfinite(self.tau) or self.tau <= 0):
            raise ValueError(f"tau must be a finite number > 0 or None (searched); got {self.tau!r}.")
        check_bounds(self.latent_bounds, 1, name="latent_bounds")
        check_bounds(self.output_bounds, 1, name="output_bounds")
        super()._validate()

    def search_space(self):
        if self.bounds is None and self.tau is None:
            return {"tau": (1e-3, 1e3, True)}
        return super().search_space()

    def refinable(self, params):
        return ()  # tau only sets the start; the latent rows are learned

    def default_library(self):
        """Quadratic polynomial in ``(y, z, u)``."""
        return PolynomialLibrary(degree=2)

    def gauge(self, *, n_outputs):
        """The gauge of each latent state, in words."""
        lines = []
        for j in range(int(self.n_latent)):
            driver = "u0" if j == 0 else f"z{j - 1}"
            lines.append(f"z{j}: the coefficient of {driver} in z{j}' is 1 (scale gauge)")
        return "\n".join(lines)

    def structure(self, params, *, n_outputs, n_inputs):
        if n_inputs < 1:
            raise ValueError("LatentHiddenState needs at least one input (the first one drives z0); got none.")
        q = int(self.n_latent)
        n = n_outputs + q
        ylo, yhi = check_bounds(self.output_bounds, 1, name="output_bounds")
        zlo, zhi = check_bounds(self.latent_bounds, 1, name="latent_bounds")
        lower = np.r_[np.full(n_outputs, ylo[0]), np.full(q, zlo[0])]
        upper = np.r_[np.full(n_outputs, yhi[0]), np.full(q, zhi[0])]
        bounds = None if np.all(np.isinf(lower)) and np.all(np.isinf(upper)) else (lower, upper)
        return Structure(n_states=n, learned=tuple(range(n)), output_index=tuple(range(n_outputs)),
                         state_names=[f"y{i}" for i in range(n_outputs)] + [f"z{j}" for j in range(q)],
                         bounds=bounds)

    def _drivers(self, n_outputs, n_inputs):
        """Column in ``Z = [y, z, u]`` of each latent row's driver."""
        q = int(self.n_latent)
        return [n_outputs + q if j == 0 else n_outputs + j - 1 for j in range(q)]

    def _lags(self, u, tau, dt):
        """The starting latent trajectory: the lag chain from its steady state."""
        q = int(self.n_latent)
        coef = np.zeros((q + 1, q))
        terms = [((j, POW, 1.0, 0.0),) for j in range(q)] + [((q, POW, 1.0, 0.0),)]
        for j in range(q):
            coef[j, j] = -1.0 / tau
            coef[q if j == 0 else j - 1, j] = 1.0
        x0 = np.cumprod(np.full(q, tau)) * u[0, 0]
        return simulate(TermsRHS(coef, terms, q), x0, u[:, :1], dt, n_substeps=4), coef, terms

    def design(self, u, y, dt, *, derivative, params):
        tau = float(params["tau"])
        z, coef, terms = self._lags(u, tau, dt)
        q = int(self.n_latent)
        zu = np.c_[z, u[:, :1]]
        z_dot = zu @ coef  # exact: the lags' own right-hand side
        return Design(states=np.c_[y, z], targets=np.c_[derivative(y), z_dot])

    def refine_free(self, coef, terms, *, n_outputs, n_inputs):
        """Entries of the learned block freed by a refinement.

        The outputs' nonzero coefficients, and every term of the latent rows
        except each row's gauge term (its driver's linear term, held at its value).
        """
        if terms is None:
            raise ValueError("LatentHiddenState needs a library of built-in terms (compiled); got a Python library.")
        free = coef != 0
        terms = [tuple(t) for t in terms]
        for j, col in enumerate(self._drivers(n_outputs, n_inputs)):
            gauge = ((col, POW, 1.0, 0.0),)
            if gauge not in terms:
                raise ValueError(f"the library has no linear term of column {col} (the driver of z{j}); expected it "
                                 "in the library: its coefficient fixes the latent state's scale.")
            free[:, n_outputs + j] = True
            free[terms.index(gauge), n_outputs + j] = False
        return free

    def initial_state(self, u, y_init, dt, *, derivative, params, model):
        """Outputs from ``y_init[0]``; latent states at rest (zero derivative) for those outputs and ``u[0]``."""
        p = y_init.shape[1]
        q = int(self.n_latent)
        tau = float(params["tau"])
        start = np.cumprod(np.full(q, tau)) * u[0, 0]
        y0 = np.asarray(y_init[0], dtype=float)

        def residual(z):
            return np.asarray(model.rhs(np.r_[y0, z], u[0]), dtype=float)[p:]

        with np.errstate(all="ignore"):
            try:
                fit = least_squares(residual, start, max_nfev=50 * q)
                z0 = fit.x if np.all(np.isfinite(fit.x)) else start
            except ValueError:
                z0 = start
        return np.r_[y0, z0]


def latent_invariants(model, u_op, *, y_guess=None, eps=1e-6):
    """Gauge-free quantities of a fitted latent model at a steady operating point.

    The poles (eigenvalues of the state Jacobian at the equilibrium for the
    constant input ``u_op``) and the static gain of the outputs from the inputs
    do not depend on the latent states' scale.

    Parameters
    ----------
    model : HiddenStateSINDy
        Fitted, with a :class:`LatentHiddenState` (any fitted model works).
    u_op : array-like of shape (n_inputs,)
        Constant input of the operating point.
    y_guess : array-like, optional
        Start of the equilibrium search (default: the training states' mean).
    eps : float, default=1e-6
        Relative step of the central differences.

    Returns
    -------
    dict
        ``"state"``: the equilibrium, ``"poles"``: eigenvalues (1/time),
        ``"gain"``: d y / d u at steady state (n_outputs, n_inputs).
    """
    u_op = np.asarray(u_op, dtype=float).reshape(-1)
    rhs = model.rhs_
    start = np.mean(model.states_, axis=0) if y_guess is None else np.asarray(y_guess, dtype=float)
    sol = least_squares(lambda x: rhs(x, u_op), start, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    x = sol.x
    n, m = x.size, u_op.size

    def jac(f, v):
        out = []
        for i in range(v.size):
            h = eps * max(1.0, abs(v[i]))
            e = np.zeros_like(v)
            e[i] = h
            out.append((f(v + e) - f(v - e)) / (2 * h))
        return np.array(out).T

    A = jac(lambda v: np.asarray(rhs(v, u_op), dtype=float), x)
    B = jac(lambda v: np.asarray(rhs(x, v), dtype=float), u_op)
    out_idx = list(model.structure_.output_index)
    gain = -np.linalg.solve(A, B)[out_idx]
    return {"state": x, "poles": np.linalg.eigvals(A), "gain": gain.reshape(len(out_idx), m)}


register_model(LatentHiddenState)
