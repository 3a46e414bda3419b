"""Model selection scored by open-loop simulation: splitters, search spaces, ``tune``.

The search-space dimensions live in :mod:`sindybench.search` and are re-exported here.
"""

from ..search import Categorical, IntRange, LogNormal, LogUniform, Normal, Uniform, as_dimension
from ._split import HoldoutSplit, LeaveOneRecordOut
from ._storage import check_storage
from ._tune import AllTrialsFailedError, tune

__all__ = [
    "AllTrialsFailedError",
    "Categorical",
    "HoldoutSplit",
    "IntRange",
    "LeaveOneRecordOut",
    "LogNormal",
    "LogUniform",
    "Normal",
    "Uniform",
    "as_dimension",
    "check_storage",
    "tune",
]
