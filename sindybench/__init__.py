"""sindybench: SINDy with control for systems with hidden states and hard nonlinearities."""

from . import _numba_cache

_numba_cache.stamp_kernels_with_op_table()  # before any kernel is compiled: a cache of another op table is stale

from . import baselines, differentiation, uncertainty
from ._divergence import DivergenceWarning
from ._lag_sindy import LagSINDy
from ._sindy import SINDy
from ._version import __version__
from .optimizers import STLS, GramCache, stls
from .hidden import HiddenStateSINDy
from .io import load_model
from .identify import identify  # sindybench.identify(X, y, dt=...): listed in sindybench.identify.__all__
from .simulate import SimulationError


__all__ = [
    "DivergenceWarning",
    "GramCache",
    "HiddenStateSINDy",
    "LagSINDy",
    "SINDy",
    "STLS",
    "SimulationError",
    "__version__",
    "baselines",
    "differentiation",
    "load_model",
    "stls",
    "uncertainty",
]
