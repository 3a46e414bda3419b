"""Fit by simulation error: forward sensitivities, output-error refinement, initial states."""

from ._core import Physical, RefinementResult, estimate_initial_state, refine_simulation_error
from ._sensitivity import simulate_sensitivity
from ._settings import OutputErrorRefinement

__all__ = [
    "OutputErrorRefinement",
    "Physical",
    "RefinementResult",
    "estimate_initial_state",
    "refine_simulation_error",
    "simulate_sensitivity",
]
