"""Accept pysindy differentiation objects wherever a sindybench method is expected."""

import numpy as np

from ._auto import data_differentiation
from ._base import BaseDifferentiation
from ._local import FiniteDifference, SavitzkyGolay

__all__ = ["PySINDyDifferentiation", "as_differentiation"]


class PySINDyDifferentiation(BaseDifferentiation):
    """Give a pysindy differentiation object the ``derivative`` interface.

    ``method`` is called as ``method._differentiate(y, t)`` (or ``method(y, t)``)
    with ``t`` the uniform step or the sample times. pysindy methods give first
    derivatives only, so ``order=2`` applies the method twice (the one place in
    sindybench where a second derivative is the derivative of a derivative).
    The method's parameters are reachable as ``method__<name>``.

    Parameters
    ----------
    method : pysindy.differentiation.BaseDifferentiation
        For example ``pysindy.differentiation.SmoothedFiniteDifference()``.

    Examples
    --------
    >>> from pysindy.differentiation import FiniteDifference as PSFD
    >>> d = PySINDyDifferentiation(method=PSFD(order=2))
    >>> d.derivative(np.arange(5.0) ** 2, dt=1.0)
    array([0., 2., 4., 6., 8.])
    """

    def __init__(self, method=None):
        self.method = method

    def _validate_params(self):
        if not (hasattr(self.method, "_differentiate") or callable(self.method)):
            raise ValueError(
                f"method must be a pysindy differentiation object (with _differentiate); got {self.method!r}."
            )

    def _call(self, y, t, step):
        fn = getattr(self.method, "_differentiate", self.method)
        out = np.asarray(fn(y, t if step is None else step), dtype=float).reshape(y.shape)
        bad = ~np.isfinite(out)
        if bad.any():
            i = int(np.argwhere(bad)[0][0])
            raise ValueError(
                f"{type(self.method).__name__} returned NaN or inf (first at sample {i}); expected finite "
                "derivatives everywhere (for pysindy's FiniteDifference set drop_endpoints=False)."
            )
        return out

    def _derivative(self, y, t, step, order):
        out = self._call(y, t, step)
        return out if order == 1 else self._call(out, t, step)


def as_differentiation(obj, y=None, dt=None):
    """Return a sindybench differentiation method for ``obj``.

    ``None`` gives ``FiniteDifference()``; ``"auto"`` the method the record
    ``y`` sampled at ``dt`` chooses (:func:`data_differentiation`; without
    ``y``, a Savitzky-Golay filter of the default window stands for it);
    sindybench methods pass through unchanged; pysindy differentiation
    objects are wrapped in :class:`PySINDyDifferentiation`.

    Examples
    --------
    >>> as_differentiation(None)
    FiniteDifference()
    >>> from pysindy.differentiation import SmoothedFiniteDifference
    >>> type(as_differentiation(SmoothedFiniteDifference())).__name__
    'PySINDyDifferentiation'
    """
    if obj is None:
        return FiniteDifference()
    if isinstance(obj, str) and obj == "auto":
        if y is None or dt is None:
            return SavitzkyGolay()
        return data_differentiation(y, dt)
    if isinstance(obj, BaseDifferentiation):
        return obj
    if hasattr(obj, "_differentiate"):
        return PySINDyDifferentiation(method=obj)
    raise ValueError(
        "differentiation must be None, 'auto', a sindybench.differentiation method or a pysindy "
        f"differentiation object; got {obj!r}."
    )
