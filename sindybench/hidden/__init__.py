"""Hidden-state SINDy: strategies that reconstruct unmeasured states."""

from ._base import Design, HiddenStrategy, ModelView, Structure, linear_term

__all__ = ["Design", "HiddenStrategy", "ModelView", "Structure", "linear_term"]
