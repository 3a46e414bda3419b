"""Identification from data: the data advice (and, with the search, the automatic choice of a model)."""

from ._advice import (
    DataAdvice,
    ProposedTerm,
    advice,
    detect_input_hold,
    detect_saturation,
    estimate_delay,
    excitation_order,
)

__all__ = [
    "DataAdvice",
    "ProposedTerm",
    "advice",
    "detect_input_hold",
    "detect_saturation",
    "estimate_delay",
    "excitation_order",
]
