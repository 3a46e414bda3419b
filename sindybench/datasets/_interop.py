"""Adapter for records of the ``nonlinear_benchmarks`` package (optional)."""

import numpy as np
from sklearn.utils import Bunch

from .._validation import check_dt, check_inputs_outputs

__all__ = ["as_input_output"]


def as_input_output(obj, *, dt=None):
    """Return an input-output record as a Bunch ``(u, y, dt, t, n_init)``.

    Accepts, without importing the package, the ``Input_output_data`` objects
    of ``nonlinear_benchmarks`` (attributes ``u``, ``y``, ``sampling_time`` and
    optionally ``state_initialization_window_length``), the split Bunches of
    :mod:`sindybench.datasets` (``u``, ``y``, ``dt``) and ``(u, y)`` pairs.

    Parameters
    ----------
    obj : object with ``u`` and ``y`` attributes, or a pair ``(u, y)``
    dt : float, optional
        Sampling interval; overrides the one carried by ``obj`` and is
        required when ``obj`` carries none.

    Returns
    -------
    Bunch
        ``u`` (n, n_inputs) and ``y`` (n, n_outputs) float arrays, ``dt``,
        ``t`` = ``arange(n) * dt`` and ``n_init`` (``None`` when unknown).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> rec = SimpleNamespace(u=np.zeros(5), y=np.ones(5), sampling_time=0.5,
    ...                       state_initialization_window_length=2)
    >>> b = as_input_output(rec)
    >>> b.u.shape, b.dt, float(b.t[-1]), b.n_init
    ((5, 1), 0.5, 2.0, 2)
    >>> as_input_output((np.zeros(3), np.zeros(3)))
    Traceback (most recent call last):
    ...
    ValueError: the record carries no sampling interval; pass dt=.
    """
    if hasattr(obj, "u") and hasattr(obj, "y"):
        u, y = obj.u, obj.y
        carried = getattr(obj, "sampling_time", None)
        if carried is None:
            carried = getattr(obj, "dt", None)
        n_init = getattr(obj, "state_initialization_window_length", None)
        if n_init is None:
            n_init = getattr(obj, "n_init", None)
    elif isinstance(obj, (tuple, list)) and len(obj) == 2:
        (u, y), carried, n_init = obj, None, None
    else:
        raise ValueError(
            f"expected an object with u and y attributes (e.g. nonlinear_benchmarks.Input_output_data) "
            f"or a pair (u, y); got {type(obj).__name__}."
        )
    if dt is None:
        dt = carried
    if dt is None:
        raise ValueError("the record carries no sampling interval; pass dt=.")
    dt = check_dt(float(dt) if isinstance(dt, (np.floating, np.integer)) else dt)
    u, y = check_inputs_outputs(u, y, x_name="u", y_name="y")
    return Bunch(u=u, y=y, dt=dt, t=np.arange(y.shape[0]) * dt, n_init=None if n_init is None else int(n_init))
