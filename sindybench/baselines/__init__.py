"""Baseline models with the SINDy interface: ARX and NN-ARX, evaluated in free run."""

from ._arx import ARX
from ._nnarx import NNARX

__all__ = ["ARX", "NNARX"]
