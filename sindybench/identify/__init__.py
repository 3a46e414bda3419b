"""Identify a system from data: ``identify`` and its estimator ``IdentifyCV`` (the structure search)."""

from ._estimator import IdentifyCV, identify

__all__ = ["IdentifyCV", "identify"]
