"""Sparse optimizers: the regression ``Theta coef = target`` behind ``SINDy`` and ``HiddenStateSINDy``.

**The optimizer contract.** An optimizer is a scikit-learn regressor (``__init__`` only stores its
keyword arguments; every tunable number is a parameter, so
``optimizer__threshold`` is searchable). The estimators clone it and call

``fit(theta, target)``
    ``theta``: ndarray of shape (n_samples, n_terms), the library features
    (finite, float64, C or F order); ``target``: ndarray of shape
    (n_samples, n_targets), the time derivatives of the learned states (one
    column per learned state; ``SINDy``: every state, ``HiddenStateSINDy``:
    the strategy's ``learned`` states). It returns ``self``. No sample
    weights, no ``dt``: the regression knows nothing of time.
``coef_``
    After ``fit``: array of shape (n_targets, n_terms) (or anything that
    reshapes to it); row ``k`` holds the coefficients of target ``k``, zero
    for a term left out. Non-finite coefficients make the estimator's fit
    fail with a ``ValueError``.

Nothing else is called (no ``predict``): the estimators assemble the model
from ``coef_`` (:func:`sindybench.dynamics.assemble`). pysindy's ``STLSQ``
satisfies the contract as it is (a model using it cannot be saved: it is not
registered).

**Model files.** A model file stores the optimizer by class name and parameters, and its
fitted state through the functions given to
:func:`sindybench.io.register_model`::

    register_model(MyOptimizer, to_dict=lambda m: {"coef": encode_array(m.coef_)},
                   from_dict=lambda m, fitted: setattr(m, "coef_", fitted.array("coef", (None, None))))

called once at the bottom of the optimizer's module (as ``STLS`` does); a
class that is not registered can be used, but a model holding it cannot be
saved.

**STLS.** :func:`stls` is the numerical core and :class:`STLS` the thin regressor on
top of it; :class:`GramCache` keeps the one QR factorization that all of
STLS's work runs on (see :mod:`sindybench.optimizers._stls`).

**ForwardOLS.** :func:`forward_ols` and :class:`ForwardOLS`: greedy forward selection of a
given number of terms by orthogonal least squares (the error-reduction ratio of NARX term
selection; see :mod:`sindybench.optimizers._forward`), for libraries of collinear terms
such as the delay coordinates of :class:`~sindybench.LagSINDy`.
"""

from ._forward import ForwardOLS, forward_ols
from ._stls import STLS, GramCache, clear_stls_cache, stls

# STLS, stls and GramCache are exported from the top-level package (sindybench.STLS), importable here too
__all__ = [
    "ForwardOLS",
    "clear_stls_cache",
    "forward_ols",
]
