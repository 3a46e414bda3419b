"""The fitted continuous-time model: :class:`Dynamics`, and :func:`assemble`, the one way to build it.

Every estimator that simulates (``SINDy``, ``HiddenStateSINDy``) answers the
question "what are your dynamics?" with a :class:`Dynamics` value, built by
:func:`assemble` from the library's terms, the learned coefficients and the
fixed rows. Here, and only here, is decided whether the right-hand side is
compiled (a :class:`~sindybench.simulate.TermsRHS`, when the library has
symbolic terms and the fixed rows are terms) or runs on the Python path.
"""

from dataclasses import dataclass

import numpy as np

from .._validation import check_integer
from ._simulate import TermsRHS, simulate
from ._terms import check_terms, evaluate_terms

__all__ = ["Dynamics", "assemble", "check_output_index", "make_rhs"]


class _PythonRHS:
    """``f(x, u)`` of a model on the Python path (a library without terms, or Python fixed rows); picklable.

    Fixed rows first (``fixed_rhs(x, u)``, or ``fixed_terms`` with ``fixed_coef``),
    then the learned rows ``theta([x, u]) @ coef`` written over them.
    """

    def __init__(self, library, coef, learned, n_states, fixed_terms, fixed_coef, fixed_rhs):
        self.n_states, self.learned = n_states, list(learned)
        self.fixed_terms, self.fixed_rhs, self.fixed_coef = list(fixed_terms), fixed_rhs, fixed_coef
        self.library, self.coef = library, coef
        lib_terms = getattr(library, "terms_", None)
        if lib_terms is not None:  # evaluate only the active terms, without the transformer's checks
            active = np.flatnonzero(np.any(coef != 0, axis=1))
            self.active_terms, self.active_coef = [lib_terms[j] for j in active], coef[active]
        else:
            self.active_terms = None

    def __call__(self, x, u):
        z = np.concatenate([x, u])[None, :]
        if self.fixed_rhs is not None:
            dx = np.array(self.fixed_rhs(x, u), dtype=float).reshape(self.n_states)
        elif self.fixed_terms:
            dx = evaluate_terms(self.fixed_terms, z)[0] @ self.fixed_coef
        else:
            dx = np.zeros(self.n_states)
        if self.active_terms is not None:
            dx[self.learned] = evaluate_terms(self.active_terms, z)[0] @ self.active_coef
        else:
            # sindybench libraries: skip the per-call input validation of ``transform``
            lib = self.library
            transform = lib._transform if hasattr(lib, "_transform") else lib.transform
            dx[self.learned] = transform(z)[0] @ self.coef
        return dx


@dataclass(frozen=True, eq=False)
class Dynamics:
    """A fitted continuous-time model ``x' = f(x, u)`` and how to simulate it.

    Build it with :func:`assemble`; estimators keep it as ``dynamics_``.

    Attributes
    ----------
    rhs : TermsRHS or callable
        The right-hand side ``f(x, u)``: compiled (:class:`~sindybench.simulate.TermsRHS`)
        or on the Python path.
    terms : list of term tuples or None
        The terms of the full model, the library's first and then the fixed
        rows' (None on the Python path).
    coef : ndarray of shape (n_terms, n_states)
        Coefficients over ``terms`` (column ``i``: the derivative of state
        ``i``), learned and fixed rows together; on the Python path the
        library's rows are those of ``library.transform``.
    n_states : int
    state_names : tuple of str
    output_index : tuple of int
        The states that are the measured outputs, in the column order of ``y``.
    learned : tuple of int
        The states whose rows were learned (the others are fixed rows).
    bounds : (lower, upper) or None
        State bounds of simulations (see :func:`~sindybench.simulate.simulate`).
    dt : float or None
        Sampling interval (None: give ``dt`` or ``t`` to :meth:`simulate`).
    n_substeps : int
    method : {"rk4", "euler"}
    input_hold : {"zoh", "linear"}
    max_abs : float
        A state with ``|x| > max_abs`` counts as diverged.

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary
    >>> library = PolynomialLibrary(degree=1).fit(np.zeros((1, 2)))   # terms 1, x0, u0
    >>> dyn = assemble(library, [[0.0], [-1.0], [1.0]], n_states=1, dt=0.1)  # x0' = -x0 + u0
    >>> dyn.compiled, dyn.n_states, dyn.output_index
    (True, 1, (0,))
    >>> x = dyn.simulate(np.ones((11, 1)), [0.0])
    >>> round(float(x[-1, 0]), 4)
    0.6321
    """

    rhs: object
    terms: list
    coef: np.ndarray
    n_states: int
    state_names: tuple
    output_index: tuple
    learned: tuple
    bounds: object = None
    dt: float = None
    n_substeps: int = 1
    method: str = "rk4"
    input_hold: str = "zoh"
    max_abs: float = np.inf
    library: object = None
    fixed_terms: list = ()
    fixed_rhs: object = None

    @property
    def compiled(self):
        """Whether the right-hand side is made of terms (compiled, exact sensitivities in a refinement).

        Rows that numba compiled from a Python ``fixed_rhs`` simulate on the
        compiled path too, but are not terms: a refinement differentiates
        them by finite differences.
        """
        return self.terms is not None

    @property
    def settings(self):
        """Keyword arguments of :func:`~sindybench.simulate.simulate` (and of the refinement)."""
        return dict(n_substeps=self.n_substeps, method=self.method, input_hold=self.input_hold, bounds=self.bounds,
                    max_abs=self.max_abs)

    @classmethod
    def from_terms(cls, terms, coef, *, dt=None, output_index=None, state_names=None, bounds=None, n_substeps=1,
                   method="rk4", input_hold="zoh", max_abs=np.inf):
        """The compiled model ``x' = terms([x, u]) @ coef`` (every row learned), without a library.

        Examples
        --------
        >>> from sindybench.dynamics import POW
        >>> dyn = Dynamics.from_terms([((0, POW, 1, 0),)], [[-1.0]], dt=0.1)  # x0' = -x0
        >>> dyn.compiled, dyn.output_index, round(float(dyn.simulate(np.zeros((11, 0)), [1.0])[-1, 0]), 4)
        (True, (0,), 0.3679)
        """
        coef = np.asarray(coef, dtype=float)
        if coef.ndim == 1:
            coef = coef.reshape(-1, 1)
        terms = check_terms(terms)
        if coef.shape[0] != len(terms):
            raise ValueError(f"coef has {coef.shape[0]} rows; expected {len(terms)} (one per term).")
        n_states = coef.shape[1]
        names = tuple(f"x{i}" for i in range(n_states)) if state_names is None else tuple(state_names)
        outputs = tuple(range(n_states)) if output_index is None else check_output_index(output_index, n_states)
        return cls(rhs=TermsRHS(coef, terms, n_states), terms=terms, coef=coef, n_states=n_states, state_names=names,
                   output_index=outputs, learned=tuple(range(n_states)), bounds=bounds, dt=dt, n_substeps=n_substeps,
                   method=method, input_hold=input_hold, max_abs=max_abs)

    def rhs_for(self, coef):
        """The right-hand side with another full coefficient matrix (the shape of :attr:`coef`)."""
        coef = np.asarray(coef, dtype=float)
        if self.terms is not None:
            return TermsRHS(coef, self.terms, self.n_states)
        n_lib = coef.shape[0] - len(self.fixed_terms)
        # all rows learned: a view, so that the Python path's products round as with ``coef`` itself
        learned = coef[:n_lib] if self.learned == tuple(range(self.n_states)) else coef[:n_lib, list(self.learned)]
        return _PythonRHS(self.library, learned, self.learned, self.n_states, self.fixed_terms, coef[n_lib:],
                          self.fixed_rhs)

    def simulate(self, u, x0, *, dt=None, t=None, on_divergence="raise"):
        """Open-loop simulation from ``x0`` driven by ``u`` (see :func:`sindybench.simulate.simulate`).

        Parameters
        ----------
        u : array-like of shape (n_samples, n_inputs)
        x0 : array-like of shape (n_states,)
        dt : float, optional
            Step instead of :attr:`dt`.
        t : array-like of shape (n_samples,), optional
            Sample times instead of a step.
        on_divergence : {"raise", "nan"}, default="raise"

        Returns
        -------
        ndarray of shape (n_samples, n_states)
        """
        if t is None and dt is None:
            dt = self.dt
        return simulate(self.rhs, x0, u, dt, t=t, on_divergence=on_divergence, **self.settings)


def assemble(library, coef, *, n_states=None, learned=None, fixed_terms=(), fixed_coef=None, fixed_rhs=None,
             output_index=None, state_names=None, bounds=None, dt=None, n_substeps=1, method="rk4",
             input_hold="zoh", max_abs=np.inf):
    """The :class:`Dynamics` of a fitted library, its coefficients and the fixed rows.

    Parameters
    ----------
    library : fitted library
        Its ``terms_`` (None for custom or external libraries, which run on
        the Python path through ``transform``).
    coef : array-like of shape (n_library_terms, n_learned)
        Column ``k`` holds the coefficients of the derivative of state ``learned[k]``.
    n_states : int, optional
        Number of states (default: ``n_learned``).
    learned : sequence of int, optional
        The states whose rows are learned (default: all of them).
    fixed_terms : sequence of term tuples, default=()
        Terms of the fixed rows (over ``Z = [x, u]``).
    fixed_coef : array-like of shape (len(fixed_terms), n_states), optional
        Coefficients of the fixed rows; the learned states' columns are ignored.
    fixed_rhs : callable or None
        ``f(x, u) -> dxdt`` for fixed rows written in Python (replaces
        ``fixed_terms``). The model then runs on the Python path, unless
        ``fixed_rhs.compiled(coef, terms, n_states)`` (a
        ``ParametricHiddenState`` right-hand side that numba compiles) returns
        a compiled right-hand side of the terms and the rows.
    output_index : sequence of int, optional
        The states that are the outputs (default: all of them).
    state_names : sequence of str, optional
        Default ``x0, x1, ...``.
    bounds, dt, n_substeps, method, input_hold, max_abs
        Simulation settings (see :class:`Dynamics`).

    Returns
    -------
    Dynamics
    """
    coef = np.asarray(coef, dtype=float)
    if coef.ndim == 1:
        coef = coef.reshape(-1, 1)
    n_states = coef.shape[1] if n_states is None else int(n_states)
    learned = tuple(range(n_states)) if learned is None else tuple(int(i) for i in learned)
    if coef.shape[1] != len(learned):
        raise ValueError(f"coef has {coef.shape[1]} columns; expected {len(learned)} (one per learned state).")
    fixed_terms = list(fixed_terms)
    fixed = np.zeros((len(fixed_terms), n_states)) if fixed_coef is None else np.array(fixed_coef, dtype=float)
    fixed = fixed.reshape(len(fixed_terms), n_states)
    fixed[:, list(learned)] = 0.0
    lib_terms = getattr(library, "terms_", None)
    n_lib = coef.shape[0]
    if not fixed_terms and learned == tuple(range(n_states)):
        # keeps the memory layout of ``coef``: the refinement's matrices, and so the
        # Python path's products, round exactly as they did before ``assemble``
        full = np.array(coef, dtype=float, order="K")
    else:
        full = np.zeros((n_lib + len(fixed_terms), n_states))
        full[:n_lib, list(learned)] = coef
        full[n_lib:] = fixed
    if lib_terms is not None and fixed_rhs is None:
        terms = list(lib_terms) + fixed_terms
        rhs = TermsRHS(full, terms, n_states)
    else:
        terms, rhs = None, None
        compile_rows = getattr(fixed_rhs, "compiled", None)  # Python fixed rows that numba may compile
        if lib_terms is not None and compile_rows is not None:  # they replace the fixed terms
            rhs = compile_rows(full[:n_lib], list(lib_terms), n_states)
        if rhs is None:
            rhs = _PythonRHS(library, coef, learned, n_states, fixed_terms, fixed, fixed_rhs)
    names = tuple(f"x{i}" for i in range(n_states)) if state_names is None else tuple(state_names)
    outputs = tuple(range(n_states)) if output_index is None else check_output_index(output_index, n_states)
    return Dynamics(rhs=rhs, terms=terms, coef=full, n_states=n_states, state_names=names, output_index=outputs,
                    learned=learned, bounds=bounds, dt=dt, n_substeps=n_substeps, method=method,
                    input_hold=input_hold, max_abs=max_abs, library=library, fixed_terms=fixed_terms,
                    fixed_rhs=fixed_rhs)


def check_output_index(output_index, n_states):
    """Return ``output_index`` as a tuple of distinct state indices in ``[0, n_states)``, or raise ``ValueError``.

    The compiled filter and k-step kernels index states by these values
    without bounds checks, so every path into them checks here first.

    Examples
    --------
    >>> check_output_index([1, 0], 2)
    (1, 0)
    >>> check_output_index((5,), 2)
    Traceback (most recent call last):
    ...
    ValueError: output_index[0] must be an integer in [0, 1]; got 5.
    """
    index = output_index
    if isinstance(index, (str, bytes)) or not hasattr(index, "__len__") or len(index) == 0:
        raise ValueError(f"output_index must be a non-empty sequence of state indices; got {index!r}.")
    index = tuple(check_integer(i, f"output_index[{j}]", low=0, high=n_states - 1) for j, i in enumerate(index))
    if len(set(index)) != len(index):
        raise ValueError(f"output_index = {index} repeats a state; expected each measured state once.")
    return index


def make_rhs(library, coef, n_states):
    """Right-hand side of a fitted library and its coefficients: ``assemble(library, coef).rhs``.

    A :class:`~sindybench.simulate.TermsRHS` (compiled simulation) when the
    library has ``terms_``, else a Python callable through ``library.transform``.

    Examples
    --------
    >>> from sindybench.libraries import PolynomialLibrary
    >>> lib = PolynomialLibrary(degree=1).fit(np.zeros((1, 2)))
    >>> make_rhs(lib, np.array([[0.0], [-1.0], [1.0]]), 1)
    TermsRHS(n_terms=3, n_active=2, n_states=1)
    """
    coef = np.asarray(coef, dtype=float)
    if getattr(library, "terms_", None) is None and (
            coef.ndim != 2 or coef.shape != (library.n_output_features_, n_states)):
        raise ValueError(f"coef has shape {coef.shape}; expected ({library.n_output_features_}, {n_states}).")
    return assemble(library, coef, n_states=n_states).rhs
