"""The three stages of ``identify``'s search (screen, blocks, refine): every candidate it scores, in order.

See :class:`~sindybench.identify.IdentifyCV` for what each stage keeps; :mod:`._stages` scores one
structure or candidate, and this module runs them stage after stage under the budget.
"""

import contextlib
import math
from functools import partial

import numpy as np

from .._progress import progress_bar
from ..hidden._latent import forget_lag_chains
from ..hidden._regressions import reused_regressions
from ..optimizers._forward import forget_selections
from ._search import pareto_front, parsimonious_index
from ._space import LATENT_FAMILIES
from ._stages import (confirm_hold, hold_twin, run_stage, score_candidate, screen_structure, store_full, store_screen,
                      stored_full, stored_screen)

__all__ = ["run_stages"]

# the most a screening stage keeps, whatever the fraction
_MAX_SURVIVORS = 16


@contextlib.contextmanager
def _search_memory():
    """What a search keeps of the work it repeats, for the search only.

    The equation-error regressions (:func:`~sindybench.hidden._regressions.reused_regressions`), the
    latent starts' lag chains and ForwardOLS's last selection are dropped when the search ends: a process
    that runs several searches (``run all``'s workers) does not carry them from one to the next.
    """
    try:
        with reused_regressions():
            yield
    finally:
        forget_lag_chains()
        forget_selections()


def run_stages(search, structs, settings, ctx, budget, store, parallel, refinement, n_inputs, n_folds):
    """``(rows, libraries)``: every candidate that ``search`` (an IdentifyCV) scored, stage by stage, and its library.

    ``structs`` are the ``(structure, library)`` pairs to screen, ``ctx`` what the stages share (records,
    folds, settings), ``store`` the :class:`~._resume.CandidateStore` that reads back and records every
    candidate, ``parallel`` the map of :func:`~._stages.parallel_map` and ``refinement`` the stage-3
    refinement; ``n_inputs`` the records' inputs and ``n_folds`` their validation folds.
    """
    stored_screens, store_screens = partial(stored_screen, store), partial(store_screen, store)
    stored_scores, store_scores = partial(stored_full, store), partial(store_full, store)
    rows, libraries = [], []
    # the candidates that repeat a regression (the other hold, the inner searches' refined ones) take a copy of it
    with progress_bar(len(structs), desc="identify", show=search.show_progress_bar) as bar, _search_memory():
        # stage 1: every structure's pruning path on the last block (the latent family has its own search)
        latent = [(s, lib) for s, lib in structs if s["family"] in LATENT_FAMILIES]
        structs = [(s, lib) for s, lib in structs if s["family"] not in LATENT_FAMILIES]
        todo = structs[: budget.take(len(structs))]
        screens = run_stage(screen_structure, [(s, lib, ctx) for s, lib in todo], stored_screens, store_screens,
                            parallel)
        for (struct, library), screened in zip(todo, screens):
            rows.extend(screened)
            libraries.extend([library] * len(screened))
            bar.update()
        if budget.left is not None:  # the path's levels count as candidates
            budget.left = max(0, budget.left - (len(rows) - len(todo)))
        # stage 2: the best screened candidates on every block (and the best ones with the other hold)
        ok = [i for i, r in enumerate(rows) if np.isfinite(r["errors"][0])]
        ok.sort(key=lambda i: rows[i]["errors"][0])
        keep = ok[: min(_MAX_SURVIVORS, max(4, math.ceil(search.screen_keep * len(ok))))]
        # ... and the best of every family and library, so that a sparse structure is refined and compared too
        seen = {(rows[i]["family"], rows[i]["library"]) for i in keep}
        for i in ok:
            if (rows[i]["family"], rows[i]["library"]) not in seen:
                seen.add((rows[i]["family"], rows[i]["library"]))
                keep.append(i)
        second = [(rows[i], libraries[i]) for i in keep]
        if search.input_delay is None and settings["input_delay"] > 0:  # the advice's delay, confirmed against none
            second += [(dict(rows[i], input_delay=0), libraries[i]) for i in keep[:2]]
        second += [(dict(s, threshold=0.0), lib) for s, lib in latent]
        if search.input_delay is None and settings["input_delay"] > 0:  # in the latent and linear families too
            second += [(dict(s, threshold=0.0, input_delay=0), lib) for s, lib in latent]
        second = second[: budget.take(len(second))]
        bar.total += len(second)
        results = run_stage(score_candidate, [(r, lib, ctx, None) for r, lib in second], stored_scores,
                            store_scores, parallel)
        for (row, library), result in zip(second, results):
            rows.append(result)
            libraries.append(library)
            bar.update()
        # stage 3: the parsimonious pick of stage 2 and the best ones, refined by simulation error
        scored = [i for i, r in enumerate(rows) if r["stage"] == "blocks" and np.all(np.isfinite(r["errors"]))
                  and r["max_row_terms"] <= search.max_terms and r["family"] not in LATENT_FAMILIES]
        scored.sort(key=lambda i: np.mean(rows[i]["errors"]))
        if scored:
            pick = scored[parsimonious_index([np.mean(rows[i]["errors"]) for i in scored],
                                             [np.std(rows[i]["errors"]) for i in scored],
                                             [rows[i]["n_terms"] for i in scored], n_folds)]
            front = [scored[k] for k in pareto_front([np.mean(rows[i]["errors"]) for i in scored],
                                                     [rows[i]["n_terms"] for i in scored])]
            order = [pick] + front + scored  # the pick, then the front sparsest first, then the best
            scored = [i for k, i in enumerate(order) if i not in order[:k]]
        third = [(rows[i], libraries[i]) for i in scored[: budget.take(min(search.n_refine, len(scored)))]]
        twin = hold_twin(third) if search.input_hold is None and n_inputs > 0 else None
        if twin is not None and budget.take(1):
            third.insert(1, twin)
        else:
            twin = None
        bar.total += len(third)
        calls = [(r, lib, ctx, refinement) for r, lib in third]
        results = run_stage(score_candidate, calls, stored_scores, store_scores, parallel)
        for (_, library), result in zip(third, results):
            rows.append(result)
            libraries.append(library)
            bar.update()
        if twin is not None:
            rows[-len(third) + 1] = confirm_hold(rows[-len(third)], rows[-len(third) + 1])
    return rows, libraries
