"""Hidden-state SINDy: strategies that reconstruct unmeasured states."""

from ._augmentation import DerivativeHiddenState
from ._base import Design, HiddenStrategy, InitialFit, ModelView, Structure, linear_term
from ._bouc_wen import BoucWenHiddenState
from ._estimator import HiddenStateSINDy
from ._latent import LatentHiddenState
from ..search import SEARCH_PENALTY  # noqa: F401 - its home is sindybench.search; kept importable here
from ._parametric import ParametricHiddenState
from ._tanks import TanksHiddenState

# HiddenStateSINDy is exported from the top-level package (sindybench.HiddenStateSINDy), importable here too
__all__ = [
    "BoucWenHiddenState",
    "DerivativeHiddenState",
    "Design",
    "HiddenStrategy",
    "InitialFit",
    "LatentHiddenState",
    "ModelView",
    "ParametricHiddenState",
    "Structure",
    "TanksHiddenState",
    "linear_term",
]
