"""Hidden-state SINDy: strategies that reconstruct unmeasured states."""

from ._augmentation import DerivativeAugmentation
from ._base import Design, HiddenStrategy, ModelView, Structure, linear_term
from ._bouc_wen import BoucWenStructure
from ._estimator import HiddenStateSINDy
from ._parametric import ParametricHiddenState
from ._tanks import TanksHiddenState

__all__ = [
    "BoucWenStructure",
    "DerivativeAugmentation",
    "Design",
    "HiddenStateSINDy",
    "HiddenStrategy",
    "ModelView",
    "ParametricHiddenState",
    "Structure",
    "TanksHiddenState",
    "linear_term",
]
