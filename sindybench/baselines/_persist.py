"""The fitted state of the ARX-type baselines in model files (see :mod:`sindybench.io`).

Stored ``fitted`` entries of both models: ``n_features_in``, ``n_outputs``,
``n_lags``, ``y_ndim``, ``y_mean`` (array (n_outputs,)) and
``feature_names_in`` (null unless ``fit`` got named columns). ARX adds
``coef`` (array (n_regressors, n_outputs)) and ``intercept``; NNARX adds the
standardisation (``u_mean``, ``u_scale``, ``y_scale``), the linear part
(``linear_coef``, ``linear_intercept``), ``n_iter`` and ``networks``: one
entry per network with its ``seed``, ``n_iter`` and its weights ``coefs``
and ``intercepts`` (lists of arrays, layer by layer).
"""

import numpy as np

from ..io import check_params, encode_array
from ._lags import n_lags

__all__ = ["arx_from_dict", "arx_to_dict", "nnarx_from_dict", "nnarx_to_dict"]


def _lags_to_dict(model):
    names = getattr(model, "feature_names_in_", None)
    return {
        "n_features_in": int(model.n_features_in_),
        "n_outputs": int(model.n_outputs_),
        "n_lags": int(model.n_lags_),
        "y_ndim": int(model.y_ndim_),
        "y_mean": encode_array(model.y_mean_),
        "feature_names_in": None if names is None else [str(n) for n in names],
    }


def _lags_from_dict(model, fitted):
    """Set the attributes every lag model has; return ``(n_regressors, n_outputs)``."""
    na, nb, nk = check_params(model._check_orders)
    model.n_features_in_ = fitted.int("n_features_in")
    model.n_outputs_ = n_outputs = fitted.int("n_outputs", low=1)
    model.n_lags_ = fitted.int("n_lags")
    if model.n_lags_ != n_lags(na, nb, nk):
        raise ValueError(f"fitted.n_lags: expected {n_lags(na, nb, nk)} (na={na}, nb={nb}, nk={nk}); "
                         f"got {model.n_lags_}.")
    model.y_ndim_ = fitted.int("y_ndim", low=1, high=2)
    if model.y_ndim_ == 1 and n_outputs != 1:
        raise ValueError(f"fitted.y_ndim: 1 (a 1-D y) but n_outputs = {n_outputs}; expected 2.")
    model.y_mean_ = fitted.array("y_mean", (n_outputs,), finite=True)
    if fitted.get("feature_names_in", allow_none=True) is not None:
        model.feature_names_in_ = np.asarray(fitted.strings("feature_names_in", model.n_features_in_), dtype=object)
    return na * n_outputs + nb * model.n_features_in_, n_outputs


def arx_to_dict(model):
    """The ``fitted`` dict of a fitted ARX model."""
    return {**_lags_to_dict(model), "coef": encode_array(model.coef_), "intercept": encode_array(model.intercept_)}


def arx_from_dict(model, fitted):
    """Set the fitted attributes of an ARX ``model`` from the :class:`~sindybench.io.Fields` ``fitted``."""
    n_reg, n_out = _lags_from_dict(model, fitted)
    model.coef_ = fitted.array("coef", (n_reg, n_out), finite=True)
    model.intercept_ = fitted.array("intercept", (n_out,), finite=True)


def nnarx_to_dict(model):
    """The ``fitted`` dict of a fitted NNARX model."""
    return {
        **_lags_to_dict(model),
        **{name: encode_array(getattr(model, f"{name}_"))
           for name in ("u_mean", "u_scale", "y_scale", "linear_coef", "linear_intercept")},
        "n_iter": int(model.n_iter_),
        "networks": [
            {
                "seed": int(net.random_state),
                "n_iter": int(net.n_iter_),
                "coefs": [encode_array(w) for w in net.coefs_],
                "intercepts": [encode_array(b) for b in net.intercepts_],
            }
            for net in model.estimators_
        ],
    }


def _finite(fitted, name, shapes):
    arrays = fitted.arrays(name, shapes)
    for i, a in enumerate(arrays):
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{fitted.where(name)}[{i}]: expected finite weights; got NaN or inf.")
    return arrays


def _network_from_dict(model, fitted, widths):
    layers = range(len(widths) - 1)
    net = model._network(fitted.int("seed"))
    net.coefs_ = _finite(fitted, "coefs", [(widths[i], widths[i + 1]) for i in layers])
    net.intercepts_ = _finite(fitted, "intercepts", [(widths[i + 1],) for i in layers])
    net.n_iter_ = fitted.int("n_iter")
    net.n_layers_, net.n_outputs_, net.n_features_in_ = len(widths), widths[-1], widths[0]
    net.out_activation_ = "identity"
    return net


def nnarx_from_dict(model, fitted):
    """Set the fitted attributes of an NNARX ``model`` from the :class:`~sindybench.io.Fields` ``fitted``."""
    sizes = check_params(model._check_settings)  # the hidden layer sizes, checked
    n_reg, n_out = _lags_from_dict(model, fitted)
    model.u_mean_ = fitted.array("u_mean", (model.n_features_in_,), finite=True)
    model.u_scale_ = fitted.array("u_scale", (model.n_features_in_,), positive=True)  # divides the inputs
    model.y_scale_ = fitted.array("y_scale", (n_out,), positive=True)
    model.linear_coef_ = fitted.array("linear_coef", (n_reg, n_out), finite=True)
    model.linear_intercept_ = fitted.array("linear_intercept", (n_out,), finite=True)
    model.n_iter_ = fitted.int("n_iter")
    widths = [n_reg, *sizes, n_out]
    model.estimators_ = [_network_from_dict(model, net, widths)
                         for net in fitted.items("networks", int(model.n_estimators))]
    model.mlp_ = model.estimators_[0]
