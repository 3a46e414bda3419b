"""Identify a system from data: the data advice, ``identify`` and its estimator ``IdentifyCV`` (the search)."""

from ._advice import (
    DataAdvice,
    ProposedTerm,
    advice,
    detect_input_hold,
    detect_saturation,
    estimate_delay,
    excitation_order,
)
from ._criterion import k_step_error
from ._estimator import IdentifyCV, identify

__all__ = [
    "DataAdvice",
    "IdentifyCV",
    "ProposedTerm",
    "advice",
    "detect_input_hold",
    "detect_saturation",
    "estimate_delay",
    "excitation_order",
    "identify",
    "k_step_error",
]
