"""The cascaded tanks' hidden upper tank: ``x1' = -k1 sqrt(x1) + k2 u`` within its bounds."""

import numbers

import numpy as np

from .._validation import check_bounds
from ..io import register_model
from ..libraries import POW, SQRT, ConcatLibrary, PolynomialLibrary, SqrtLibrary
from ..refine import CoefficientMap
from ..search import Uniform
from ..simulate import TermsRHS, simulate
from ._base import Structure, positive_dimension
from ._parametric import ParametricHiddenState

__all__ = ["TanksHiddenState"]


#: The lower tank's row over the terms ``(sqrt(x1), u)``: ``x1' = -k1 sqrt(x1) + k2 u``.
_FIXED_ROWS = CoefficientMap((2, 2), [(0, 1, -1.0, ("k1",), ()), (1, 1, 1.0, ("k2",), ())])


class TanksHiddenState(ParametricHiddenState):
    """Hidden upper-tank level of a cascaded-tanks system.

    A :class:`ParametricHiddenState` with the preset dynamics
    ``x1' = -k1 sqrt(x1) + k2 u`` (Torricelli outflow, pump inflow), simulated
    within ``bounds`` (the tank overflows at its upper bound). The measured
    lower tank is learned as ``y' = Theta^T phi(y, x1, u)``. The model is
    expressed in library terms, so it is simulated by the compiled simulator.

    Parameters
    ----------
    k1, k2 : float, optional
        Outflow and inflow coefficients; None = searched within ``k_bounds``
        (log scale), or, when both are searched and ``ratio_bounds`` is given,
        ``k1`` within ``k_bounds`` and the ratio ``k2 / k1`` within
        ``ratio_bounds``.
    x0 : float, optional
        Upper-tank level at the start of the training data; None = searched
        within ``bounds``.
    bounds : (float, float), default=(0.0, 10.0)
        Range of the upper-tank level (same units as ``y``).
    k_bounds : (float, float), default=(0.005, 0.2)
        Search range of ``k1`` and ``k2``.
    ratio_bounds : (float, float), optional
        Search range of ``k2 / k1`` (log scale), searched instead of ``k2``
        when both ``k1`` and ``k2`` are None. The ratio sets the upper tank's
        steady level ``(k2 u / k1)^2`` and so the pump voltage
        ``sqrt(upper bound) k1 / k2`` above which it overflows; ``k1`` alone
        then sets its time constant. Searching ``(k1, k2 / k1)`` turns the
        narrow diagonal valley of good ``(k1, k2)`` pairs into a valley along
        one axis, which the search finds far more reliably. E.g.
        ``(0.3, 3.0)``: overflow above about 1 to 10 V on a 10 V tank.
    output_bounds : (float, float), optional
        Simulation bounds of the measured level (e.g. the sensor range).
    init : {"simulation", "derivative"}, default="simulation"
        Initial upper-tank level on new data: minimum simulation error over
        the first ``init_size`` samples (grid, then refined by
        :func:`~sindybench.refine.estimate_initial_state` within ``bounds``), or the
        study's grid search matching the model's ``y'(0)`` to the measured one.
    init_size : int, default=50
    grid_size : int, default=41
    n_substeps : int, default=4
        RK4 steps per sample when reconstructing the upper tank.

    Examples
    --------
    >>> s = TanksHiddenState(k1=0.04, k2=0.03)
    >>> sorted(s.search_space())
    ['x0']
    >>> s.structure({"k1": 0.04, "k2": 0.03, "x0": 5.0}, n_outputs=1, n_inputs=1).state_names
    ['y0', 'x1']
    >>> s = TanksHiddenState(ratio_bounds=(0.3, 3.0))
    >>> sorted(s.search_space())
    ['k1', 'ratio', 'x0']
    >>> s.resolve_params({"k1": 0.04, "ratio": 0.75, "x0": 5.0})
    {'k1': 0.04, 'k2': 0.03, 'x0': 5.0}
    """

    def __init__(self, *, k1=None, k2=None, x0=None, bounds=(0.0, 10.0), k_bounds=(0.005, 0.2), ratio_bounds=None,
                 output_bounds=None, init="simulation", init_size=50, grid_size=41, n_substeps=4):
        self.k1 = k1
        self.k2 = k2
        self.x0 = x0
        self.bounds = bounds
        self.k_bounds = k_bounds
        self.ratio_bounds = ratio_bounds
        self.output_bounds = output_bounds
        self.init = init
        self.init_size = init_size
        self.grid_size = grid_size
        self.n_substeps = n_substeps

    hidden_names = ("x1",)
    rhs = params = x0_bounds = None

    def _tank_bounds(self):
        lo, hi = check_bounds(self.bounds, 1)
        if lo[0] < 0 or not np.isfinite(hi[0]):
            raise ValueError(f"bounds must be (lower >= 0, finite upper) for the tank level; got {self.bounds!r}.")
        return float(lo[0]), float(hi[0])

    def _hidden_rhs(self):
        lo, hi = self._tank_bounds()

        def rhs(xh, y, u, *, k1, k2):
            return -k1 * np.sqrt(np.clip(xh, lo, hi)) + k2 * u[:1]

        return rhs

    def _param_specs(self):
        k_range = positive_dimension(self.k_bounds, "k_bounds")
        out = {}
        for name in ("k1", "k2"):
            value = getattr(self, name)
            if value is None:
                out[name] = k_range
            elif isinstance(value, numbers.Real) and not isinstance(value, bool) and np.isfinite(value) and value > 0:
                out[name] = float(value)
            else:
                raise ValueError(f"{name} must be a finite number > 0 or None (searched); got {value!r}.")
        if self.ratio_bounds is not None:
            ratio = positive_dimension(self.ratio_bounds, "ratio_bounds")
            if self.k1 is None and self.k2 is None:
                del out["k2"]
                out["ratio"] = ratio
        return out

    def resolve_params(self, values=None):
        params = super().resolve_params(values)
        if "ratio" in params:  # searched as k2 / k1
            ratio = params.pop("ratio")
            params = {"k1": params["k1"], "k2": params["k1"] * ratio, **params}
        return params

    def _x0_specs(self):
        lo, hi = self._tank_bounds()
        if self.x0 is None:
            return [Uniform(lo, hi)]
        if isinstance(self.x0, bool) or not isinstance(self.x0, numbers.Real) or not lo <= self.x0 <= hi:
            raise ValueError(f"x0 must be a number within bounds {self.bounds!r} or None (searched); got {self.x0!r}.")
        return [float(self.x0)]

    def _state_names(self, p, q):
        return ["y0", "x1"]

    def _validate_data(self, u, y):
        """The measured lower level is a tank level too: below the tanks' lower bound it is refused."""
        lo, _ = self._tank_bounds()
        low = np.asarray(y, dtype=float) < lo
        if low.any():
            k = int(np.argmax(low.any(axis=1) if low.ndim > 1 else low))
            raise ValueError(f"y has levels below the tanks' lower bound {lo:g} (first at sample {k}: "
                             f"{np.asarray(y, dtype=float).reshape(len(y), -1)[k, 0]:g}); expected tank levels "
                             f">= {lo:g} (bounds={self.bounds!r}). Measured with an offset? Subtract it, or clip "
                             "small noise below the bound.")
        super()._validate_data(u, y)

    def default_library(self):
        """Quadratic polynomial in ``(y, x1, u)`` plus ``sqrt(y)``, ``sqrt(x1)``."""
        return ConcatLibrary([PolynomialLibrary(degree=2), SqrtLibrary(variables=[0, 1])])

    def _hidden_terms(self, params, x_col, u_col):
        lo, hi = self._tank_bounds()
        terms = [((x_col, SQRT, lo, hi),), ((u_col, POW, 1.0, 0.0),)]
        return terms, np.array([-params["k1"], params["k2"]])

    def structure(self, params, *, n_outputs, n_inputs):
        if n_outputs != 1 or n_inputs != 1:
            raise ValueError(
                f"TanksHiddenState models one input and one output; got {n_inputs} inputs and {n_outputs} outputs."
            )
        terms, _ = self._hidden_terms(params, 1, 2)
        lo, hi = self._tank_bounds()
        ylo, yhi = check_bounds(self.output_bounds, 1, name="output_bounds")
        return Structure(
            n_states=2,
            learned=(0,),
            output_index=(0,),
            fixed_terms=terms,
            fixed_coef=_FIXED_ROWS.matrix(params),
            state_names=["y0", "x1"],
            bounds=(np.array([ylo[0], lo]), np.array([yhi[0], hi])),
        )

    def physical_map(self, params, *, n_outputs, n_inputs):
        """The lower tank's row over the terms ``(sqrt(x1), u)``: ``x1' = -k1 sqrt(x1) + k2 u``.

        Examples
        --------
        >>> TanksHiddenState().physical_map({}, n_outputs=1, n_inputs=1).matrix({"k1": 0.5, "k2": 2.0}).tolist()
        [[0.0, -0.5], [0.0, 2.0]]
        """
        return _FIXED_ROWS

    def _simulate_hidden(self, u, y, dt, params):
        terms, coef = self._hidden_terms(params, 0, 1)
        _, x0 = self._split(params)
        rhs = TermsRHS(coef[:, None], terms, 1)
        return simulate(rhs, x0, u, dt, n_substeps=self.n_substeps, bounds=self._tank_bounds())


register_model(TanksHiddenState)
