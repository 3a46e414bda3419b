"""sindybench: SINDy with control for systems with hidden states and hard nonlinearities."""

__version__ = "0.1.0"

__all__ = ["__version__"]
