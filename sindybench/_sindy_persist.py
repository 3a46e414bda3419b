"""The fitted state of :class:`~sindybench.SINDy` in model files (see :mod:`sindybench.io`).

Stored ``fitted`` entries (add a new fitted attribute to both functions; ``SINDy._rebuild_model``
then assembles ``dynamics_`` from them):

``library``
    the fitted library: its parameters and its symbolic terms
    (:func:`~sindybench.libraries.fitted_library_to_dict`);
``optimizer``
    the fitted optimizer (``{"class", "params", "fitted"}``);
``differentiation``
    the differentiation method used;
``coef``
    array (n_states, n_terms);
``feature_names``, ``output_names``, ``input_names``
    lists of strings;
``n_states``, ``n_inputs``
    integers;
``dt``
    the training sampling interval (null for non-uniform sample times);
``x0``
    array (n_states,), the first training sample;
``output_1d``
    whether ``fit`` got a 1-D ``y``;
``refinement``
    ``refinement_``, the record of the simulation-error refinement (null without
    ``refine``; the refined coefficients and first state are ``coef`` and ``x0``);
``scaling``
    ``scaling_``, the operating point of ``normalize`` (null without; absent
    in files written before ``normalize`` existed, which load with
    ``normalize=False``). ``coef`` is always in the user's units, so nothing
    else depends on it.
"""

import math

from .differentiation import BaseDifferentiation, as_differentiation
from .io import (
    check_fitted_kind,
    check_limit,
    check_params,
    encode_array,
    encode_value,
    fitted_from_dict,
    fitted_to_dict,
)
from .libraries import fitted_library_from_dict, fitted_library_to_dict
from ._covariance import check_refinement_record
from ._stls import STLS
from ._validation import check_column_names, check_distinct_names

__all__ = ["fitted_parts", "load_scaling", "sindy_from_dict", "sindy_to_dict"]


def sindy_to_dict(model):
    """The ``fitted`` dict of a fitted SINDy model."""
    return {
        "library": fitted_library_to_dict(model.library_),
        "optimizer": fitted_to_dict(model.optimizer_, "fitted.optimizer"),
        "differentiation": encode_value(model.differentiation_, "fitted.differentiation"),
        "coef": encode_array(model.coef_),
        "feature_names": list(model.feature_names_),
        "output_names": list(model.output_names_),
        "input_names": list(model.input_names_),
        "n_states": int(model.n_states_),
        "n_inputs": int(model.n_inputs_),
        "dt": None if model.dt_ is None else float(model.dt_),
        "x0": encode_array(model.x0_),
        "output_1d": bool(getattr(model, "_y_1d", False)),
        "refinement": encode_value(model.refinement_, "fitted.refinement"),
        "scaling": encode_value(model.scaling_, "fitted.scaling"),
    }


def load_scaling(model, fitted):
    """``scaling_`` from the file; a file written before ``normalize`` existed loads with ``normalize=False``."""
    if "scaling" not in fitted.data:
        model.normalize = False  # the estimator it was saved from had no such parameter: it did not normalize
        model.scaling_ = None
    else:
        model.scaling_ = fitted.mapping("scaling", allow_none=True)


def fitted_parts(model, fitted, default_optimizer):
    """The fitted optimizer and differentiation method, each of the class the parameters name.

    ``default_optimizer`` is the class fitted when the ``optimizer`` parameter is None.
    """
    expected = type(model.optimizer) if model.optimizer is not None else default_optimizer
    optimizer = check_fitted_kind(fitted_from_dict(fitted.fields("optimizer")), expected, "fitted.optimizer")
    differentiation = fitted.value("differentiation")
    if not isinstance(differentiation, BaseDifferentiation):
        raise ValueError(f"fitted.differentiation: expected a differentiation method; "
                         f"got {type(differentiation).__name__}.")
    # "auto" fits whichever method the record chose
    expected = (type(differentiation) if isinstance(model.differentiation, str) and model.differentiation == "auto"
                else type(check_params(as_differentiation, model.differentiation)))
    return optimizer, check_fitted_kind(differentiation, expected, "fitted.differentiation")


def sindy_from_dict(model, fitted):
    """Set the fitted attributes of ``model`` from the :class:`~sindybench.io.Fields` ``fitted``."""
    # the cheap checks first: the names bound the sizes (a file cannot ask for more states than it names)
    n_states, n_inputs = fitted.int("n_states", low=1), fitted.int("n_inputs")
    model.output_names_ = fitted.strings("output_names", n_states)
    model.input_names_ = fitted.strings("input_names", n_inputs)
    check_params(model._check_params, n_states)
    check_limit(model.n_substeps, "params.n_substeps")
    model.library_ = fitted_library_from_dict(fitted.fields("library"), n_states + n_inputs)
    model.terms_ = model.library_.terms_
    n_terms = len(model.terms_)
    model.coef_ = fitted.array("coef", (n_states, n_terms), finite=True)
    model.optimizer_, model.differentiation_ = fitted_parts(model, fitted, STLS)
    model.feature_names_ = fitted.strings("feature_names", n_terms)
    model.n_inputs_, model.n_features_in_ = n_inputs, n_inputs
    model.dt_ = fitted.float("dt", allow_none=True)
    if model.dt_ is not None and not (math.isfinite(model.dt_) and model.dt_ > 0):
        raise ValueError(f"fitted.dt: expected a finite number > 0 or null; got {model.dt_!r}.")
    model.x0_ = fitted.array("x0", (n_states,), finite=True)
    model._y_1d = fitted.bool("output_1d")
    model.refinement_ = fitted.mapping("refinement", allow_none=True)
    load_scaling(model, fitted)
    _check_derived(model, n_states, n_inputs)
    model._rebuild_model()
    check_refinement_record(model)


def _check_derived(model, n_states, n_inputs):
    """Names, feature names and dt follow from the parameters and the library: a file that says otherwise is refused."""
    try:
        expected = {"output_names": check_column_names(model.output_names, n_states, "y", "output_names"),
                    "input_names": check_column_names(model.input_names, n_inputs, "u", "input_names")}
    except ValueError as exc:
        raise ValueError(f"params: {exc}") from exc
    for name, value in expected.items():
        if getattr(model, name + "_") != value:
            raise ValueError(f"fitted.{name} = {getattr(model, name + '_')!r}, but params.{name} gives {value!r}; "
                             "expected the names it was fitted with.")
    check_distinct_names(model.output_names_, model.input_names_)
    features = list(model.library_.get_feature_names_out(model.output_names_ + model.input_names_))
    if model.feature_names_ != features:
        raise ValueError(f"fitted.feature_names differ from the library's names of its terms ({features[:6]}...); "
                         "expected the fitted library's feature names.")
