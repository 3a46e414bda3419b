"""Bouc-Wen structural iteration: a hidden hysteretic force behind a known mechanical law.

The mechanical part of the model is known up to three numbers,

    m y'' + c y' + k y + z = u,

and the restoring force ``z`` is hidden. For a guess of ``(m, c, k)`` the force is
reconstructed from the measured displacement and its derivatives,
``z = u - c y' - k y - m y''``, and its rate ``z'`` is fitted sparsely with a
library of products of ``y'``, ``z``, ``|y'|`` and ``|z|`` (the Bouc-Wen law
``z' = alpha y' - beta (gamma |y'| z + delta y' |z|)`` is one sparse member).
The model simulates the state ``(y, v, z)`` with ``v = y'``:

    y' = v,   v' = (u - c v - k y - z) / m,   z' = Theta(v, z) xi.

The first two rows are fixed by the guess, the third is learned.
:class:`~sindybench.HiddenStateSINDy` searches the guesses that are left
``None`` by the open-loop simulation error on a validation block.

Filtered regression. The target ``z' = D(z)`` carries the smoothing of the
differentiation method ``D`` (e.g. a band limit), while products such as
``|y'| z`` of smoothed signals hold harmonics beyond it. Regressing the smoothed
target on unsmoothed features biases the fit and lets spurious terms in (a
linear ``z`` term: a relaxation that ruins the quasi-static hysteresis loop).
With ``filter_features`` every feature column ``theta`` is replaced by
``D(integral of theta)``, the same smoothing as the target's, through
:attr:`Design.feature_filter`.
"""

import copy
import numbers

import numpy as np
from scipy.integrate import cumulative_simpson, cumulative_trapezoid

from .._validation import check_bool, check_integer
from ..io import register_model
from ..refine import CoefficientMap
from ..search import LogUniform
from ._base import Design, HiddenStrategy, InitialFit, Structure, linear_term, with_defaults

__all__ = ["BoucWenHiddenState", "DEFAULT_BOUNDS"]

#: Search ranges used for ``m``, ``c``, ``k`` when ``bounds`` has no entry for them:
#: ``name -> dimension`` in SI units, wide around the benchmark's values.
DEFAULT_BOUNDS = {"m": LogUniform(0.1, 20.0), "c": LogUniform(0.1, 1000.0), "k": LogUniform(1e3, 1e6)}

# columns of the library input Z = [y, v, z, u]
_Y, _V, _Z, _U = 0, 1, 2, 3
_INTEGRATORS = {"simpson": cumulative_simpson, "trapezoid": cumulative_trapezoid}


def _local_derivatives(y, dt):
    """Value, slope and curvature at the first sample of a short record (local polynomial)."""
    n = y.shape[0]
    if n == 1:
        return y[0], 0.0, 0.0
    s = np.arange(n, dtype=float)
    p = np.polynomial.polynomial.polyfit(s, y, min(3, n - 1))
    p = np.concatenate([p, np.zeros(3)])
    return p[0], p[1] / dt, 2.0 * p[2] / dt**2


#: The fixed rows over the terms ``(v, y, z, u)``: ``y' = v``, ``v' = (u - c v - k y - z) / m``.
_FIXED_ROWS = CoefficientMap((4, 3), [(0, 0, 1.0, (), ()), (0, 1, -1.0, ("c",), ("m",)), (1, 1, -1.0, ("k",), ("m",)),
                                      (2, 1, -1.0, (), ("m",)), (3, 1, 1.0, (), ("m",))])


class BoucWenHiddenState(HiddenStrategy):
    """Hidden hysteretic force of a mass-spring-damper (Bouc-Wen structural iteration).

    States ``(y, v, z)``: displacement, velocity ``v = y'`` and the hidden
    restoring force ``z``; library input ``Z = [y, v, z, u]``. Rows ``y' = v``
    and ``v' = (u - c v - k y - z) / m`` are fixed, ``z'`` is learned.

    Parameters
    ----------
    m, c, k : float or None, default=None
        Mass, viscous damping and linear stiffness. ``None`` = searched within
        ``bounds`` by :class:`~sindybench.HiddenStateSINDy`.
    bounds : dict or None, default=None
        ``name -> dimension`` for the searched parameters (``LogUniform(1e4,
        1e5)``, a ``LogNormal`` prior, ... of :mod:`sindybench.search`; the
        older ``(low, high)`` or ``(low, high, log)`` still work); entries
        missing here come from :data:`DEFAULT_BOUNDS`.
    n_init : int, default=10
        Number of first output samples used to set the initial state on new data.
    refine_init : bool, default=True
        Refine the initial state by least squares between the model's simulation
        and the first ``n_init`` samples (:meth:`initial_fit`). Otherwise ``(y, v, z)``
        at the first sample come from a local cubic fit of those samples (``z`` from
        the force balance).
    trim : int, default=100
        Samples left out of the regression at each end of the training record
        (edge effects of the differentiation).
    filter_features : {"simpson", "trapezoid"} or None, default="simpson"
        Smooth the library features like the target (see the module notes):
        ``D(cumulative integral of theta)`` with this integration rule; None
        regresses on the raw features.

    See Also
    --------
    sindybench.HiddenStateSINDy : the estimator that uses this strategy.

    Notes
    -----
    Simulate with ``input_hold="linear"``: a zero-order hold of the force delays
    it by half a sample, which on the benchmark costs about 1e-4 m of RMSE.

    The mass is well identified by the validation error; ``c`` and ``k`` much
    less, since the learned ``z'`` absorbs part of the linear stiffness (``k``
    trades against ``alpha``). Give ``k`` a range of about a decade around a
    physical guess: over :data:`DEFAULT_BOUNDS` a modest budget can land on a
    degenerate split that fits the validation block and fails elsewhere.

    Examples
    --------
    >>> s = BoucWenHiddenState(m=2.0, c=10.0, k=5e4)
    >>> st = s.structure(s.resolve_params(), n_outputs=1, n_inputs=1)
    >>> st.state_names, st.learned, st.output_index
    (['y', 'v', 'z'], (2,), (0,))
    >>> st.fixed_coef[:, 1].tolist()  # v' = (u - c v - k y - z) / m over [v, y, z, u]
    [-5.0, -25000.0, -0.5, 0.5]
    """

    _physical = ("m", "c", "k")

    def __init__(self, *, m=None, c=None, k=None, bounds=None, n_init=10, refine_init=True, trim=100,
                 filter_features="simpson"):
        self.m = m
        self.c = c
        self.k = k
        self.bounds = bounds
        self.n_init = n_init
        self.refine_init = refine_init
        self.trim = trim
        self.filter_features = filter_features

    def default_library(self):
        """Products of ``v``, ``z``, ``|v|``, ``|z|`` up to degree two (12 terms)."""
        from ..libraries import AbsProductLibrary, ConcatLibrary, PolynomialLibrary

        return ConcatLibrary(
            [
                PolynomialLibrary(degree=2, include_bias=False, variables=[_V, _Z]),
                AbsProductLibrary(pairs=[(_V, _Z)], include_abs=True),
                AbsProductLibrary(pairs=[(_V, _V), (_Z, _Z)], products=("x|y|",)),
            ]
        )

    def search_space(self):
        """Searched parameters with their ranges (``bounds`` over :data:`DEFAULT_BOUNDS`)."""
        merged = copy.copy(self)
        merged.bounds = with_defaults(self.bounds, DEFAULT_BOUNDS)
        return super(BoucWenHiddenState, merged).search_space()

    def _validate(self):
        for name, strict in (("m", True), ("c", False), ("k", False)):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, numbers.Real)
                                      or value < 0 or (strict and value == 0)):
                op = ">" if strict else ">="
                raise ValueError(f"{name} must be a number {op} 0 or None (searched); got {value!r}.")
        super()._validate()
        for name, dim in self.search_space().items():
            low = dim.support()[0]
            if low < 0 or (name == "m" and low == 0):
                raise ValueError(f"bounds[{name!r}] starts at {low!r}; expected a range of positive values.")
        check_integer(self.n_init, "n_init")
        check_integer(self.trim, "trim", low=0)
        check_bool(self.refine_init, "refine_init")
        if self.filter_features is not None and self.filter_features not in _INTEGRATORS:
            raise ValueError(
                f"filter_features must be one of {sorted(_INTEGRATORS)} or None; got {self.filter_features!r}."
            )

    def structure(self, params, *, n_outputs, n_inputs):
        """States ``(y, v, z)``; fixed rows ``y' = v`` and the force balance; ``z'`` learned."""
        if n_outputs != 1 or n_inputs != 1:
            raise ValueError(
                f"BoucWenHiddenState models one force input and one displacement output; "
                f"got {n_inputs} inputs and {n_outputs} outputs."
            )
        terms = [linear_term(_V), linear_term(_Y), linear_term(_Z), linear_term(_U)]
        coef = _FIXED_ROWS.matrix(params)
        return Structure(n_states=3, learned=(_Z,), output_index=(_Y,), fixed_terms=terms, fixed_coef=coef,
                         state_names=["y", "v", "z"])

    def physical_map(self, params, *, n_outputs, n_inputs):
        """The fixed rows over the terms ``(v, y, z, u)``: ``y' = v``, ``v' = (u - c v - k y - z) / m``.

        Examples
        --------
        >>> rows = BoucWenHiddenState().physical_map({}, n_outputs=1, n_inputs=1)
        >>> rows.matrix({"m": 2.0, "c": 10.0, "k": 5e4})[:, 1].tolist()
        [-5.0, -25000.0, -0.5, 0.5]
        """
        return _FIXED_ROWS

    def design(self, u, y, dt, *, derivative, params):
        """States ``[y, y', z]`` with ``z = u - c y' - k y - m y''`` and the target ``z'``."""
        y = np.asarray(y, dtype=float).reshape(len(y), -1)[:, 0]
        u = np.asarray(u, dtype=float).reshape(len(u), -1)[:, 0]
        n = y.shape[0]
        if 2 * self.trim >= n:
            raise ValueError(f"trim={self.trim} leaves no sample of the {n} training samples; expected trim < n / 2.")
        v = derivative(y, order=1)
        a = derivative(y, order=2)
        z = u - params["c"] * v - params["k"] * y - params["m"] * a
        z_dot = derivative(z, order=1)
        states = np.column_stack([y, v, z])
        feature_filter = None
        if self.filter_features is not None:
            feature_filter = _IntegralFilter(derivative, dt, self.filter_features)
        return Design(states=states, targets=z_dot.reshape(-1, 1), rows=slice(self.trim, n - self.trim),
                      feature_filter=feature_filter)

    def initial_state(self, u, y_init, dt, *, derivative, params, model):
        """First guess of ``(y, v, z)`` at the first sample from the first ``n_init`` samples of ``y_init``.

        A local cubic fit gives ``y``, ``y'`` and ``y''``, the force balance gives
        ``z`` (refined as :meth:`initial_fit` says).
        """
        y = np.asarray(y_init, dtype=float).reshape(len(y_init), -1)[:, 0]
        u = np.asarray(u, dtype=float).reshape(len(u), -1)
        n = min(self.n_init, y.shape[0], u.shape[0])
        y, u = y[:n], u[:n]
        y0, v0, a0 = _local_derivatives(y, dt)
        return np.array([y0, v0, u[0, 0] - params["c"] * v0 - params["k"] * y0 - params["m"] * a0])

    def initial_fit(self, params, *, n_outputs, n_inputs):
        """With ``refine_init``: the three states matched to the first ``n_init`` samples; else None.

        Examples
        --------
        >>> BoucWenHiddenState(n_init=20).initial_fit({}, n_outputs=1, n_inputs=1)
        InitialFit(n_samples=20, free=None, bounds=None)
        """
        return InitialFit(self.n_init) if self.refine_init else None


class _IntegralFilter:
    """``theta -> derivative(cumulative integral of theta)``: the target's smoothing on the features."""

    def __init__(self, derivative, dt, rule):
        self.derivative = derivative
        self.dt = dt
        self.rule = rule

    def __call__(self, theta):
        integral = _INTEGRATORS[self.rule](theta, dx=self.dt, axis=0, initial=0.0)
        return self.derivative(integral, order=1)


register_model(BoucWenHiddenState)
