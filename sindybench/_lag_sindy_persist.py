"""The fitted state of :class:`~sindybench.LagSINDy` in model files (see :mod:`sindybench.io`).

Stored ``fitted`` entries: ``library`` (its parameters and symbolic terms), ``optimizer``, ``coef``
(n_outputs, n_terms: the increments' coefficients), ``feature_names``, ``output_names``,
``input_names``, ``n_outputs``, ``n_inputs``, ``output_lags``, ``input_lags``, ``dt``, ``x0`` (the
first training state, delay coordinates), ``output_1d``, ``refinement``, ``scaling`` and
``lag_search``. ``LagSINDy._rebuild_model`` assembles ``dynamics_`` from them.
"""

import math

from .io import check_fitted_kind, check_limit, check_params, encode_array, encode_value, fitted_from_dict, fitted_to_dict
from .libraries import fitted_library_from_dict, fitted_library_to_dict
from ._covariance import check_refinement_record
from ._lags import feature_names, n_lag_states
from ._stls import STLS

__all__ = ["lag_sindy_from_dict", "lag_sindy_to_dict"]

def lag_sindy_to_dict(model):
    """The ``fitted`` dict of a fitted LagSINDy model."""
    return {
        "library": fitted_library_to_dict(model.library_),
        "optimizer": fitted_to_dict(model.optimizer_, "fitted.optimizer"),
        "coef": encode_array(model.coef_),
        "feature_names": list(model.feature_names_),
        "output_names": list(model.output_names_),
        "input_names": list(model.input_names_),
        "n_outputs": len(model.output_names_),
        "n_inputs": int(model.n_inputs_),
        "output_lags": int(model.output_lags_),
        "input_lags": int(model.input_lags_),
        "dt": float(model.dt_),
        "x0": encode_array(model.x0_),
        "output_1d": bool(getattr(model, "_y_1d", False)),
        "refinement": encode_value(model.refinement_, "fitted.refinement"),
        "scaling": encode_value(model.scaling_, "fitted.scaling"),
        "lag_search": encode_value(model.lag_search_, "fitted.lag_search"),
    }


def lag_sindy_from_dict(model, fitted):
    """Set the fitted attributes of ``model`` from the :class:`~sindybench.io.Fields` ``fitted``."""
    check_params(model._validate_params)
    n_outputs, n_inputs = fitted.int("n_outputs", low=1), fitted.int("n_inputs")
    model.output_names_ = fitted.strings("output_names", n_outputs)
    model.input_names_ = fitted.strings("input_names", n_inputs)
    na, nb = fitted.int("output_lags", low=1), fitted.int("input_lags", low=1)
    check_limit(na, "fitted.output_lags")
    check_limit(nb, "fitted.input_lags")
    model.output_lags_, model.input_lags_ = na, nb
    n_states = n_lag_states(n_outputs, n_inputs, na, nb)
    model.library_ = fitted_library_from_dict(fitted.fields("library"), n_states + n_inputs)
    model.terms_ = model.library_.terms_
    n_terms = len(model.terms_)
    model.coef_ = fitted.array("coef", (n_outputs, n_terms), finite=True)
    expected = type(model.optimizer) if model.optimizer is not None else STLS
    model.optimizer_ = check_fitted_kind(fitted_from_dict(fitted.fields("optimizer")), expected, "fitted.optimizer")
    model.feature_names_ = fitted.strings("feature_names", n_terms)
    model.n_inputs_ = model.n_features_in_ = n_inputs
    model.dt_ = fitted.float("dt")
    if not (math.isfinite(model.dt_) and model.dt_ > 0):
        raise ValueError(f"fitted.dt: expected a finite number > 0; got {model.dt_!r}.")
    model.x0_ = fitted.array("x0", (n_states,), finite=True)
    model._y_1d = fitted.bool("output_1d")
    model.refinement_ = fitted.mapping("refinement", allow_none=True)
    model.scaling_ = fitted.mapping("scaling", allow_none=True)
    model.lag_search_ = fitted.value("lag_search", allow_none=True)
    names = feature_names(model.library_, model.output_names_, model.input_names_, na, nb, model.input_delay)
    if model.feature_names_ != names:
        raise ValueError(f"fitted.feature_names differ from the library's names of its terms ({names[:6]}...); "
                         "expected the fitted library's feature names.")
    model._rebuild_model()
    check_refinement_record(model)
