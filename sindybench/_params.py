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
