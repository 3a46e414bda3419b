"""Hidden-state SINDy: strategies that reconstruct unmeasured states."""

from ._augmentation import DerivativeHiddenState
from ._base import Design, HiddenStrategy, InitialFit, ModelView, Structure, linear_term
from ._bouc_wen import BoucWenHiddenState
from ._estimator import HiddenStateSINDy
from ._latent import LatentHiddenState
from ._objective import SEARCH_PENALTY
from ._parametric import ParametricHiddenState
from ._tanks import TanksHiddenState

__all__ = [
    "SEARCH_PENALTY",
    "BoucWenHiddenState",
    "DerivativeHiddenState",
    "Design",
    "HiddenStateSINDy",
    "HiddenStrategy",
    "InitialFit",
    "LatentHiddenState",
    "ModelView",
    "ParametricHiddenState",
    "Structure",
    "TanksHiddenState",
    "linear_term",
]
