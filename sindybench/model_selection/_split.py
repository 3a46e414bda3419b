"""Splitters: the last block of a record validates (``HoldoutSplit``), or each record (``LeaveOneRecordOut``)."""

import numbers

import numpy as np
from sklearn.model_selection import BaseCrossValidator

__all__ = ["HoldoutSplit", "LeaveOneRecordOut"]


class HoldoutSplit(BaseCrossValidator):
    """Train on the first samples, validate on the last block.

    One split, in time order, as in the benchmarking study (e.g. the cascaded
    tanks: train on the first 768 samples of the estimation record, validate
    on its last 256). A scikit-learn CV splitter: pass it as ``cv=`` to
    ``GridSearchCV``, ``cross_val_score``, ``OptunaSearchCV`` or
    :func:`~sindybench.model_selection.tune`.

    Parameters
    ----------
    validation_size : int or float, default=0.2
        Number of validation samples (int >= 1) or their fraction of the
        record (float in (0, 1), rounded up to whole samples).

    See Also
    --------
    sklearn.model_selection.TimeSeriesSplit : several growing training blocks.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.zeros((10, 1))
    >>> [(train.tolist(), test.tolist()) for train, test in HoldoutSplit(validation_size=3).split(X)]
    [([0, 1, 2, 3, 4, 5, 6], [7, 8, 9])]
    >>> train, test = next(HoldoutSplit(validation_size=0.25).split(np.zeros((1024, 1))))
    >>> len(train), len(test)
    (768, 256)
    """

    def __init__(self, validation_size=0.2):
        self.validation_size = validation_size

    def _n_validation(self, n_samples):
        size = self.validation_size
        if isinstance(size, numbers.Integral) and not isinstance(size, bool):
            n_val = int(size)
            if not 1 <= n_val < n_samples:
                raise ValueError(
                    f"validation_size={n_val} samples leaves no training data or no validation data for "
                    f"{n_samples} samples; expected an int in [1, {n_samples - 1}]."
                )
            return n_val
        if isinstance(size, numbers.Real) and not isinstance(size, bool) and 0.0 < size < 1.0:
            n_val = int(np.ceil(size * n_samples))
            if n_val >= n_samples:
                raise ValueError(
                    f"validation_size={size} of {n_samples} samples leaves no training data; "
                    "expected a smaller fraction or more samples."
                )
            return n_val
        raise ValueError(
            f"validation_size must be an int >= 1 (samples) or a float in (0, 1) (fraction); got {size!r}."
        )

    def split(self, X, y=None, groups=None):
        """Yield the one ``(train, validation)`` pair of index arrays.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y, groups : ignored
            Accepted for the scikit-learn splitter interface.

        Yields
        ------
        train, validation : ndarray of int
        """
        n_samples = X.shape[0] if hasattr(X, "shape") else len(X)
        n_val = self._n_validation(n_samples)
        indices = np.arange(n_samples)
        yield indices[: n_samples - n_val], indices[n_samples - n_val :]

    def get_n_splits(self, X=None, y=None, groups=None):
        """Number of splits: always 1."""
        return 1


class LeaveOneRecordOut(BaseCrossValidator):
    """Cross-validation over records: each record validates once, the others train.

    For several records of one system passed as lists of arrays (``fit([u1,
    u2, u3], [y1, y2, y3])``): the indices it yields pick *records* from the
    lists, not samples, so a model is always scored on a whole record it
    was not fitted on, simulated from that record's own start. Pass it as
    ``cv=`` to :func:`~sindybench.model_selection.tune` with lists ``X`` and
    ``y`` (its default there). Lists rather than a record-id column: the
    scikit-learn checks and splitters cut one array by rows, and a seam
    between two records must never be differentiated, reconstructed or
    simulated across; see the user guide.

    Examples
    --------
    >>> import numpy as np
    >>> ys = [np.zeros((50, 1)), np.zeros((80, 1)), np.zeros((60, 1))]
    >>> [(train.tolist(), test.tolist()) for train, test in LeaveOneRecordOut().split(ys)]
    [([1, 2], [0]), ([0, 2], [1]), ([0, 1], [2])]
    """

    def split(self, X, y=None, groups=None):
        """Yield ``(train, validation)`` arrays of record indices.

        Parameters
        ----------
        X : list
            The records' inputs (or outputs: only their number counts); None
            takes the number of records from ``y``.
        y : list, optional
        groups : ignored

        Yields
        ------
        train, validation : ndarray of int
        """
        n = self.get_n_splits(X, y)
        records = np.arange(n)
        for k in range(n):
            yield np.delete(records, k), records[k : k + 1]

    def get_n_splits(self, X=None, y=None, groups=None):
        """Number of records (at least 2)."""
        ref = y if X is None else X
        if not isinstance(ref, list):
            raise ValueError(f"LeaveOneRecordOut splits records given as lists of arrays; got "
                             f"{type(ref).__name__}. Expected X or y as a list with one array per record.")
        if len(ref) < 2:
            raise ValueError(f"LeaveOneRecordOut needs at least 2 records to train on one and validate on "
                             f"another; got {len(ref)}.")
        return len(ref)
