"""A hidden state with user-supplied parametric dynamics ``x_h' = rhs(x_h, y, u, **params)``."""

import inspect
import itertools
import numbers

import numpy as np

from .._limits import check_size
from .._validation import check_bounds, check_integer, check_option
from ..io import register_model
from ..dynamics._rows import ParametricRows, compiled_rows
from ..search import LogUniform, Uniform, as_dimension
from ..simulate import simulate
from ._base import Design, HiddenStrategy, InitialFit, Structure

__all__ = ["ParametricHiddenState"]

#: Points of the initial-state grid (all hidden states together): each is a simulation at every ``predict``.
MAX_GRID_POINTS = 10_000
#: Integration steps of that grid search: points x window samples x the model's sub-steps per sample (measured
#: on the cascaded-tanks model: 2e6 steps in 10,000 simulations took 3.6 s, 8200 steps of the default 0.05 s).
MAX_GRID_STEPS = 10**6

_INITS = ("simulation", "derivative")


def _middle(dim):
    """The middle of a searched range (geometric for log ranges, the median of a prior)."""
    if isinstance(dim, LogUniform):
        return float(np.sqrt(dim.low * dim.high))
    if isinstance(dim, Uniform):
        return 0.5 * (dim.low + dim.high)
    return dim.from_unit(0.5)


class ParametricHiddenState(HiddenStrategy):
    """Hidden states with known parametric dynamics; the outputs' dynamics are learned.

    States are ``(y_0, ..., y_{p-1}, x_h0, ..., x_h{q-1})``: the measured outputs
    followed by the hidden states. The hidden states follow the user's model
    ``x_h' = rhs(x_h, y, u, **params)``; on training data they are reconstructed
    by simulating it (with the measured ``y`` as an input) from an initial
    hidden state, and the library learns ``y' = Theta^T phi(y, x_h, u)``. The
    parameters given as ranges and the training initial hidden state are
    searched by ``HiddenStateSINDy`` (validation simulation error).

    On new data the initial hidden state is found on a grid over ``x0_bounds``:
    with ``init="simulation"`` (default) by the simulation error over the first
    ``init_size`` samples (then refined within ``x0_bounds`` by
    :func:`~sindybench.refine.estimate_initial_state`), with
    ``init="derivative"`` by matching the model's ``y'(0)`` to the measured one.

    Parameters
    ----------
    rhs : callable
        ``rhs(x_h, y, u, **params) -> dx_h/dt`` with 1-D arrays ``x_h`` (q,),
        ``y`` (p,), ``u`` (n_inputs,). Written with NumPy, it is compiled by
        numba (the model then simulates on the compiled path); a function numba
        cannot compile runs on the Python path, with a warning.
    params : dict, optional
        ``name -> value`` (fixed) or ``name -> dimension`` (searched:
        ``Uniform(low, high)``, ``LogUniform``, a ``Normal`` or ``LogNormal``
        prior of :mod:`sindybench.search`, or the older ``(low, high[, log])``).
    x0_bounds : (low, high) or sequence of (low, high)
        Range of each hidden state's initial value (one pair per hidden state;
        a single pair means one hidden state).
    bounds : (lower, upper), optional
        Simulation bounds of the hidden states (scalars or one per hidden state).
    init : {"simulation", "derivative"}, default="simulation"
        How the initial hidden state is estimated on new data.
    init_size : int, default=50
        Samples of the initialisation window on new data.
    grid_size : int, default=11
        Grid points per hidden state for the initial-state search (the best
        point is then refined with ``init="simulation"``).
    n_substeps : int, default=4
        RK4 steps per sample when reconstructing the hidden states.
    hidden_names : sequence of str, optional
        Names of the hidden states (default ``h0, h1, ...``).

    Examples
    --------
    >>> def leak(xh, y, u, *, a):
    ...     return -a * xh + u
    >>> s = ParametricHiddenState(leak, params={"a": (0.1, 2.0)}, x0_bounds=(0.0, 1.0))
    >>> sorted(s.search_space())
    ['a', 'x0']
    """

    def __init__(self, rhs=None, params=None, x0_bounds=None, *, bounds=None, init="simulation", init_size=50,
                 grid_size=11, n_substeps=4, hidden_names=None):
        self.rhs = rhs
        self.params = params
        self.x0_bounds = x0_bounds
        self.bounds = bounds
        self.init = init
        self.init_size = init_size
        self.grid_size = grid_size
        self.n_substeps = n_substeps
        self.hidden_names = hidden_names

    # ------------------------------------------------------------- the model
    def _hidden_rhs(self):
        """The user's ``rhs`` (subclasses supply a preset)."""
        return self.rhs

    def _param_specs(self):
        """``name -> float`` (fixed) or ``name -> dimension`` (searched)."""
        params = {} if self.params is None else self.params
        if not isinstance(params, dict):
            raise ValueError(f"params must be a dict name -> value or dimension (Uniform(low, high), ...) or "
                             f"(low, high[, log]); got {params!r}.")
        out = {}
        for name, spec in params.items():
            if isinstance(spec, numbers.Real) and not isinstance(spec, bool):
                if not np.isfinite(spec):
                    raise ValueError(f"params[{name!r}] = {spec!r}; expected a finite number.")
                out[name] = float(spec)
            else:
                out[name] = as_dimension(spec, name=f"params[{name!r}]", real=True)
        return out

    def _x0_specs(self):
        """One entry per hidden state: a range ``Uniform(low, high)`` (or a fixed float, in subclasses)."""
        x0 = self.x0_bounds
        if x0 is None:
            raise ValueError("x0_bounds is None; expected (low, high) for each hidden state.")
        arr = np.asarray(x0, dtype=object)
        if arr.ndim == 0:
            raise ValueError(f"x0_bounds = {x0!r}; expected (low, high) or one (low, high) per hidden state.")
        pairs = [x0] if arr.ndim == 1 else list(x0)
        return [as_dimension(p, name="x0_bounds", real=True, log=False) for p in pairs]

    def _x0_names(self, n):
        return ["x0"] if n == 1 else [f"x0_{i}" for i in range(n)]

    def _validate(self):
        if not callable(self._hidden_rhs()):
            raise ValueError(f"rhs must be a callable rhs(x_h, y, u, **params); got {self.rhs!r}.")
        check_option(self.init, "init", _INITS)
        check_integer(self.init_size, "init_size")
        check_integer(self.grid_size, "grid_size", low=2)
        check_integer(self.n_substeps, "n_substeps")
        n_hidden = len(self._x0_specs())
        self._grid_points()
        self._hidden_bounds(n_hidden)
        if self.hidden_names is not None and len(self.hidden_names) != n_hidden:
            raise ValueError(f"hidden_names has {len(self.hidden_names)} names; expected {n_hidden}.")
        self.search_space()

    def _validate_data(self, u, y):
        """Call the hidden dynamics once, on the first sample, before any search.

        A signature that does not take ``(x_h, y, u, **params)`` or a result
        that is not one value per hidden state would otherwise fail every
        candidate of the search alike.
        """
        rhs = self._hidden_rhs()
        name = getattr(rhs, "__qualname__", None) or repr(rhs)
        params, x_h = self._split(self.resolve_params({k: _middle(s) for k, s in self.search_space().items()}))
        q = x_h.shape[0]
        call = f"rhs(x_h, y, u{''.join(f', {k}=...' for k in params)})"
        try:
            signature = inspect.signature(rhs)
        except (TypeError, ValueError):  # no signature to read (a builtin): the call below tells
            signature = None
        if signature is not None:
            try:
                signature.bind(x_h, y[0], u[0], **params)
            except TypeError as exc:
                raise ValueError(
                    f"rhs {name}{signature} cannot be called as {call} ({exc}); expected a function of the hidden "
                    f"states, outputs and inputs taking the parameters {sorted(params)} as keywords."
                ) from exc
        out = rhs(x_h, y[0], u[0], **params)
        try:
            shape = np.shape(out)
            out = np.asarray(out, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"rhs {name} returned {out!r} for the first sample; expected {q} numbers.") from exc
        if out.size != q:
            raise ValueError(
                f"rhs {name} returned shape {shape} for the first sample (x_h of shape ({q},), y of shape "
                f"({y.shape[1]},), u of shape ({u.shape[1]},)); expected {q} value{'s' * (q > 1)}, the derivative "
                f"of each hidden state (x0_bounds gives {q})."
            )

    def _hidden_bounds(self, n_hidden):
        return check_bounds(self.bounds, n_hidden)

    def search_space(self):
        space = {k: v for k, v in self._param_specs().items() if not isinstance(v, float)}
        specs = self._x0_specs()
        for name, spec in zip(self._x0_names(len(specs)), specs):
            if not isinstance(spec, float):
                space[name] = spec
        return space

    def resolve_params(self, values=None):
        values = {} if values is None else dict(values)
        out = {}
        specs = self._x0_specs()
        named = list(self._param_specs().items()) + list(zip(self._x0_names(len(specs)), specs))
        for name, spec in named:
            if isinstance(spec, float):
                out[name] = spec
            elif name in values:
                out[name] = float(values[name])
            else:
                raise ValueError(f"no value for the searched parameter {name!r}.")
        return out

    def _grid_points(self):
        """Points of the initial-state grid (``grid_size`` per hidden state with a range), at most 10,000."""
        n_ranged = sum(lo < hi for lo, hi in self._init_ranges())
        grid_size = check_integer(self.grid_size, "grid_size", low=2)
        check_size(f"{type(self).__name__}(grid_size={grid_size}): the initial-state grid",
                   {f"points of hidden state {i}": grid_size for i in range(n_ranged)},
                   limit=MAX_GRID_POINTS, unit="grid points", advice="Use a smaller grid_size.")
        return grid_size ** n_ranged

    def _init_ranges(self):
        """Search range of each initial hidden state on new data: its ``x0_bounds``,
        or the simulation bounds when the training value is fixed."""
        specs = self._x0_specs()
        lo, hi = self._hidden_bounds(len(specs))
        ranges = []
        for i, spec in enumerate(specs):
            if not isinstance(spec, float):
                ranges.append(spec.support())
            elif np.isfinite(lo[i]) and np.isfinite(hi[i]):
                ranges.append((float(lo[i]), float(hi[i])))
            else:
                ranges.append((spec, spec))
        return ranges

    def _split(self, params):
        """Physical parameters for ``rhs`` and the training initial hidden state."""
        n = len(self._x0_specs())
        x0_names = self._x0_names(n)
        phys = {k: v for k, v in params.items() if k not in x0_names}
        return phys, np.array([params[k] for k in x0_names], dtype=float)

    # -------------------------------------------------------------- protocol
    def refinable(self, params):
        """The parameters of ``rhs`` (not the training initial hidden state)."""
        return tuple(self._split(params)[0])

    def structure(self, params, *, n_outputs, n_inputs):
        p = n_outputs
        q = len(self._x0_specs())
        phys, _ = self._split(params)
        lo, hi = self._hidden_bounds(q)
        return Structure(
            n_states=p + q,
            learned=tuple(range(p)),
            output_index=tuple(range(p)),
            state_names=self._state_names(p, q),
            bounds=(np.r_[np.full(p, -np.inf), lo], np.r_[np.full(p, np.inf), hi]),
            fixed_rhs=ParametricRows(self._hidden_rhs(), phys, p, q),
        )

    def _state_names(self, p, q):
        hidden = list(self.hidden_names) if self.hidden_names is not None else [f"h{i}" for i in range(q)]
        return [f"y{j}" for j in range(p)] + hidden

    def _simulate_hidden(self, u, y, dt, params):
        """Hidden trajectory driven by the inputs and the measured outputs."""
        phys, x0 = self._split(params)
        rhs, q = self._hidden_rhs(), len(x0)
        n_u, n_y = u.shape[1], y.shape[1]
        f = compiled_rows(np.zeros((0, q)), [], q, rhs, phys, ((0, q), (q + n_u, q + n_u + n_y), (q, q + n_u)), 0)
        if f is not None:
            return simulate(f, x0, np.hstack([u, y]), dt, n_substeps=self.n_substeps, input_hold="linear",
                            bounds=self._hidden_bounds(q))

        def f(xh, uy):
            return np.asarray(rhs(xh, uy[u.shape[1]:], uy[: u.shape[1]], **phys), dtype=float).reshape(q)

        return simulate(f, x0, np.hstack([u, y]), dt, n_substeps=self.n_substeps, input_hold="linear",
                        bounds=self._hidden_bounds(q))

    def design(self, u, y, dt, *, derivative, params):
        hidden = self._simulate_hidden(u, y, dt, params)
        return Design(states=np.hstack([y, hidden]), targets=derivative(y, 1))

    def initial_state(self, u, y_init, dt, *, derivative, params, model):
        """First guess: the measured outputs and the best hidden states of a grid over their ranges.

        The grid point whose simulation best matches the first ``init_size``
        samples (``init="simulation"``; then refined as :meth:`initial_fit`
        says), or whose ``y'(0)`` best matches the measured one
        (``init="derivative"``).
        """
        p = y_init.shape[1]
        n_w = max(2, min(self.init_size, y_init.shape[0], u.shape[0]))
        y_w, u_w = y_init[:n_w], u[:n_w]
        if self.init == "simulation":  # each point is a simulation of the window: bound their product first
            check_size(f"{type(self).__name__}(grid_size={self.grid_size}, init_size={self.init_size}): the "
                       "initial-state grid search", {"grid points": self._grid_points(), "window samples": n_w,
                                                     "sub-steps per sample": getattr(model, "n_substeps", 1)},
                       limit=MAX_GRID_STEPS, unit="integration steps",
                       advice="Use a smaller grid_size or init_size (or fewer sub-steps).")
        grids = [np.linspace(lo, hi, self.grid_size) if lo < hi else np.array([lo]) for lo, hi in self._init_ranges()]
        candidates = np.array(list(itertools.product(*grids)))
        y0 = y_w[0]

        if self.init == "derivative":
            yd0 = derivative(y_w, 1)[0]

            def cost(xh):
                return float(np.sum((model.rhs(np.r_[y0, xh], u_w[0])[:p] - yd0) ** 2))
        else:
            def cost(xh):
                y_sim = model.simulate(np.r_[y0, xh], u_w)[:, :p]
                err = np.mean((y_sim - y_w) ** 2)
                return float(err) if np.isfinite(err) else np.inf

        costs = np.array([cost(c) for c in candidates])
        return np.r_[y0, candidates[int(np.argmin(costs))]]

    def initial_fit(self, params, *, n_outputs, n_inputs):
        """With ``init="simulation"``: the hidden states with a range, within it, over ``init_size`` samples.

        Examples
        --------
        >>> s = ParametricHiddenState(lambda xh, y, u: -xh, x0_bounds=(0.0, 2.0))
        >>> s.initial_fit({"x0": 1.0}, n_outputs=1, n_inputs=1)
        InitialFit(n_samples=50, free=(1,), bounds=(array([-inf,  0.]), array([inf,  2.])))
        """
        if self.init != "simulation":
            return None
        ranges = self._init_ranges()
        free = tuple(n_outputs + i for i, (lo, hi) in enumerate(ranges) if lo < hi)
        lower = np.r_[np.full(n_outputs, -np.inf), [lo for lo, _ in ranges]]
        upper = np.r_[np.full(n_outputs, np.inf), [hi for _, hi in ranges]]
        return InitialFit(self.init_size, free=free, bounds=(lower, upper))


register_model(ParametricHiddenState, functions=("rhs",))
