"""Fit by simulation error: forward sensitivities, output-error refinement, initial states."""

from ._core import Physical, RefinementResult, estimate_initial_state, refine_simulation_error
from ._sensitivity import simulate_sensitivity

__all__ = ["Physical", "RefinementResult", "estimate_initial_state", "refine_simulation_error", "simulate_sensitivity"]
