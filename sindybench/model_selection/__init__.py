"""Model selection scored by open-loop simulation: splitters, search spaces, ``tune``.

The search-space dimensions live in :mod:`sindybench.search` and are re-exported here.
"""

from ..search import Categorical, IntRange, LogNormal, LogUniform, Normal, Uniform, as_dimension
from ._split import HoldoutSplit, LeaveOneRecordOut
from ._storage import check_storage
from ._tune import AllTrialsFailedError, tune

# the search-space dimensions are exported from sindybench.search and importable here too
__all__ = [
    "AllTrialsFailedError",
    "HoldoutSplit",
    "LeaveOneRecordOut",
    "check_storage",
    "tune",
]
