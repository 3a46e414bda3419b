"""One regression fitted once inside a search: the candidates that repeat it take a copy (:func:`reused_regressions`).

A search fits the same equation-error regression many times: a candidate with the
other input hold (the hold changes the simulation, not the regression), the inner
search's best candidates again before their refinement, a structure's dense fit
before its pruning path. Inside :func:`reused_regressions` (``identify`` runs its
stages inside it), :func:`fit_regression` keeps each regression's fitted library,
optimizer and coefficients under a digest of everything they are computed from
(the library input, the targets, the rows, the unfitted library and optimizer, the
normalization), and a later call with the same digest gets copies of them: the same
numbers. A fit that warned is not kept (its warnings are said again each time);
outside the block, :func:`fit_regression` is :func:`~sindybench._regression.fit_sparse`.
"""

import collections
import contextlib
import copy
import hashlib
import pickle
import warnings

import numpy as np

from .._regression import fit_sparse

__all__ = ["fit_regression", "reused_regressions"]

#: the regressions kept inside :func:`reused_regressions` (digest -> (library, optimizer, coef)), else None
_KEPT = None
#: the most regressions kept (the oldest dropped first)
MAX_KEPT = 512


@contextlib.contextmanager
def reused_regressions():
    """Let :func:`fit_regression` reuse the regressions fitted inside this block (nested blocks share the outer one's).

    Examples
    --------
    >>> from sindybench import STLS
    >>> from sindybench.libraries import PolynomialLibrary
    >>> Z = np.linspace(0.0, 1.0, 20)[:, None]
    >>> with reused_regressions():
    ...     first = fit_regression(PolynomialLibrary(degree=1), STLS(threshold=0.1), Z, 3.0 * Z)
    ...     again = fit_regression(PolynomialLibrary(degree=1), STLS(threshold=0.1), Z, 3.0 * Z)
    >>> again[2].round(6).tolist(), again[2] is first[2]
    ([[0.0], [3.0]], False)
    """
    global _KEPT
    outer = _KEPT
    if outer is None:
        _KEPT = collections.OrderedDict()
    try:
        yield
    finally:
        _KEPT = outer


def _digest(*arrays):
    h = hashlib.blake2b(digest_size=20)
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(repr((a.shape, a.dtype.str)).encode())
        h.update(a.data)
    return h.digest()


def _key(library, optimizer, Z, target, rows, what, normalize):
    try:
        settings = pickle.dumps((library, optimizer, what, normalize), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:  # an object that cannot be pickled (a lambda in a custom library): never kept
        return None
    return _digest(Z, target, np.zeros(0) if rows is None else rows) + hashlib.blake2b(settings, digest_size=20).digest()


def fit_regression(library, optimizer, Z, target, *, rows=None, feature_filter=None, what="library output",
                   normalize=False):
    """``(library, optimizer, coef)``: :func:`~sindybench._regression.fit_sparse` of the unfitted ``library`` and
    ``optimizer``, fitted here, or copies of those fitted before on the same numbers (see the module text)."""
    kept = _KEPT
    key = None if kept is None or feature_filter is not None else _key(library, optimizer, Z, target, rows, what,
                                                                        normalize)
    if key is None:
        coef = fit_sparse(library, optimizer, Z, target, rows=rows, feature_filter=feature_filter, what=what,
                          normalize=normalize)
        return library, optimizer, coef
    hit = kept.get(key)  # one read: another thread dropping the entry cannot make it vanish between two
    if hit is not None:
        with contextlib.suppress(KeyError):  # dropped meanwhile: the copy below is still the entry's
            kept.move_to_end(key)
        return copy.deepcopy(hit)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        coef = fit_sparse(library, optimizer, Z, target, rows=rows, what=what, normalize=normalize)
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if not caught:
        kept[key] = copy.deepcopy((library, optimizer, coef))
        while len(kept) > MAX_KEPT:
            kept.popitem(last=False)
    return library, optimizer, coef
