"""Fixed-step open-loop simulation (the code lives in :mod:`sindybench.dynamics`).

This module keeps the public names where they have always been:
:class:`TermsRHS`, :func:`make_rhs`, :func:`simulate` and
:class:`SimulationError`.
"""

from .dynamics._model import make_rhs
from .dynamics._simulate import (  # noqa: F401 - _HOLDS and _METHODS: the estimators' option checks
    _HOLDS,
    _METHODS,
    SimulationError,
    TermsRHS,
    simulate,
)

# SimulationError is exported from the top-level package (sindybench.SimulationError), importable here too
__all__ = ["TermsRHS", "make_rhs", "simulate"]
