"""Model selection scored by open-loop simulation: splitters, search spaces, ``tune``."""

from ._space import Categorical, IntRange, LogNormal, LogUniform, Normal, Uniform
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
    "check_storage",
    "tune",
]
