"""Several records of one system (a Python list of arrays): their checks and the record named in messages.

One record is a list of one at the estimators' input check (``DynamicsEstimator._check_fit_records``);
these helpers check the lists and put the record at fault in front of a message. The primitives
(``is_records``, ``records_hint``) stay in :mod:`sindybench._validation`, whose checks use them.
"""

import contextlib

import numpy as np  # noqa: F401 - used by the doctests

from ._validation import _ndim, check_array_like, check_inputs_outputs, is_records, records_hint

__all__ = [
    "check_one_record",
    "check_record_lists",
    "check_records",
    "count_records",
    "in_record",
    "record_name",
]


def count_records(a):
    """The number of records in ``a`` when it is a list of arrays one of which is 2-D, else None.

    What a method that takes one record refuses: a list of 2-D arrays is
    never one record, while a list of 1-D arrays may be one record's rows.

    Examples
    --------
    >>> count_records([np.zeros((5, 1)), np.zeros((3, 1))])
    2
    >>> count_records([np.zeros(2), np.zeros(2)]) is None
    True
    """
    return len(a) if is_records(a) and any(r.ndim >= 2 for r in a) else None

def check_one_record(what, *arrays, advice="call it once per record"):
    """Refuse several records (a list holding a 2-D array) in ``what``, a method that takes one record.

    Examples
    --------
    >>> check_one_record("simulate", [np.zeros((5, 1)), np.zeros((3, 1))])
    Traceback (most recent call last):
    ...
    ValueError: simulate takes one record; got a list of 2 records. Expected one array each (call it once per record).
    """
    n = next((count_records(a) for a in arrays if count_records(a)), None)
    if n is not None:
        raise ValueError(f"{what} takes one record; got a list of {n} records. Expected one array each ({advice}).")

def check_record_lists(X, y):
    """Several records: ``y`` a list of arrays, ``X`` None or a list as long, each ``X[i]`` as long as ``y[i]``.

    Only the lists and lengths are checked (the arrays themselves by :func:`check_records`).

    Examples
    --------
    >>> check_record_lists([np.zeros((3, 1))], [np.zeros(3), np.zeros(4)])
    Traceback (most recent call last):
    ...
    ValueError: y is a list of 2 records, so X must be None or a list of 2 input arrays; got a list of 1.
    """
    if not is_records(y):
        n = len(X)
        raise ValueError(f"X is a list of {n} records, so y must be a list of {n} output arrays (one per record); "
                         f"got {type(y).__name__}.{records_hint(y)}")
    n = len(y)
    if X is not None and (not isinstance(X, list) or len(X) != n):
        got = f"a list of {len(X)}" if isinstance(X, list) else type(X).__name__
        raise ValueError(f"y is a list of {n} records, so X must be None or a list of {n} input arrays; got {got}.")
    for i, (X_i, y_i) in enumerate(zip(X or [None] * n, y)):
        if _ndim(X_i) and _ndim(y_i) and len(X_i) != len(y_i):  # None and scalars: check_records says what is wrong
            raise ValueError(f"record {i}: X[{i}] has {len(X_i)} samples and y[{i}] has {len(y_i)}; expected the "
                             "same number of samples.")

def record_name(name, i, several):
    """``name`` of record ``i`` in a message: ``"y[2]"`` with several records, ``"y"`` when the user gave one array.

    Examples
    --------
    >>> record_name("y", 2, True), record_name("y", 0, False)
    ('y[2]', 'y')
    """
    return f"{name}[{i}]" if several else name


@contextlib.contextmanager

def in_record(i, several):
    """Put ``record i:`` in front of a ``ValueError`` raised inside, when the user gave several records.

    Examples
    --------
    >>> with in_record(1, True):
    ...     raise ValueError("y has 2 samples.")
    Traceback (most recent call last):
    ...
    ValueError: record 1: y has 2 samples.
    """
    try:
        yield
    except ValueError as exc:
        if not several:
            raise
        raise ValueError(f"record {i}: {exc}") from exc

def check_records(X, y, *, y_kind="states"):
    """Lists ``(Xs, ys)`` of 2-D arrays, one per record of the list ``y``, with the columns of record 0.

    ``X`` is None (no inputs) or a list with one entry (an array or None) per
    record. ``y_kind`` names the columns of ``y`` in the messages.

    Examples
    --------
    >>> Xs, ys = check_records(None, [np.zeros(5), np.ones(3)])
    >>> [X.shape for X in Xs], [y.shape for y in ys]
    ([(5, 0), (3, 0)], [(5, 1), (3, 1)])
    """
    n_records = len(y)
    if X is None:
        X = [None] * n_records
    if not isinstance(X, list) or len(X) != n_records:
        n_x = f"a list of {len(X)}" if isinstance(X, list) else type(X).__name__
        raise ValueError(f"y is a list of {n_records} records, so X must be None or a list of {n_records} "
                         f"input arrays (or None), one per record; got {n_x}.")
    Xs, ys = [], []
    for i, (X_i, y_i) in enumerate(zip(X, y)):
        check_array_like(X_i, f"X[{i}]")
        check_array_like(y_i, f"y[{i}]")
        X_i, y_i = check_inputs_outputs(X_i, y_i, x_name=f"X[{i}]", y_name=f"y[{i}]")
        if i and (y_i.shape[1] != ys[0].shape[1] or X_i.shape[1] != Xs[0].shape[1]):
            raise ValueError(f"record {i} has {y_i.shape[1]} {y_kind} and {X_i.shape[1]} inputs; expected "
                             f"{ys[0].shape[1]} and {Xs[0].shape[1]} as in record 0.")
        Xs.append(X_i)
        ys.append(y_i)
    return Xs, ys
