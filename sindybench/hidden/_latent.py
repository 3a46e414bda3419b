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
another model with the same outputs. ``scale="driver"`` fixes it by holding the
coefficient of each latent row's driver (``u0`` or ``v0`` for ``z0``, ``z(j-1)``
for ``zj``) at 1 during the refinement; ``scale="units"`` holds it at
``1 / tau``, its value in a start whose static gain from the driver is 1 (the
latent state in the driver's units, so that a level of it, such as the kink
of a hinge ``max(z - L, 0)``, can be named from the data before the time
constant is searched); ``scale="range"`` by the latent state's finite bounds.
With hinge terms of a latent state in the library (:mod:`._latent_hard`), the
level in the library is held and the latent state's offset (the constant of
its row) is fitted instead: the same family of models as a free level with
the offset held, and :meth:`LatentHiddenState.gauge` gives the fitted level
in the coordinates where the latent state rests at 0. A mixing ``z -> z + k y`` that leaves the outputs
unchanged is moved, after the refinement, to the point where ``y_i'`` has no
linear ``y_i`` term, and refined there (the mixing gauge).
:meth:`LatentHiddenState.gauge` says which in words,
and gauge-free quantities (the poles and the static gain of the linearized
model at an operating point) come from
:func:`sindybench.estimation.latent_invariants`.
"""

import collections
import hashlib
import numbers
import threading
import warnings

import numpy as np
from scipy.optimize import least_squares
from sklearn.base import clone

from .._limits import check_memory
from .._validation import check_bounds
from ..io import register_model
from ..libraries import HINGE, LOGISTIC, POW, STEP, PolynomialLibrary
from ..refine import OutputErrorRefinement, PredictionErrorRefinement
from ..simulate import TermsRHS, simulate
from ._latent_hard import level_lines
from ._latent_starts import subspace_start, support_warnings
from ._base import Design, HiddenStrategy, Structure, bounds_space, linear_term, with_defaults

__all__ = ["LatentHiddenState"]

# the lag chains simulated last, by their inputs (see _lag_chain), and the most bytes they keep
_LAG_CHAINS = collections.OrderedDict()
_LAG_CHAINS_BYTES = 64 * 2**20
_LAG_CHAINS_LOCK = threading.Lock()


def _lag_chain(coef, terms, q, x0, drive, dt, bounds):
    """The lag chain's simulation from ``x0`` driven by ``drive`` (a copy of the one kept when asked before).

    A search asks for the same chain many times: every library, input hold and refined candidate of one
    record and time constant. The chain is a function of its inputs only, so the one simulated before is
    returned (the same numbers); the chains kept take at most ``_LAG_CHAINS_BYTES``, the oldest dropped first.
    """
    drive = np.ascontiguousarray(drive, dtype=float)
    key = (hashlib.blake2b(drive.tobytes(), digest_size=20).digest(), drive.shape, q, float(dt),
           *(np.asarray(a, dtype=float).tobytes() for a in (coef, x0, *bounds)))
    with _LAG_CHAINS_LOCK:
        z = _LAG_CHAINS.get(key)
        if z is not None:
            _LAG_CHAINS.move_to_end(key)
            return z.copy()
    z = simulate(TermsRHS(coef, terms, q), x0, drive[:, None], dt, n_substeps=4, bounds=bounds)
    if z.nbytes <= _LAG_CHAINS_BYTES:
        with _LAG_CHAINS_LOCK:
            _LAG_CHAINS[key] = z.copy()
            while sum(v.nbytes for v in _LAG_CHAINS.values()) > _LAG_CHAINS_BYTES:
                _LAG_CHAINS.popitem(last=False)
    return z


def forget_lag_chains():
    """Drop the kept lag chains (a search keeps them for itself; up to ``_LAG_CHAINS_BYTES`` in all)."""
    with _LAG_CHAINS_LOCK:
        _LAG_CHAINS.clear()


class LatentHiddenState(HiddenStrategy):
    """Latent states with learned sparse equations (fitted by simulation error).

    Parameters
    ----------
    n_latent : int, default=1
        Number of latent states (``z0, z1, ...``).
    order : {1, 2}, default=1
        Order of the outputs' equations: 1 learns ``y' = f(y, z, u)``; 2 adds
        the velocities ``v = y'`` (reconstructed by the estimator's
        differentiation, as :class:`DerivativeHiddenState` does), with the
        fixed rows ``y' = v`` and ``v' = f(y, v, z, u)`` learned.
    driver : {"input", "velocity", "output"}, default="input"
        What drives ``z0`` in the starting lag chain and fixes its gauge: the
        first input ``u0``, the first velocity ``v0`` (``order=2``; e.g. a
        hysteresis state) or the first output ``y0``.
    tau : float, optional
        Time constant of the starting lag chain; None = searched within
        ``bounds["tau"]`` (log scale).
    scale : {"driver", "units", "range"}, default="driver"
        The gauge. ``"driver"``: the coefficient of each latent row's driver
        is held at 1. ``"units"``: the start is ``z' = (d - z) / tau`` (static
        gain 1 from the driver ``d``: the latent state in the driver's units)
        and the coefficient of the driver is held at its start value
        ``1 / tau``. ``"range"``: each latent state ranges over
        ``latent_bounds`` (finite, e.g. ``(0, 10)`` for a tank that overflows
        at its top), which sets its scale; every coefficient of its row is
        free and the start's driver gain ``gain`` is searched.
    gain : float, optional
        Driver gain of the starting lags with ``scale="range"``; None =
        searched within ``bounds["gain"]`` (log scale). Unused with
        ``scale="driver"`` (the gain is the gauge, 1).
    offset : float or None, default=0.0
        Offset of the driver in the starting lag chain: ``z0`` starts as the
        lag of ``d - offset``. It moves the start's latent state against the
        levels of hinge terms in the library (held there: the level gauge);
        None = searched within ``bounds["offset"]`` (linear scale), as a
        free level is searched before the refinement moves it.
    bounds : dict, optional
        Search ranges: ``"tau"`` (time units of ``dt``; default
        ``(1e-3, 1e3)``), ``"gain"`` (default ``(1e-3, 1e3)``) and
        ``"offset"`` (no default: needed with ``offset=None``); a pair
        ``(low, high)`` is searched on a log scale, a dimension of
        :mod:`sindybench.search` (``LogNormal`` prior, ...) as it says.
    latent_bounds : (float, float), optional
        Simulation bounds of every latent state (in the gauge's units), e.g.
        ``(0, inf)`` for a level that cannot go negative; None = unbounded.
        With ``scale="range"``, a finite range is required.
    output_bounds : (float, float), optional
        Simulation bounds of the outputs (e.g. a sensor range).
    start : {"lag", "subspace", "auto"}, default="lag"
        The latent states' start. ``"lag"``: the lag chain of the driver
        (``tau`` searched). ``"subspace"``: the states of a linear
        state-space model of order ``n_outputs * order + n_latent`` fitted by
        subspace identification (MOESP, no search), in the coordinates
        orthogonal to the measured ones, scaled to the gauge. ``"auto"``:
        :class:`~sindybench.HiddenStateSINDy` searches every start of
        :meth:`starts` (the driver's lag, the output lag, the subspace
        model), each with its own inner search, refines the driver lag's
        ``n_refined`` best candidates and each other start's best side by
        side on the training part, scores each on the validation block only,
        and refits the best one (``model.starts_`` records each start,
        ``model.refined_results_`` each refined candidate).
    block_rows : int, optional
        Block rows of the subspace start's Hankel matrices (``start="subspace"``):
        about the samples of the slowest dynamics to resolve; None =
        ``max(2 n_states, 10)``.
    cascade : bool, default=False
        A cascade: the latent rows have no term of an output (or velocity),
        ``z' = f(z, u)`` and ``y' = g(y, z, u)`` (tanks in series, a thermal
        lag, an actuator before the plant). Those terms are set to 0 after the
        equation-error fit and never freed by the refinement
        (:meth:`coef_support`); the hard terms of the library then reach the
        latent rows through the latent state only. Needs ``driver="input"``
        and a lag start (``start="auto"`` tries the input lag only).
    levels : {"library", "range"}, default="library"
        Where hinge terms of the latent states start. ``"library"``: at the
        levels the library writes, fitted with the start. ``"range"`` (a warm
        start, :func:`~sindybench.hidden._latent_hard.fit_range_levels`): the
        model without the hinges (the library's last part, a
        ``TermsLibrary`` of hinge terms, left out) is fitted and refined
        first; the hinges are then placed at the 80 % (upper) and 20 %
        (lower) quantiles of its simulated latent state and refined from
        coefficients 0, kept only when the simulation error of the training
        record does not grow. One record only.

    Notes
    -----
    Use it with ``refine=OutputErrorRefinement(prune=...)``: without a
    refinement the latent rows stay the starting linear lags. The library
    must contain the linear term of each latent row's driver, whose
    coefficient fixes the gauge.

    Examples
    --------
    >>> s = LatentHiddenState(n_latent=1)
    >>> sorted(s.search_space())
    ['tau']
    >>> s.structure({"tau": 10.0}, n_outputs=1, n_inputs=1).state_names
    ['y0', 'z0']
    >>> print(s.gauge())
    z0: the coefficient of u0 in z0' is held at 1 by the refinement (scale gauge)
    >>> LatentHiddenState(order=2, driver="velocity").structure({"tau": 1.0}, n_outputs=1, n_inputs=1).state_names
    ['y0', 'v0', 'z0']
    >>> terms = [(), ((0, POW, 1.0, 0.0),), ((1, POW, 1.0, 0.0),), ((2, POW, 1.0, 0.0),)]  # 1, y0, z0, u0
    >>> LatentHiddenState(cascade=True).coef_support(terms, n_outputs=1, n_inputs=1)[:, 1].tolist()  # z0's row
    [True, False, True, True]
    """

    _physical = ("tau", "gain", "offset")

    def __init__(self, *, n_latent=1, order=1, driver="input", scale="driver", tau=None, gain=None, offset=0.0,
                 bounds=None, latent_bounds=None, output_bounds=None, start="lag", block_rows=None,
                 cascade=False, levels="library"):
        self.n_latent = n_latent
        self.order = order
        self.driver = driver
        self.scale = scale
        self.tau = tau
        self.gain = gain
        self.offset = offset
        self.bounds = bounds
        self.latent_bounds = latent_bounds
        self.output_bounds = output_bounds
        self.start = start
        self.block_rows = block_rows
        self.cascade = cascade
        self.levels = levels

    def _validate(self):
        if isinstance(self.n_latent, bool) or not isinstance(self.n_latent, numbers.Integral) or self.n_latent < 1:
            raise ValueError(f"n_latent must be an integer >= 1; got {self.n_latent!r}.")
        check_memory(f"LatentHiddenState(n_latent={self.n_latent}): the lag chain's coefficients",
                     (int(self.n_latent) + 1, int(self.n_latent)), advice="Expected a few latent states.")
        if self.order not in (1, 2) or isinstance(self.order, bool):
            raise ValueError(f"order must be 1 or 2; got {self.order!r}.")
        if self.driver not in _DRIVERS:
            raise ValueError(f"driver must be one of {_DRIVERS}; got {self.driver!r}.")
        if self.driver == "velocity" and self.order != 2:
            raise ValueError("driver='velocity' needs order=2 (the velocities are states only then).")
        if self.scale not in _SCALES:
            raise ValueError(f"scale must be one of {_SCALES}; got {self.scale!r}.")
        if self.offset is not None and (isinstance(self.offset, bool) or not isinstance(self.offset, numbers.Real)
                                        or not np.isfinite(self.offset)):
            raise ValueError(f"offset must be a finite number or None (searched); got {self.offset!r}.")
        for name in ("tau", "gain"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, numbers.Real)
                                      or not np.isfinite(value) or value <= 0):
                raise ValueError(f"{name} must be a finite number > 0 or None (searched); got {value!r}.")
        zlo, zhi = check_bounds(self.latent_bounds, 1, name="latent_bounds")
        if self.scale == "range" and not (np.isfinite(zlo[0]) and np.isfinite(zhi[0])):
            raise ValueError(f"scale='range' fixes the latent scale by its bounds; expected finite latent_bounds, "
                             f"got {self.latent_bounds!r}.")
        check_bounds(self.output_bounds, 1, name="output_bounds")
        if self.levels not in _LEVELS:
            raise ValueError(f"levels must be one of {_LEVELS}; got {self.levels!r}.")
        if self.start not in _STARTS:
            raise ValueError(f"start must be one of {_STARTS}; got {self.start!r}.")
        if self.block_rows is not None and (isinstance(self.block_rows, bool) or not isinstance(
                self.block_rows, numbers.Integral) or self.block_rows < 2):
            raise ValueError(f"block_rows must be None or an integer >= 2; got {self.block_rows!r}.")
        if not isinstance(self.cascade, (bool, np.bool_)):
            raise TypeError(f"cascade must be True or False; got {self.cascade!r}.")
        if self.cascade and (self.driver != "input" or self.start == "subspace"):
            raise ValueError(f"cascade=True needs driver='input' and a lag start (its latent rows have no output "
                             f"terms); got driver={self.driver!r}, start={self.start!r}.")
        self.search_space()

    def search_space(self):
        bounds = with_defaults(self.bounds, {"tau": (1e-3, 1e3), "gain": (1e-3, 1e3)})
        names = ("tau", "gain") if self.scale == "range" else ("tau",)
        if self.start == "subspace":
            names = ()  # the subspace model sets the start: nothing to search
        space = bounds_space(self, names, bounds, positive=True)
        if self.offset is None and self.start != "subspace":
            space.update(bounds_space(self, ("offset",), bounds))
        return space

    def resolve_params(self, values=None):
        values = dict(values or {})
        if self.scale in ("driver", "units"):
            values["gain"] = 1.0
        if self.start == "subspace":  # unused by the start; the initial state's first guess only
            values = {"tau": 1.0, "gain": 1.0, "offset": 0.0, **values}
        params = {name: getattr(self, name) if getattr(self, name) is not None else values.get(name)
                  for name in self._physical}
        if self.offset is not None and float(self.offset) == 0.0:
            del params["offset"]  # the default start: the parameters (and the model files) of before the offset
        elif params["offset"] is not None:
            params["offset"] = float(params["offset"])
        missing = [name for name, value in params.items() if value is None]
        if missing:
            raise ValueError(f"no value for the searched parameter {missing[0]!r}.")
        if self.scale == "driver":
            params["gain"] = 1.0
        elif self.scale == "units":  # static gain 1: the latent state in the driver's units
            params["gain"] = 1.0 / float(params["tau"])
        return params

    def refinable(self, params):
        return ()  # tau and gain set the start; the latent rows are learned

    def starts(self):
        """The starts ``start="auto"`` tries: ``[(name, strategy), ...]``.

        The lag of the driver (this strategy with ``start="lag"``), the lag
        of the first output (``driver="output"``, which also moves the scale
        gauge onto ``y0``; not repeated when the driver is already the
        output), and the subspace model (``start="subspace"``).

        Examples
        --------
        >>> [name for name, _ in LatentHiddenState(start="auto").starts()]
        ['input lag', 'output lag', 'subspace']
        """
        own = clone(self).set_params(start="lag")
        out = [(f"{self.driver} lag", own)]
        if self.cascade:  # the output lag and the subspace states mix the outputs into the latent rows
            return out
        if self.driver != "output":
            out.append(("output lag", clone(own).set_params(driver="output")))
        out.append(("subspace", clone(own).set_params(start="subspace")))
        return out

    def diverging_refinement(self, refine):
        """The refinement used when ``refine`` cannot start because the start's simulation diverges.

        An :class:`~sindybench.refine.OutputErrorRefinement` becomes a
        :class:`~sindybench.refine.PredictionErrorRefinement` (one-step
        predictions through the state estimator, which start from a
        diverging model) with the same budget, pruning level and freedoms;
        anything else: None (the start is kept, as for other strategies).
        """
        if not isinstance(refine, OutputErrorRefinement):
            return None
        return PredictionErrorRefinement(max_nfev=refine.max_nfev, prune=refine.prune, physical=refine.physical,
                                         initial_state=refine.initial_state, max_samples=refine.max_samples)

    def canonical_mixing(self, cand, x0, n_inputs):
        """A refined candidate in the mixing gauge (see :func:`canonical_mixing`), or None (a cascade: no mixing)."""
        return None if self.cascade else canonical_mixing(self, cand, x0, n_inputs)

    def coef_support(self, terms, *, n_outputs, n_inputs):
        """With ``cascade=True``, the entries that may be nonzero: every one but the output terms of the latent rows.

        A term with a factor of an output (or a velocity) is held at 0 in
        every latent row; None without a cascade (every entry may be nonzero).
        """
        if not self.cascade:
            return None
        if terms is None:
            raise ValueError("LatentHiddenState(cascade=True) needs a library of built-in terms; got a Python library.")
        n_meas = n_outputs * int(self.order)
        support = np.ones((len(terms), n_outputs + int(self.n_latent)), dtype=bool)  # learned: (y or v), z
        measured = [any(col < n_meas for col, *_ in term) for term in terms]
        support[np.asarray(measured, dtype=bool), n_outputs:] = False
        return support

    def check_fit(self, model, u, y, dt):
        """Warn when ``n_latent`` looks larger than the data support (see :func:`support_warnings`)."""
        for message in support_warnings(self, model, u, y, dt):
            warnings.warn(message, UserWarning, stacklevel=3)

    def default_library(self):
        """Quadratic polynomial in ``(y, [v,] z, u)``."""
        return PolynomialLibrary(degree=2)

    def gauge(self, model=None):
        """How each latent state's scale is fixed, in words; with ``model``, what its fit actually holds.

        Parameters
        ----------
        model : HiddenStateSINDy, optional
            A model fitted with this strategy (``equations()`` passes it). Its
            coefficients are read: the driver's coefficient as fitted (or that
            the row has none, and the scale is then free), whether a refinement
            held it, and how a mixing ``z -> z + k y`` of a latent state with
            an output that leaves the outputs unchanged within the model's
            library (a freedom the scale gauge does not fix) is fixed: by the
            mixing gauge (the linear ``y_i`` term of ``y_i'`` held at 0, see
            :func:`canonical_mixing`), by the sparse support (every ``k != 0``
            adds terms), or not at all.

        Returns
        -------
        str
            One line per latent state (more with a free mixing).

        Examples
        --------
        >>> print(LatentHiddenState(n_latent=2).gauge())
        z0: the coefficient of u0 in z0' is held at 1 by the refinement (scale gauge)
        z1: the coefficient of z0 in z1' is held at 1 by the refinement (scale gauge)
        >>> print(LatentHiddenState(scale="units").gauge())
        z0: the coefficient of u0 in z0' is held at its start value 1/tau by the refinement (scale gauge: static gain 1 at the start, z0 in u0's units); with hinge terms of z0, their levels are held and z0's offset is fitted (level gauge)
        """
        self._validate()
        q = int(self.n_latent)
        if self.scale == "range":
            return "\n".join(f"z{j}: ranges over {tuple(self.latent_bounds)} (range gauge)" for j in range(q))
        first = {"input": "u0", "velocity": "v0", "output": "y0"}[self.driver]
        drivers = [first] + [f"z{j}" for j in range(q - 1)]
        if model is None and self.scale == "units":
            return "\n".join(f"z{j}: the coefficient of {d} in z{j}' is held at its start value 1/tau by the "
                              f"refinement (scale gauge: static gain 1 at the start, z{j} in {d}'s units); with hinge "
                              f"terms of z{j}, their levels are held and z{j}'s offset is fitted (level gauge)"
                              for j, d in enumerate(drivers))
        if model is None:
            return "\n".join(f"z{j}: the coefficient of {d} in z{j}' is held at 1 by the refinement (scale gauge)"
                              for j, d in enumerate(drivers))
        return "\n".join(_fitted_gauge(self, model, drivers))

    def structure(self, params, *, n_outputs, n_inputs):
        if n_inputs < 1 and self.driver == "input":
            raise ValueError("driver='input' needs at least one input (the first one drives z0); got none.")
        p, q = n_outputs, int(self.n_latent)
        n_meas = p * int(self.order)
        ylo, yhi = check_bounds(self.output_bounds, 1, name="output_bounds")
        zlo, zhi = self._latent_range(params)
        lower = np.r_[np.full(p, ylo[0]), np.full(n_meas - p, -np.inf), np.full(q, zlo[0])]
        upper = np.r_[np.full(p, yhi[0]), np.full(n_meas - p, np.inf), np.full(q, zhi[0])]
        bounds = None if np.all(np.isinf(lower)) and np.all(np.isinf(upper)) else (lower, upper)
        names = [f"y{i}" for i in range(p)] + [f"v{i}" for i in range(n_meas - p)] + [f"z{j}" for j in range(q)]
        if self.order == 1:
            return Structure(n_states=p + q, learned=tuple(range(p + q)), output_index=tuple(range(p)),
                             state_names=names, bounds=bounds)
        fixed_coef = np.zeros((p, n_meas + q))
        fixed_coef[np.arange(p), np.arange(p)] = 1.0  # y_i' = v_i
        return Structure(n_states=n_meas + q, learned=tuple(range(p, n_meas + q)), output_index=tuple(range(p)),
                         fixed_terms=[linear_term(p + i) for i in range(p)], fixed_coef=fixed_coef,
                         state_names=names, bounds=bounds)

    def _latent_range(self, params):
        return check_bounds(self.latent_bounds, 1, name="latent_bounds")

    def _drivers(self, n_outputs):
        """Column in ``Z = [y, (v,) z, u]`` of each latent row's driver."""
        n_meas = n_outputs * int(self.order)
        q = int(self.n_latent)
        first = {"input": n_meas + q, "velocity": n_outputs, "output": 0}[self.driver]
        return [first if j == 0 else n_meas + j - 1 for j in range(q)]

    def _lags(self, drive, params, dt):
        """The starting latent trajectory: the lag chain driven by ``drive``, from its steady state."""
        tau, gain = float(params["tau"]), float(params["gain"])
        q = int(self.n_latent)
        coef = np.zeros((q + 1, q))
        terms = [((j, POW, 1.0, 0.0),) for j in range(q)] + [((q, POW, 1.0, 0.0),)]
        for j in range(q):
            coef[j, j] = -1.0 / tau
            coef[q if j == 0 else j - 1, j] = gain
        zlo, zhi = self._latent_range(params)
        x0 = np.clip(np.cumprod(np.full(q, tau * gain)) * drive[0], zlo[0], zhi[0])
        bounds = (np.full(q, zlo[0]), np.full(q, zhi[0]))
        z = _lag_chain(coef, terms, q, x0, drive, dt, bounds)
        return z, np.c_[z, drive] @ coef  # the lags and their exact derivatives

    def _measured(self, y, derivative):
        return y if self.order == 1 else np.c_[y, derivative(y)]

    def _drive(self, meas, u, n_outputs):
        """The signal that drives ``z0`` (columns: samples; 1-D rows: one sample)."""
        source = {"input": (u, 0), "velocity": (meas, n_outputs), "output": (meas, 0)}[self.driver]
        return source[0][..., source[1]]

    def design(self, u, y, dt, *, derivative, params):
        states = self._measured(y, derivative)
        if self.start == "subspace":
            z, z_dot = subspace_start(self, u, y, dt, self._drivers(y.shape[1]))
        else:
            z, z_dot = self._lags(self._drive(states, u, y.shape[1]) - float(params.get("offset", 0.0)), params, dt)
        return Design(states=np.c_[states, z], targets=np.c_[derivative(y, order=int(self.order)), z_dot])

    def refine_free(self, coef, terms, *, n_outputs, n_inputs):
        """Entries of the learned block freed by a refinement.

        The outputs' nonzero coefficients and their hinges and indicators of a
        latent state (a hinge the start never reaches has a zero coefficient,
        which the refinement must still move), and every term of the latent rows
        except, with ``scale="driver"`` or ``"units"``, each row's gauge term
        (its driver's linear term, held at its value).
        """
        if terms is None:
            raise ValueError("LatentHiddenState needs a library of built-in terms (compiled); got a Python library.")
        free = coef != 0
        support = self.coef_support(terms, n_outputs=n_outputs, n_inputs=n_inputs)
        terms = [tuple(t) for t in terms]
        n_meas = n_outputs * int(self.order)
        latent = range(n_meas, n_meas + int(self.n_latent))
        for t, term in enumerate(terms):
            if any(op in (HINGE, STEP, LOGISTIC) and col in latent for col, op, _, _ in term):
                free[t, :n_outputs] = True
        for j, col in enumerate(self._drivers(n_outputs)):
            free[:, n_outputs + j] = True
            if self.scale == "range":
                continue
            gauge = ((col, POW, 1.0, 0.0),)
            if gauge not in terms:
                raise ValueError(f"the library has no linear term of column {col} (the driver of z{j}); expected it "
                                 "in the library: its coefficient fixes the latent state's scale.")
            free[terms.index(gauge), n_outputs + j] = False
        return free if support is None else free & support

    def initial_state(self, u, y_init, dt, *, derivative, params, model):
        """Outputs (and velocities) from ``y_init``; latent states at rest for them and ``u[0]``."""
        q = int(self.n_latent)
        meas = np.asarray(self._measured(y_init, derivative)[0], dtype=float)
        zlo, zhi = self._latent_range(params)
        drive0 = self._drive(meas, np.asarray(u[0], dtype=float), y_init.shape[1]) - float(params.get("offset", 0.0))
        start = np.clip(np.cumprod(np.full(q, float(params["tau"]) * float(params["gain"]))) * drive0, zlo[0], zhi[0])

        def residual(z):
            return np.asarray(model.rhs(np.r_[meas, z], u[0]), dtype=float)[meas.size:]

        with np.errstate(all="ignore"):
            try:
                fit = least_squares(residual, start, max_nfev=50 * q)
                z0 = fit.x if np.all(np.isfinite(fit.x)) else start
            except ValueError:
                z0 = start
        return np.r_[meas, np.clip(z0, zlo[0], zhi[0])]  # at rest may lie past the range: the range holds it


def _fitted_gauge(strategy, model, drivers):
    """The lines of :meth:`LatentHiddenState.gauge` for a fitted ``model`` (see there)."""
    p = len(model.structure_.output_index)
    terms = [tuple(t) for t in (getattr(model.library_, "terms_", None) or ())]
    refined = getattr(model, "refinement_", None) is not None
    lines = []
    for j, (col, name) in enumerate(zip(strategy._drivers(p), drivers)):
        row = model.structure_.learned.index(p * int(strategy.order) + j)
        term = ((col, POW, 1.0, 0.0),)
        c = float(model.coef_[row, terms.index(term)]) if term in terms else 0.0
        if c == 0.0:
            why = "has no linear term " + name if term not in terms else "coefficient is 0"
            lines.append(f"z{j}: not fixed: z{j}' has no {name} term (the library {why}); the scale of z{j} is free")
            continue
        held = "held in the refinement" if refined else "from the starting lag, not held: no refinement ran"
        lines.append(f"z{j}: the coefficient of {name} in z{j}' is {c:.4g} (scale gauge, {held})")
    lines += level_lines(model)
    held = {tuple(h[:2]): h for h in ((model.refinement_ or {}).get("mixing_held") or [])} if refined else {}
    names = model.structure_.state_names
    for j in range(len(drivers)):
        for i in range(p):
            if (j, i) in held:
                _, _, t, r = held[(j, i)]
                c = float(model.coef_[r, t])
                lines.append(f"z{j}: the mixing z{j} -> z{j} + k y{i} (same outputs within this library) is fixed by "
                             f"holding the coefficient of y{i} in {names[model.structure_.learned[r]]}' at {c:.4g} "
                             "(mixing gauge, held in the refinement)")
                continue
            free = _mixing_is_free(strategy, model, j, i)
            if free == "support":
                lines.append(f"z{j}: z{j} -> z{j} + k y{i} gives the same outputs within this library but adds "
                             "terms for any k != 0: the model's support fixes this mixing (sparsity gauge)")
            elif free:
                lines.append(f"z{j}: z{j} -> z{j} + k y{i} gives the same outputs for any k within this library; "
                             "the gauge leaves this mixing free")
    return lines


def _mixing_coef(strategy, rhs, lib, s, states, n_inputs, j, i, rtol=1e-8, k=None):
    """``(k, coef, new)``: the learned block ``coef`` (n_terms, n_learned) of ``rhs`` and of its image under ``z_j -> z_j + k y_i``.

    The image ``T f(T^-1 x, u)`` at random points near ``states`` is regressed
    on the library's features there; ``new`` is None when the library does
    not reproduce it exactly (relative residual ``rtol``).
    """
    terms = getattr(lib, "terms_", None)
    if terms is None:
        return None
    n = s.n_states
    p = len(s.output_index)
    cz = p * int(strategy.order) + j
    rng = np.random.default_rng(0)
    states = np.asarray(states, dtype=float)
    states = states[np.all(np.isfinite(states), axis=1)]
    n_points = 4 * len(terms) + 10
    x = states[rng.integers(0, len(states), n_points)] if len(states) else np.zeros((n_points, n))
    x = x + rng.standard_normal(x.shape) * (np.std(states, axis=0) + 1.0) * 0.1 if len(states) else x
    u = rng.standard_normal((n_points, n_inputs))
    if k is None:
        k = 0.1 * (np.std(x[:, cz]) + 1.0) / (np.std(x[:, i]) + 1.0)
    back = x.copy()
    back[:, cz] -= k * x[:, i]  # T^-1 x: the original coordinates
    with np.errstate(all="ignore"):
        f0 = np.array([np.asarray(rhs(xb, ub), dtype=float) for xb, ub in zip(x, u)])
        f = np.array([np.asarray(rhs(xb, ub), dtype=float) for xb, ub in zip(back, u)])
        f[:, cz] += k * f[:, i]  # T f
        theta = lib.transform(np.c_[x, u])
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(f0)) and np.all(np.isfinite(theta))):
        return None
    learned = list(s.learned)
    coef = np.linalg.lstsq(theta, f0[:, learned], rcond=None)[0]
    target = f[:, learned]
    new = np.linalg.lstsq(theta, target, rcond=None)[0]
    if np.max(np.abs(theta @ new - target)) > rtol * max(np.max(np.abs(target)), 1.0):
        new = None
    return k, coef, new


def _drivers_unchanged(strategy, terms, s, coef, new):
    p = len(s.output_index)
    terms = [tuple(t) for t in terms]
    for jj, col in enumerate(strategy._drivers(p)):
        term = ((col, POW, 1.0, 0.0),)
        if term in terms:
            t, row = terms.index(term), s.learned.index(p * int(strategy.order) + jj)
            if abs(new[t, row] - coef[t, row]) > 1e-6 * (1.0 + abs(coef[t, row])):
                return False
    return True


def _mixing_is_free(strategy, model, j, i):
    """Whether ``z_j -> z_j + k y_i`` maps the fitted model onto another of its library, gauge terms unchanged.

    True: yes, within the model's support too (the mixing is free);
    ``"support"``: only by adding terms (the support fixes it); False: no.
    """
    states = model.states_ if not isinstance(model.states_, list) else model.states_[0]
    out = _mixing_coef(strategy, model.rhs_, model.library_, model.structure_, states, int(model.n_features_in_), j, i)
    if out is None or out[2] is None or not _drivers_unchanged(strategy, model.library_.terms_, model.structure_,
                                                               out[1], out[2]):
        return False
    support = model.coef_.T != 0
    return "support" if _adds_terms(out[2], support) else True


def _adds_terms(image, support):
    """Whether the learned block ``image`` has nonzero entries outside ``support``."""
    return bool(np.any(np.abs(image[~support]) > 1e-6 * max(np.max(np.abs(image)), 1.0)))


def canonical_mixing(strategy, cand, x0, n_inputs):
    """The refined candidate's image under the mixing that removes ``y_i`` from ``y_i'``, or None.

    When ``z_j -> z_j + k y_i`` maps the model onto another of its library
    (the scale gauge unchanged), the outputs do not fix ``k``. The canonical
    choice is the ``k`` that makes the coefficient of the linear term ``y_i``
    in ``y_i'`` zero (``a - b k = 0``, with ``b`` the coefficient of ``z_j``
    there), kept only when it has no more terms than the refined model
    (else the sparse support fixes ``k``, and :meth:`LatentHiddenState.gauge`
    says so). Returns ``(coef, states, x0, held)`` in the new coordinates
    (coefficients below 1e-9 of their row's largest set to 0), with
    ``held = [(j, i, term, row)]``; None when no mixing is free or it cannot
    be fixed this way. ``order=1`` and the scale gauge only; one mixing per
    call.
    """
    if strategy.scale != "driver" or int(strategy.order) != 1:
        return None
    s, lib = cand.structure, cand.library
    terms = [tuple(t) for t in (getattr(lib, "terms_", None) or ())]
    p = len(s.output_index)
    states, x0 = np.array(cand.design.states, dtype=float), np.array(x0, dtype=float)
    for i in range(p):
        term = ((i, POW, 1.0, 0.0),)
        if term not in terms:
            continue
        t, r = terms.index(term), list(s.learned).index(i)
        for j in range(int(strategy.n_latent)):
            out = _mixing_coef(strategy, cand.dynamics.rhs, lib, s, states, n_inputs, j, i)
            if out is None or out[2] is None or not _drivers_unchanged(strategy, terms, s, out[1], out[2]):
                continue
            k1, base, image = out
            slope = (base[t, r] - image[t, r]) / k1  # a(k) = a - b k
            if abs(slope) <= 1e-9 * (1.0 + abs(base[t, r])) or base[t, r] == 0.0:
                continue
            k = base[t, r] / slope
            out = _mixing_coef(strategy, cand.dynamics.rhs, lib, s, states, n_inputs, j, i, k=k)
            if out is None or out[2] is None or abs(out[2][t, r]) > 1e-6 * (1.0 + abs(base[t, r])):
                continue
            image = out[2]
            image[np.abs(image) < 1e-9 * np.max(np.abs(image), axis=0, keepdims=True)] = 0.0
            image[t, r] = 0.0
            if np.count_nonzero(image) > np.count_nonzero(cand.coef):
                continue  # the canonical point has more terms: the sparse support fixes k (gauge() says so)
            cz = p + j
            states[:, cz] += k * states[:, i]
            x0[cz] += k * x0[i]
            return image, states, x0, [(j, i, t, r)]  # one mixing at a time: the caller refines, then asks again
    return None


_DRIVERS = ("input", "velocity", "output")
_STARTS = ("lag", "subspace", "auto")
_LEVELS = ("library", "range")
_SCALES = ("driver", "units", "range")


register_model(LatentHiddenState)
