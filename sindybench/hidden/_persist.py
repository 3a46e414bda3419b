"""The fitted state of :class:`~sindybench.HiddenStateSINDy` in model files (see :mod:`sindybench.io`).

Stored ``fitted`` entries (a new fitted attribute goes into both functions;
``HiddenStateSINDy._rebuild_model`` then assembles the model from them):

``hidden``
    the fitted strategy ``hidden_`` (its parameters);
``params``, ``best_params``, ``search_results``
    ``params_``, ``best_params_`` and ``search_results_``;
``library``
    the fitted library: parameters and symbolic terms;
``optimizer``
    the fitted optimizer (``{"class", "params", "fitted"}``);
``differentiation``
    the differentiation method ``differentiation_``;
``coef``
    array (n_learned, n_terms);
``structure``
    ``n_states``, ``learned``, ``output_index``, ``fixed_terms``,
    ``fixed_coef`` (array (n_fixed_terms, n_states)), ``state_names``,
    ``bounds`` and ``fixed_rhs`` (true when the fixed rows are a Python
    function: it is rebuilt from the strategy and ``params``);
``states``
    array (n_samples, n_states), the state trajectory on the training data
    (``hidden_states_`` is taken from it);
``x0``
    array (n_states,);
``dt``, ``n_features_in``, ``n_outputs``, ``output_1d``;
``refinement``
    ``refinement_``, the record of the simulation-error refinement (null without
    ``refine``; the refined values are in ``params``, ``coef``,
    ``structure.fixed_coef`` and ``x0``);
``scaling``
    ``scaling_`` (null without ``normalize``; absent in older files, which
    load with ``normalize=False``).
``input_hold``
    ``input_hold_``, the hold the model simulates with (what ``input_hold="auto"``
    decided); absent in files written before 0.2, which simulate with the
    ``input_hold`` parameter they stored.
"""

import math

import numpy as np
from sklearn.base import clone

from .._sindy_persist import fitted_parts, load_scaling
from .._stls import STLS
from .._validation import check_bounds
from ..io import check_limit, check_params, encode_array, encode_value, fitted_to_dict
from ..libraries import check_terms, fitted_library_from_dict, fitted_library_to_dict, terms_to_json
from ..libraries._spec import MAX_COLUMNS
from .._covariance import check_refinement_record
from ..differentiation import FiniteDifference
from ._auto import HOLDS, is_auto
from ._base import HiddenStrategy, Structure
from ._parametric import MAX_GRID_POINTS as MAX_GRID  # grid points a strategy's initial-state search may ask for

__all__ = ["hidden_sindy_from_dict", "hidden_sindy_to_dict"]


def _structure_to_dict(s):
    return {
        "n_states": int(s.n_states),
        "learned": list(s.learned),
        "output_index": list(s.output_index),
        "fixed_terms": terms_to_json(s.fixed_terms),
        "fixed_coef": encode_array(s.fixed_coef),
        "state_names": list(s.state_names),
        "bounds": encode_value(s.bounds, "fitted.structure.bounds"),
        "fixed_rhs": s.fixed_rhs is not None,
    }


def _structure_from_dict(f, hidden, params, n_outputs, n_inputs):
    n_states = f.int("n_states", low=1)
    state_names = f.strings("state_names", n_states)  # the cheap check first: bounds n_states by the file
    learned = f.ints("learned", high=n_states)
    output_index = f.ints("output_index", high=n_states)
    if len(output_index) != n_outputs:
        raise ValueError(f"{f.where('output_index')}: expected {n_outputs} indices (one per output); "
                         f"got {len(output_index)}.")
    fixed_terms = check_terms(f.get("fixed_terms", "a list of terms"), n_states + n_inputs,
                              name=f.where("fixed_terms"))
    fixed_rhs = None
    if f.bool("fixed_rhs"):  # a Python function: rebuilt from the strategy, never stored
        fixed_rhs = hidden.structure(params, n_outputs=n_outputs, n_inputs=n_inputs).fixed_rhs
        if fixed_rhs is None:
            raise ValueError(f"{f.where('fixed_rhs')}: true, but {type(hidden).__name__} has no Python fixed rows.")
    return Structure(
        n_states=n_states,
        learned=tuple(learned),
        output_index=tuple(output_index),
        fixed_terms=fixed_terms,
        fixed_coef=f.array("fixed_coef", (len(fixed_terms), n_states), finite=True),
        state_names=state_names,
        bounds=f.value("bounds", allow_none=True),
        fixed_rhs=fixed_rhs,
    )


def _check_derived_structure(s, hidden, params, n_outputs, n_inputs):
    """The stored structure is what the strategy derives from ``params``: every field the same.

    Fixed rows, which states are measured, names and bounds all follow from the
    strategy and its parameters; a file that says otherwise (a fixed
    coefficient of 0.5 beside k1 = 0.04, an output index on the hidden state,
    swapped names, another bound) is refused.
    """
    try:
        derived = hidden.structure(params, n_outputs=n_outputs, n_inputs=n_inputs)
    except (ValueError, TypeError, KeyError) as exc:
        raise ValueError(f"fitted.structure: {type(hidden).__name__} cannot derive it from fitted.params: {exc}") \
            from exc
    try:
        lo, hi = check_bounds(s.bounds, s.n_states, name="fitted.structure.bounds")
    except (ValueError, TypeError) as exc:
        raise ValueError(f"fitted.structure.bounds: expected (lower, upper) of {s.n_states} states; {exc}") from exc
    dlo, dhi = check_bounds(derived.bounds, derived.n_states)
    checks = {
        "n_states": s.n_states == derived.n_states,
        "learned": tuple(s.learned) == tuple(derived.learned),
        "output_index": tuple(s.output_index) == tuple(derived.output_index),
        "state_names": list(s.state_names) == list(derived.state_names),
        "fixed_terms": [tuple(t) for t in s.fixed_terms] == [tuple(t) for t in check_terms(derived.fixed_terms)],
        "fixed_coef": np.shape(s.fixed_coef) == np.shape(derived.fixed_coef)
        and np.allclose(s.fixed_coef, derived.fixed_coef, rtol=1e-12, atol=0.0),
        "bounds": lo.shape == dlo.shape and np.array_equal(lo, dlo) and np.array_equal(hi, dhi),
        "fixed_rhs": (s.fixed_rhs is None) == (derived.fixed_rhs is None),
    }
    wrong = [name for name, ok in checks.items() if not ok]
    if wrong:
        name = wrong[0]
        value = getattr(derived, name)
        raise ValueError(f"fitted.structure.{name} differs from what {type(hidden).__name__} derives from "
                         f"fitted.params ({_short(value)}); expected the structure of the fitted strategy.")


def _short(value, limit=120):
    text = repr(value.tolist() if isinstance(value, np.ndarray) else value)
    return text if len(text) <= limit else text[:limit] + "..."


def _check_states(states):
    """The training trajectory: finite (or NaN from a divergence to the end, as the simulator writes it)."""
    finite = np.all(np.isfinite(states), axis=1)
    if not finite.all():
        k = int(np.argmax(~finite))
        if finite[k:].any() or not np.all(np.isnan(states[k:])):
            raise ValueError(f"fitted.states: row {k} is not finite; expected the training trajectory (finite, or "
                             "NaN from a divergence to the end).")


def _check_fixed_params(hidden, params, refined):
    """A physical parameter the strategy fixes (its constructor value, or the latent gauge) is that value in
    ``params_``, unless a refinement moved it."""
    moved = set(hidden.refinable(params)) if refined else set()
    own = hidden.get_params(deep=False)
    expected = {k: own[k] for k in params
                if isinstance(own.get(k), (int, float)) and not isinstance(own.get(k), bool)}
    try:  # what resolve_params puts back (a gauge: LatentHiddenState's gain with scale="driver")
        expected.update({k: v for k, v in hidden.resolve_params(params).items() if k in params and v != params[k]})
    except (ValueError, TypeError, KeyError):
        pass  # parameters searched under other names (TanksHiddenState's ratio): the constructor values only
    for name, value in expected.items():
        if name not in moved and not np.isclose(params[name], value, rtol=1e-12, atol=0.0):
            raise ValueError(f"fitted.params[{name!r}] = {params[name]!r}, but {type(hidden).__name__} fixes it at "
                             f"{value!r} and no refinement moved it; expected the fitted value.")


def hidden_sindy_to_dict(model):
    """The ``fitted`` dict of a fitted HiddenStateSINDy model."""
    return {
        "hidden": encode_value(model.hidden_, "fitted.hidden"),
        "params": encode_value(model.params_, "fitted.params"),
        "best_params": encode_value(model.best_params_, "fitted.best_params"),
        "search_results": encode_value(model.search_results_, "fitted.search_results"),
        "library": fitted_library_to_dict(model.library_),
        "optimizer": fitted_to_dict(model.optimizer_, "fitted.optimizer"),
        "differentiation": encode_value(model.differentiation_, "fitted.differentiation"),
        "coef": encode_array(model.coef_),
        "structure": _structure_to_dict(model.structure_),
        "states": encode_array(model.states_),
        "x0": encode_array(model.x0_),
        "dt": float(model.dt_),
        "n_features_in": int(model.n_features_in_),
        "n_outputs": int(model.n_outputs_),
        "output_1d": bool(model._y_1d),
        "refinement": encode_value(model.refinement_, "fitted.refinement"),
        "scaling": encode_value(model.scaling_, "fitted.scaling"),
        "input_hold": model.input_hold_,
    }


def _check_strategy(hidden, field):
    """The limits of what a strategy runs at every ``predict``, then its own checks (``_validate``)."""
    params = hidden.get_params(deep=False)
    check_limit(params.get("n_substeps"), f"{field}.estimator.params.n_substeps")
    check_limit(params.get("grid_size"), f"{field}.estimator.params.grid_size", MAX_GRID)
    try:
        hidden._validate()  # with the products of sizes (a grid over all hidden states, latent states)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{field}: {type(hidden).__name__} refused its parameters: {exc}") from exc


def _check_physical(hidden, params):
    """The fitted physical parameters (``params_``) pass the strategy's checks of its constructor values."""
    bad = [k for k, v in params.items()
           if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)]
    if bad:
        raise ValueError(f"fitted.params[{bad[0]!r}]: expected a finite number; got {params[bad[0]]!r}.")
    try:
        space = hidden.search_space()
        expected = sorted(hidden.resolve_params({k: dim.support()[0] for k, dim in space.items()}))
    except (ValueError, TypeError, KeyError) as exc:
        raise ValueError(f"fitted.hidden: {type(hidden).__name__} cannot name its parameters: {exc}") from exc
    if sorted(params) != expected:
        raise ValueError(f"fitted.params: expected the {type(hidden).__name__} parameters {expected}; "
                         f"got {sorted(params)}.")
    try:
        names = hidden.refinable(params)
        own = {k: params[k] for k in names if k in hidden._get_param_names()}
        clone(hidden).set_params(**own)._validate()
    except (ValueError, TypeError, KeyError) as exc:
        raise ValueError(f"fitted.params: the {type(hidden).__name__} parameters {params} are refused: {exc}") from exc


def _load_input_hold(model, fitted):
    """``input_hold_``, the hold the model simulates with, and the parameters of a file written before 0.2.

    Such a file has no ``fitted.input_hold``: it simulates with its ``input_hold``
    parameter, and a parameter it did not store (so that loading gave it the
    current default) takes the default of its time: ``input_hold="zoh"``,
    ``library=None``, ``refine=None``, ``differentiation=FiniteDifference()``
    (see :func:`_load_differentiation`).
    """
    if "input_hold" in fitted.data:
        model.input_hold_ = fitted.str("input_hold")
        if model.input_hold_ not in HOLDS:
            raise ValueError(f"fitted.input_hold: expected one of {list(HOLDS)}; got {model.input_hold_!r}.")
        _load_differentiation(model, before_02=False)
        return
    old = {"input_hold": "zoh", "library": None, "refine": None}  # "auto" did not exist before 0.2
    model.set_params(**{k: v for k, v in old.items() if is_auto(getattr(model, k))})
    _load_differentiation(model, before_02=True)
    model.input_hold_ = model.input_hold


def _load_differentiation(model, *, before_02):
    """The ``differentiation`` parameter of a file that did not store it: the default of its time, as fitted.

    Loading gives a missing parameter today's default, ``"auto"`` (since 0.3).
    A file whose fitted method is a ``FiniteDifference`` that ``"auto"`` cannot
    have chosen (any, before 0.2, when ``"auto"`` did not exist; accuracy 4,
    the default of 0.2, after) was fitted with the old default, which it keeps:
    a refit of the loaded model is the fit of its time.
    """
    fitted = model.differentiation_
    if (is_auto(model.differentiation) and type(fitted) is FiniteDifference
            and (before_02 or fitted.accuracy == 4)):
        model.differentiation = clone(fitted)


def hidden_sindy_from_dict(model, fitted):
    """Set the fitted attributes of ``model`` from the :class:`~sindybench.io.Fields` ``fitted``."""
    model.dt_ = fitted.float("dt")
    check_params(model._check_params, model.dt_)
    check_limit(model.n_substeps, "params.n_substeps")
    if model.hidden is not None:
        _check_strategy(model.hidden, "params.hidden")
    hidden = fitted.value("hidden")
    if not isinstance(hidden, HiddenStrategy):
        raise ValueError(f"fitted.hidden: expected a hidden-state strategy; got {type(hidden).__name__}.")
    _check_strategy(hidden, "fitted.hidden")
    n_inputs = fitted.int("n_features_in", high=MAX_COLUMNS)
    n_outputs = fitted.int("n_outputs", low=1, high=MAX_COLUMNS)
    model.hidden_ = hidden
    model.params_ = fitted.mapping("params")
    _check_physical(hidden, model.params_)
    model.best_params_ = fitted.mapping("best_params")
    results = fitted.value("search_results")
    if not isinstance(results, list):
        raise ValueError(f"fitted.search_results: expected a list of (values, score); got {type(results).__name__}.")
    model.search_results_ = results
    model.refined_results_ = []  # not saved: the record of a fit's refined candidates
    s = _structure_from_dict(fitted.fields("structure"), hidden, model.params_, n_outputs, n_inputs)
    _check_derived_structure(s, hidden, model.params_, n_outputs, n_inputs)
    model.structure_ = s
    model.library_ = fitted_library_from_dict(fitted.fields("library"), s.n_states + n_inputs)
    model.coef_ = fitted.array("coef", (len(s.learned), len(model.library_.terms_)), finite=True)
    model.optimizer_, model.differentiation_ = fitted_parts(model, fitted, STLS)
    model.states_ = fitted.array("states", (None, s.n_states))
    if model.states_.shape[0] == 0:
        raise ValueError(f"fitted.states: expected the training trajectory (at least one sample of {s.n_states} "
                         "states); got 0 samples.")
    model.x0_ = fitted.array("x0", (s.n_states,), finite=True)
    try:
        lo, hi = check_bounds(s.bounds, s.n_states, name="fitted.structure.bounds")
    except (ValueError, TypeError) as exc:
        raise ValueError(f"fitted.structure.bounds: expected (lower, upper) of {s.n_states} states; {exc}") from exc
    outside = (model.x0_ < lo) | (model.x0_ > hi)
    if outside.any():
        i = int(np.argmax(outside))
        raise ValueError(f"fitted.x0: x0[{i}] = {model.x0_[i].item()!r} is outside fitted.structure.bounds "
                         f"[{lo[i].item()!r}, {hi[i].item()!r}]; expected the first state of the training trajectory.")
    model.n_features_in_ = n_inputs
    model._y_1d = fitted.bool("output_1d")
    model.refinement_ = fitted.mapping("refinement", allow_none=True)
    load_scaling(model, fitted)
    _load_input_hold(model, fitted)
    _check_states(model.states_)
    _check_fixed_params(hidden, model.params_, model.refinement_ is not None)
    model._rebuild_model()
    check_refinement_record(model)
