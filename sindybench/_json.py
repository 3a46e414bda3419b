"""Labels of parameter values for JSON records (search trials, experiment results)."""

import numpy as np

__all__ = ["jsonable"]


def jsonable(value):
    """Return ``value`` as a JSON-able label.

    ``None``, bool, int, float and str stay as they are, numpy scalars become
    the matching Python scalars, and any other object (a tuple, a library)
    becomes its ``repr``: the label under which
    :class:`~sindybench.model_selection.Categorical` stores such a choice.
    Unlike the library specs of :mod:`sindybench.io`, the label is for reading,
    not for rebuilding the value.

    Examples
    --------
    >>> jsonable(np.float64(0.5)), jsonable("tanh"), jsonable((16, 16))
    (0.5, 'tanh', '(16, 16)')
    """
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return repr(value)
