"""The fitted state of :class:`~sindybench.uncertainty.BootstrapEnsemble` in model files.

Stored ``fitted`` entries: ``estimator`` (the model fitted to the record,
``{"class", "params", "fitted"}``), ``members`` (a list of those),
``n_failed``, ``block_length`` and ``residuals`` (array (n_samples,
n_outputs)). The summaries (``coef_``, ``inclusion_probabilities_``,
``params_``) are recomputed from the members at loading.
"""

from ..io import encode_array, fitted_from_dict, fitted_to_dict

__all__ = ["ensemble_from_dict", "ensemble_to_dict"]


def ensemble_to_dict(model):
    """The ``fitted`` dict of a fitted ensemble."""
    return {"estimator": fitted_to_dict(model.estimator_, "fitted.estimator"),
            "members": [fitted_to_dict(m, f"fitted.members[{i}]") for i, m in enumerate(model.members_)],
            "n_failed": int(model.n_failed_), "block_length": int(model.block_length_),
            "residuals": encode_array(model.residuals_)}


def ensemble_from_dict(model, fitted):
    """Set the fitted attributes of ``model`` from the :class:`~sindybench.io.Fields` ``fitted``."""
    model.estimator_ = fitted_from_dict(fitted.fields("estimator"))
    members = fitted.get("members", "a list of members")
    if not isinstance(members, list) or len(members) < 2:
        raise ValueError(f"{fitted.where('members')}: expected a list of at least 2 fitted members.")
    model.members_ = [fitted_from_dict(f) for f in fitted.items("members", len(members))]
    model.n_failed_ = fitted.int("n_failed")
    model.residuals_ = fitted.array("residuals")
    model.block_length_ = fitted.int("block_length", low=1, high=max(1, len(model.residuals_)))  # as fit checks
    model._summarize()
