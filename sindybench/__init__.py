"""sindybench: SINDy with control for systems with hidden states and hard nonlinearities."""

from ._stls import STLS, stls

__version__ = "0.1.0"

__all__ = ["STLS", "__version__", "stls"]
