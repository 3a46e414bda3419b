"""The table of ``identify``'s candidates and the choice among them (before the refit on the whole record)."""

import numpy as np

from ._lag import LAG_FAMILY, equation_or_lag
from ._linear import linear_base_rule
from ._search import parsimonious_index
from ._stages import STRUCTURE

__all__ = ["candidate_table", "choose_candidate", "scored_table"]


def candidate_table(rows, n_blocks):
    """``cv_results_``: one list per column; block errors of screened rows only in their last split."""
    table = {k: [r[k] for r in rows] for k in STRUCTURE + ("threshold", "refine", "stage", "n_terms",
                                                            "max_row_terms", "fit_time", "status")}
    table["equations"] = [r.get("equations") for r in rows]  # of the last fold's fit; None for screened rows
    errors = np.full((len(rows), n_blocks), np.nan)
    for i, r in enumerate(rows):
        errors[i, n_blocks - len(r["errors"]):] = r["errors"]
    for k in range(n_blocks):
        table[f"split{k}_validation_error"] = errors[:, k]
    complete = ~np.isnan(errors).any(axis=1) & np.isfinite(errors).all(axis=1)
    with np.errstate(invalid="ignore"):
        table["mean_validation_error"] = np.where(complete, errors.mean(axis=1), np.inf)
        table["std_validation_error"] = np.where(complete, errors.std(axis=1), np.inf)
    return table


def scored_table(rows, n_blocks, max_terms):
    """``(table, mean)``: :func:`candidate_table`, and each candidate's mean validation error where it may be
    chosen (scored on every block, at most ``max_terms`` terms per row, not excluded), else inf; raises when none may."""
    table = candidate_table(rows, n_blocks)
    full = np.array([r["stage"] != "screen" and (r["max_row_terms"] or 0) <= max_terms
                     and not r.get("excluded") for r in rows])
    mean = np.where(full, table["mean_validation_error"], np.inf)
    if not np.any(np.isfinite(mean)):
        reasons = sorted({r["status"] for r in rows if r["status"] != "ok"})[:3] or [
            "the budget ended before any candidate was scored on every block"]
        raise ValueError(f"identify: none of the {len(rows)} candidates with at most max_terms={max_terms} "
                         f"terms per row simulated every validation block without failing (first reasons: "
                         f"{reasons}); expected a record long and rich enough for at least one candidate, or a "
                         "larger time_budget / max_candidates / max_terms.")
    return table, mean


def choose_candidate(rows, table, n_blocks, mean):
    """``(index, rule)``: the equations' parsimonious pick (the lag models aside; the linear base's rule), then the
    lag model only when better by more than its standard error; ``mean`` the errors of :func:`scored_table`."""
    terms = [t if t is not None else 10**9 for t in table["n_terms"]]
    lags = np.array([r["family"] == LAG_FAMILY for r in rows])
    # the equations' pick (the lag models aside), then the lag model only when better by more than its SE
    equation_mean = np.where(lags, np.inf, mean)
    best = rule = None
    if np.any(np.isfinite(equation_mean)):
        best = parsimonious_index(equation_mean, table["std_validation_error"], terms, n_blocks)
        best, rule = linear_base_rule(best, rows, equation_mean, table["std_validation_error"], n_blocks)
    lag = int(np.argmin(np.where(lags, mean, np.inf))) if np.any(np.isfinite(mean[lags])) else None
    best, lag_reason = equation_or_lag(best, lag, mean, table["std_validation_error"], n_blocks)
    return best, lag_reason or rule
