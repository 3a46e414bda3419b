"""The fitted continuous-time model (:class:`Dynamics`) and its one assembler."""

from ._model import Dynamics, assemble

__all__ = [
    "Dynamics",
    "assemble",
]
