"""Search spaces and the Optuna driver shared by ``tune`` and ``HiddenStateSINDy``.

One language describes every searched range: a dict ``{name: dimension}`` of
:class:`Uniform`, :class:`LogUniform`, :class:`IntRange`, :class:`Categorical`,
:class:`Normal` and :class:`LogNormal` (or Optuna's own distributions), for
:func:`~sindybench.model_selection.tune`, ``HiddenStateSINDy(search_params=...)``
and the hidden-state strategies' ``bounds``. The older spellings ``(low, high)``,
``(low, high, log)`` and lists of choices are read by :func:`as_dimension`.
One driver runs the searches: :func:`create_study` makes every study with its TPE
sampler, :func:`sample_params` turns a space into a trial's values, and
:func:`minimize` is the inner search (TPE or :func:`grid_points`, then bounded Nelder-Mead).
"""

from ._grid import grid_points
from ._minimize import SEARCH_PENALTY, minimize
from ._space import (
    Categorical,
    Dimension,
    IntRange,
    LogNormal,
    LogUniform,
    Normal,
    Uniform,
    as_dimension,
    check_search_space,
    sample_params,
)
from ._study import TrialSeededTPE, create_study, make_sampler

__all__ = [
    "SEARCH_PENALTY",
    "Categorical",
    "Dimension",
    "IntRange",
    "LogNormal",
    "LogUniform",
    "Normal",
    "TrialSeededTPE",
    "Uniform",
    "as_dimension",
    "check_search_space",
    "create_study",
    "grid_points",
    "make_sampler",
    "minimize",
    "sample_params",
]
