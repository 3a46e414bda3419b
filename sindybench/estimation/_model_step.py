"""The one place where :mod:`sindybench.estimation` reads a fitted model.

:func:`model_step` reads a fitted estimator's ``dynamics_`` (the
:class:`~sindybench.dynamics.Dynamics` that every sindybench estimator
exposes) into a :class:`ModelStep`: the compiled right-hand side of the full
state, which states are measured, the bounds, the simulation settings and the
model's input delay (``input_delay``: every estimation function given a model
and the user's inputs ``X`` delays them by it, through :meth:`ModelStep.delayed`,
so a user never shifts inputs by hand).
:meth:`ModelStep.step_model` turns it into the :class:`~sindybench.dynamics.StepModel`
of the public one-step map (:mod:`sindybench.dynamics`), whose numba kernels
``step_kernel`` and ``step_jacobian_kernel`` the filter, the smoother, the
k-step prediction and the linearization call: the simulator's own step (the
same state to the last bit) and the exact Jacobian of that discrete step.
"""

from typing import NamedTuple

import numpy as np

from .._preprocessing import delay_inputs
from .._validation import check_bounds, check_dt, check_integer, check_option, check_positive
from ..dynamics import TermsRHS, check_output_index, step_model

__all__ = ["ModelStep", "model_step"]


class ModelStep(NamedTuple):
    """A fitted model's dynamics as the estimators need them.

    Attributes
    ----------
    rhs : TermsRHS
        Right-hand side of the full state (learned and fixed rows).
    n_inputs : int
    output_index : tuple of int
        The measured states, in the order of the columns of ``y``.
    lower, upper : ndarray of shape (n_states,)
        State bounds (``-inf`` / ``inf`` when unbounded).
    dt : float
        Sampling interval.
    n_substeps : int
    method : {"rk4", "euler"}
    input_hold : {"zoh", "linear"}
    max_abs : float
        A state beyond this magnitude counts as divergence.
    x0 : ndarray of shape (n_states,)
        The model's first training state (a default prior mean).
    state_scale : ndarray of shape (n_states,)
        Standard deviation of each state on the training record (a default
        prior spread and the unit of estimated process noise).
    input_delay : int, default=0
        The estimator's ``input_delay``: the dynamics are driven by
        ``u(t - input_delay dt)``. The filter, the smoother, the k-step
        prediction and the noise estimate take the user's inputs and delay
        them themselves (:meth:`delayed`).
    """

    rhs: TermsRHS
    n_inputs: int
    output_index: tuple
    lower: np.ndarray
    upper: np.ndarray
    dt: float
    n_substeps: int
    method: str
    input_hold: str
    max_abs: float
    x0: np.ndarray
    state_scale: np.ndarray
    input_delay: int = 0

    @property
    def n_states(self):
        return self.rhs.n_states

    @classmethod
    def from_rhs(cls, rhs, dt, *, n_inputs=0, output_index=(0,), bounds=None, n_substeps=1, method="rk4",
                 input_hold="zoh", max_abs=np.inf, x0=None, state_scale=None, input_delay=0):
        """A model given by its right-hand side and simulation settings (defaults as ``simulate``'s).

        Examples
        --------
        >>> from sindybench.libraries import POW
        >>> m = ModelStep.from_rhs(TermsRHS([[-1.0]], [((0, POW, 1, 0),)], 1), 0.1)
        >>> m.n_states, m.output_index, m.upper.tolist()
        (1, (0,), [inf])
        """
        if not isinstance(rhs, TermsRHS):
            raise ValueError(f"rhs must be a TermsRHS; got {type(rhs).__name__}.")
        n = rhs.n_states
        lo, hi = check_bounds(bounds, n)
        x0 = np.zeros(n) if x0 is None else x0
        scale = np.ones(n) if state_scale is None else state_scale
        return cls(rhs=rhs, n_inputs=n_inputs, output_index=output_index, lower=lo, upper=hi, dt=dt,
                   n_substeps=n_substeps, method=method, input_hold=input_hold, max_abs=max_abs, x0=x0,
                   state_scale=scale, input_delay=input_delay).checked()

    def delayed(self, X):
        """The inputs the dynamics see: the user's checked ``X`` delayed by ``input_delay`` samples.

        The one place where :mod:`sindybench.estimation` applies a model's
        delay (the estimator's :meth:`~sindybench.SINDy.delayed_inputs` does
        the same); row ``k`` holds ``X[k - input_delay]``, the first row held
        before the start (a delay of -1, a lag model's lead, holds the last
        row after the end).

        Examples
        --------
        >>> from sindybench.libraries import POW
        >>> rhs = TermsRHS.from_equations([{((0, POW, 1, 0),): -1.0, ((1, POW, 1, 0),): 1.0}])  # x' = -x + u
        >>> m = ModelStep.from_rhs(rhs, 0.1, n_inputs=1, input_delay=2)
        >>> m.delayed(np.arange(5.0)[:, None]).ravel().tolist()
        [0.0, 0.0, 0.0, 1.0, 2.0]
        """
        return delay_inputs(X, self.input_delay)

    def checked(self):
        """This model with every field checked against the others (what the compiled kernels index with).

        The filter, the smoother, the k-step prediction, the noise estimate,
        the linearization and the CasADi export index arrays by these values
        inside compiled code, which does not check bounds: an output index
        past the states or fewer inputs than the terms use would read and
        write outside the arrays. So :func:`model_step` calls this on every
        model it is given, a ``ModelStep`` built or edited by hand included.

        Raises
        ------
        ValueError
            Naming the field, what it holds and what was expected.

        Examples
        --------
        >>> from sindybench.libraries import POW
        >>> m = ModelStep.from_rhs(TermsRHS([[-1.0]], [((0, POW, 1, 0),)], 1), 0.1)
        >>> m._replace(output_index=(5,)).checked()
        Traceback (most recent call last):
        ...
        ValueError: output_index[0] must be an integer in [0, 0]; got 5.
        """
        rhs = self.rhs
        if not isinstance(rhs, TermsRHS):
            raise ValueError(f"rhs must be a TermsRHS; got {type(rhs).__name__}.")
        n = rhs.n_states
        n_inputs = check_integer(self.n_inputs, "n_inputs", low=0)
        if rhs.n_variables > n + n_inputs:
            raise ValueError(f"n_inputs = {n_inputs}, but the model's terms use column {rhs.n_variables - 1} of "
                             f"Z = [x, u] with {n} states; expected n_inputs >= {rhs.n_variables - n}.")
        index = check_output_index(self.output_index, n)
        lo, hi = (np.asarray(v, dtype=float) for v in (self.lower, self.upper))
        if lo.shape != (n,) or hi.shape != (n,) or np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo >= hi):
            raise ValueError(f"lower {lo} and upper {hi} must hold {n} values each (one per state), no NaN, with "
                             "lower < upper.")
        x0, scale = (np.asarray(v, dtype=float) for v in (self.x0, self.state_scale))
        if x0.shape != (n,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 = {x0}; expected {n} finite values (one per state).")
        if scale.shape != (n,) or not np.all(np.isfinite(scale) & (scale > 0)):
            raise ValueError(f"state_scale = {scale}; expected {n} finite values > 0 (one per state).")
        return self._replace(
            n_inputs=n_inputs, output_index=index, lower=lo, upper=hi, dt=check_dt(self.dt),
            n_substeps=check_integer(self.n_substeps, "n_substeps"),
            method=check_option(self.method, "method", ("rk4", "euler")),
            input_hold=check_option(self.input_hold, "input_hold", ("zoh", "linear")),
            max_abs=check_positive(self.max_abs, "max_abs", allow_inf=True), x0=x0, state_scale=scale,
            input_delay=check_integer(self.input_delay, "input_delay", low=-1))

    def step_model(self, *, with_inputs=False):
        """The :class:`~sindybench.dynamics.StepModel` of the public one-step map (no coefficient directions).

        Its numba kernels ``step_kernel`` and ``step_jacobian_kernel``
        (:mod:`sindybench.dynamics`) are the simulator's step and its exact
        state Jacobian. With ``with_inputs``, the model over ``[x, u]`` with
        ``u' = 0`` (the input held over the sample): the state Jacobian of its
        step holds the input Jacobian too.

        Examples
        --------
        >>> from sindybench.dynamics import step_kernel
        >>> from sindybench.libraries import POW
        >>> m = ModelStep.from_rhs(TermsRHS([[-1.0]], [((0, POW, 1, 0),)], 1), 0.1, method="euler")
        >>> x_next, diverged = step_kernel(m.step_model(), np.array([1.0]), np.zeros(0), np.zeros(0), m.dt)
        >>> x_next.tolist(), diverged
        ([0.9], False)
        """
        rhs, lower, upper, hold = self.rhs, self.lower, self.upper, self.input_hold
        if with_inputs:
            n_u = self.n_inputs
            rhs = TermsRHS(np.hstack([rhs.coef, np.zeros((rhs.coef.shape[0], n_u))]), rhs.terms, rhs.n_states + n_u)
            lower = np.concatenate([lower, np.full(n_u, -np.inf)])
            upper = np.concatenate([upper, np.full(n_u, np.inf)])
            hold = "zoh"
        return step_model(rhs, directions=np.zeros((0, *rhs.coef.shape)), n_substeps=self.n_substeps,
                          method=self.method, input_hold=hold, bounds=(lower, upper), max_abs=self.max_abs)


def state_spread(states, fallback=1.0):
    """Standard deviation of each state over a trajectory; ``fallback`` where it is zero or not finite."""
    scale = np.std(np.asarray(states, dtype=float), axis=0)
    return np.where(np.isfinite(scale) & (scale > 0), scale, fallback)


def model_step(model):
    """Read a fitted estimator into a :class:`ModelStep`.

    Parameters
    ----------
    model : SINDy, HiddenStateSINDy or ModelStep
        A fitted estimator with the compiled right-hand side (library
        ``terms_`` and no Python fixed rows); a ``ModelStep`` is returned as is.

    Returns
    -------
    ModelStep

    Raises
    ------
    ValueError
        When ``model`` is not fitted, has no compiled right-hand side, or
        was fitted on non-uniform sample times.

    Examples
    --------
    >>> import numpy as np
    >>> from sindybench import SINDy
    >>> from sindybench.libraries import PolynomialLibrary
    >>> u = np.sin(np.arange(200) * 0.05)[:, None]
    >>> y = np.cumsum(u, axis=0) * 0.05
    >>> m = model_step(SINDy(library=PolynomialLibrary(degree=1), dt=0.05).fit(u, y))
    >>> m.n_states, m.output_index, m.method
    (1, (0,), 'rk4')
    """
    if isinstance(model, ModelStep):
        return model.checked()
    name = type(model).__name__
    if not getattr(model, "_has_dynamics", False):  # asked, not an import of the estimators (which sit above)
        raise ValueError(f"{name} has no state-space dynamics: the Kalman filter, the smoother, the k-step "
                         "prediction, the noise estimate, the linearization and the CasADi export take SINDy-family "
                         "models only (a fitted SINDy or HiddenStateSINDy, or a ModelStep); ARX and NN-ARX predict "
                         "from past outputs and have no state to filter.")
    dyn = getattr(model, "dynamics_", None)  # the fitted-dynamics contract of every sindybench estimator
    if dyn is None:
        raise ValueError(f"{name} is not fitted; expected a fitted SINDy or HiddenStateSINDy.")
    if not isinstance(dyn.rhs, TermsRHS):
        raise ValueError(f"{name} has a Python right-hand side (a custom library or Python fixed rows); the "
                         "estimators need the compiled one (libraries with terms_).")
    if dyn.dt is None:
        raise ValueError(f"{name} was fitted on non-uniform sample times; the estimators need a uniform dt.")
    lo, hi = check_bounds(dyn.bounds, dyn.n_states)
    x0 = np.clip(np.asarray(model.x0_, dtype=float), lo, hi)
    states = getattr(model, "states_", None)  # the training trajectory (hidden states included), where kept
    scale = state_spread(states) if states is not None else np.ones(dyn.n_states)
    return ModelStep(rhs=dyn.rhs, n_inputs=int(model.n_features_in_), output_index=tuple(dyn.output_index),
                     lower=lo, upper=hi, dt=float(dyn.dt), n_substeps=int(dyn.n_substeps), method=dyn.method,
                     input_hold=dyn.input_hold, max_abs=float(dyn.max_abs), x0=x0, state_scale=scale,
                     input_delay=int(getattr(model, "input_delay", 0))).checked()
