"""``IdentifyCV``'s checks: its settings (at the start of ``fit``) and the records it is given."""

import numpy as np

from .._records import check_record_lists, check_records
from .._validation import (check_array_like, check_bool, check_dt, check_inputs_outputs, check_integer, check_option,
                           check_positive, is_records)
from ._advice import check_magnitude
from ._criterion import CRITERIA
from ._space import ALL_FAMILIES, LIBRARIES

__all__ = ["HOLDS", "MIN_TRAIN", "check_data", "check_params"]

HOLDS = ("zoh", "linear")
# fewest samples a fold may train on
MIN_TRAIN = 5


def check_params(search, dt):
    """The sampling interval (``dt``, else ``search.dt``), after checking every setting of ``search`` (an IdentifyCV)."""
    dt = check_dt(dt if dt is not None else search.dt, allow_none=True)
    if dt is None:
        raise ValueError("dt is None; pass the sampling interval dt to IdentifyCV or to fit.")
    for name, value, options in (("families", search.families, ALL_FAMILIES),
                                 ("libraries", search.libraries, LIBRARIES),
                                 ("derivatives", search.derivatives, ("finite_difference", "savgol", "spectral"))):
        if value is None and name == "derivatives":
            continue
        if isinstance(value, str) or not hasattr(value, "__iter__") or not list(value):
            raise ValueError(f"{name} must be a non-empty list of names from {list(options)}; got {value!r}.")
        for v in value:
            check_option(v, name, options)
    if search.input_hold is not None:
        check_option(search.input_hold, "input_hold", HOLDS)
    if search.input_delay is not None:
        check_integer(search.input_delay, "input_delay", low=0)
    check_option(search.criterion, "criterion", CRITERIA)
    if search.horizon is not None:
        check_integer(search.horizon, "horizon", low=1)
    check_integer(search.n_blocks, "n_blocks", low=2)
    check_positive(search.block_size, "block_size")
    if search.block_size * search.n_blocks >= 0.9:
        raise ValueError(f"n_blocks * block_size = {search.n_blocks * search.block_size:.3g} leaves too little "
                         "training data; expected < 0.9.")
    check_integer(search.max_path, "max_path")
    check_positive(search.screen_keep, "screen_keep")
    if search.screen_keep > 1:
        raise ValueError(f"screen_keep must be a fraction in (0, 1]; got {search.screen_keep!r}.")
    check_integer(search.screen_window, "screen_window", low=MIN_TRAIN)
    check_integer(search.n_refine, "n_refine", low=0)
    check_integer(search.max_terms, "max_terms")
    if search.refinement is not None and not hasattr(search.refinement, "run"):
        raise ValueError(f"refinement must be an OutputErrorRefinement or None; got "
                         f"{type(search.refinement).__name__}.")
    if search.time_budget is not None:
        check_positive(search.time_budget, "time_budget")
    if search.max_candidates is not None:
        check_integer(search.max_candidates, "max_candidates")
    if search.n_init is not None:
        check_integer(search.n_init, "n_init")
    if search.n_jobs is not None and (check_integer(search.n_jobs, "n_jobs", low=None) == 0 or search.n_jobs < -1):
        raise ValueError(f"n_jobs must be None (one process), an integer >= 1, or -1 for one process per CPU; got "
                         f"{search.n_jobs!r}.")
    check_bool(search.show_progress_bar, "show_progress_bar")
    if search.validation is not None:
        check_option(search.validation, "validation", ("blocks", "records"))
    if search.study_name is not None and not isinstance(search.study_name, str):
        raise ValueError(f"study_name must be None or a str; got {search.study_name!r}.")
    if search.storage is not None:
        from ..model_selection import check_storage

        check_storage(search.storage)
    return dt


def check_data(X, y):
    """Lists ``(X, y)`` of 2-D arrays, one per record (one array: a list of one), checked."""
    if y is None:
        raise ValueError("IdentifyCV requires y to be passed, but the target y is None; expected the outputs.")
    if is_records(y) or (isinstance(X, list) and X and hasattr(X[0], "shape") and np.ndim(X[0]) == 2):
        check_record_lists(X, y)
        X, y = check_records(X, y, y_kind="outputs")
    else:
        check_array_like(X, "X")
        check_array_like(y, "y")
        X, y = check_inputs_outputs(X, y)
        X, y = [X], [y]
    check_magnitude(np.vstack(X), np.vstack(y))
    n = sum(y_r.shape[0] for y_r in y)
    if n < 2 * MIN_TRAIN:
        raise ValueError(f"y has {n} sample(s) (n_samples = {n}); identify needs at least "
                         f"{2 * MIN_TRAIN} to train and validate a candidate.")
    for j, col in enumerate(np.vstack(X).T):
        if np.ptp(col) == 0:
            raise ValueError(f"input column {j} is constant ({col[0]!r}); a constant input cannot be told apart "
                             "from an offset. Expected inputs that vary (drop the constant column).")
    for j, col in enumerate(np.vstack(y).T):
        if np.ptp(col) == 0:
            raise ValueError(f"output column {j} is constant ({col[0]!r}); expected outputs that vary.")
    return X, y
