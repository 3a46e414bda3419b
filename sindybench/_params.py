"""Estimator parameters whose defaults are estimator instances (``optimizer=STLS()``).

A default instance in a signature is one object shared by every estimator
constructed without that argument. ``fit`` only ever uses clones of it, and
:class:`SharedDefaultsMixin` keeps ``set_params(optimizer__threshold=...)``
from changing it: the shared default is replaced by a clone of its own first.
"""

import inspect

from sklearn.base import clone

__all__ = ["SharedDefaultsMixin"]


class SharedDefaultsMixin:
    """``set_params`` that never changes a default instance shared through the signature.

    Examples
    --------
    >>> from sindybench import SINDy
    >>> a, b = SINDy(), SINDy()
    >>> a.optimizer is b.optimizer
    True
    >>> a.set_params(optimizer__threshold=0.5).optimizer.threshold, b.optimizer.threshold
    (0.5, 0.1)
    """

    def set_params(self, **params):
        signature = inspect.signature(type(self).__init__).parameters
        for key in params:
            name, nested, _ = key.partition("__")
            default = signature[name].default if name in signature else None
            if nested and hasattr(default, "get_params") and getattr(self, name, None) is default:
                setattr(self, name, clone(default))
        return super().set_params(**params)


class Constraint:
    """One declared parameter constraint: ``check(value, name, **options)`` from :mod:`sindybench._validation`.

    Parameters
    ----------
    check : callable
        ``check(value, name, **options)``, raising ``ValueError`` with a
        message that names the parameter, what it got and what is expected.
    **options
        Further keywords of ``check`` (``low=0``, ``options=("rk4", "euler")``).

    Examples
    --------
    >>> from sindybench._validation import check_integer
    >>> Constraint(check_integer, low=0)(-1, "input_delay")
    Traceback (most recent call last):
    ...
    ValueError: input_delay must be an integer >= 0; got -1.
    """

    def __init__(self, check, **options):
        self.check, self.options = check, options

    def __call__(self, value, name):
        return self.check(value, name, **self.options)

    def __repr__(self):
        options = ", ".join(f"{k}={v!r}" for k, v in self.options.items())
        return f"{self.check.__name__}({options})"


class ParameterChecksMixin:
    """``_validate_params()``: every parameter named in ``_parameter_constraints`` checked, in declaration order.

    The class declares ``_parameter_constraints = {"name": Constraint(...)}``
    (scikit-learn's declarative style, with this package's messages); a
    subclass extends its parent's dict. ``fit`` calls ``_validate_params()``
    first, and loading a model file runs it on the stored parameters.
    """

    _parameter_constraints = {}

    def _validate_params(self):
        for name, constraint in self._parameter_constraints.items():
            constraint(getattr(self, name), name)
