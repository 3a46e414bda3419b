"""Libraries of Python functions and adapters for external libraries.

These cannot be compiled: their ``terms_`` is ``None`` and a model built on
them simulates through the slower Python path.
"""

import inspect
from itertools import combinations

import numpy as np

from ._base import BaseLibrary, ExternalLibrary, as_component, check_variables
from ._builtin import PolynomialLibrary

__all__ = ["CustomLibrary", "ExternalLibrary", "as_library"]


def _arity(f, i):
    if not callable(f):
        raise ValueError(f"functions[{i}] is not callable; got {f!r}.")
    try:
        params = inspect.signature(f).parameters.values()
    except (TypeError, ValueError):
        return 1
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    n = sum(1 for p in params if p.kind in kinds and p.default is inspect.Parameter.empty)
    if n < 1:
        raise ValueError(f"functions[{i}] takes no positional argument; expected a function of columns.")
    return n


class CustomLibrary(BaseLibrary):
    """Features from Python functions of the columns of ``Z``.

    A function of ``k`` positional arguments is applied to every combination
    of ``k`` distinct selected columns (one column at a time for ``k = 1``);
    it receives 1-D arrays and returns an array of the same length.

    Parameters
    ----------
    functions : sequence of callable
        Vectorised functions, e.g. ``np.sin`` or ``lambda x, y: x * np.tanh(y)``.
    names : sequence of (str or callable), optional
        One per function: a format string with one ``{}`` per argument
        (``"sin({})"``) or a callable taking the argument names. Default
        ``"f0(x0)"``-style names.
    variables : sequence of int, optional
        Columns of ``Z`` to use; default all.

    Attributes
    ----------
    terms_ : None
        Custom features are not compilable.
    n_output_features_ : int

    Examples
    --------
    >>> import numpy as np
    >>> lib = CustomLibrary(functions=[np.tanh, lambda a, b: a * b], names=["tanh({})", "{}*{}"])
    >>> lib.fit(np.zeros((1, 2))).get_feature_names_out(["y", "u"]).tolist()
    ['tanh(y)', 'tanh(u)', 'y*u']
    >>> lib.transform([[0.0, 2.0]]).round(4).tolist()
    [[0.0, 0.964, 0.0]]
    """

    def __init__(self, *, functions=None, names=None, variables=None):
        self.functions = functions
        self.names = names
        self.variables = variables

    def fit(self, Z, y=None):
        """Check the functions and list the (function, columns) pairs."""
        self._validate_Z(Z, reset=True)
        functions = self.functions
        if functions is None or callable(functions) or len(functions) == 0:
            raise ValueError(f"functions must be a non-empty sequence of callables; got {functions!r}.")
        if self.names is not None and (isinstance(self.names, str) or len(self.names) != len(functions)):
            raise ValueError(
                f"names must be None or hold one name per function ({len(functions)}); got {self.names!r}."
            )
        cols = check_variables(self.variables, self.n_features_in_)
        self.combinations_ = [
            (i, combo) for i, f in enumerate(functions) for combo in combinations(cols, _arity(f, i))
        ]
        if not self.combinations_:
            raise ValueError("CustomLibrary has no features: every function takes more arguments than variables.")
        self.terms_ = None
        self.n_output_features_ = len(self.combinations_)
        return self

    def _transform(self, Z):
        out = np.empty((Z.shape[0], len(self.combinations_)))
        for k, (i, combo) in enumerate(self.combinations_):
            value = np.asarray(self.functions[i](*(Z[:, c] for c in combo)), dtype=float)
            try:
                out[:, k] = np.broadcast_to(value, (Z.shape[0],))
            except ValueError as exc:
                raise ValueError(
                    f"functions[{i}] returned shape {value.shape}; expected ({Z.shape[0]},) (one value per sample)."
                ) from exc
        return out

    def _feature_names(self, names):
        out = []
        for i, combo in self.combinations_:
            args = [names[c] for c in combo]
            fmt = None if self.names is None else self.names[i]
            if fmt is None:
                out.append(f"f{i}({', '.join(args)})")
            elif callable(fmt):
                out.append(str(fmt(*args)))
            else:
                out.append(str(fmt).format(*args))
        return out


def as_library(obj):
    """Return ``obj`` as a sindybench library.

    Parameters
    ----------
    obj : library, pysindy feature library, scikit-learn transformer or None
        ``None`` gives ``PolynomialLibrary()`` (degree 2 with bias); a
        sindybench library is returned as is; anything else with ``fit`` and
        ``transform`` is wrapped in :class:`ExternalLibrary`.

    Examples
    --------
    >>> import pysindy as ps
    >>> type(as_library(ps.FourierLibrary())).__name__
    'ExternalLibrary'
    >>> as_library(None)
    PolynomialLibrary()
    """
    if obj is None:
        return PolynomialLibrary()
    return as_component(obj)
