"""Export of fitted dynamics to other tools: CasADi (optional extra ``casadi``)."""

from ._casadi import CasadiModel, simulate_casadi, to_casadi

__all__ = ["CasadiModel", "simulate_casadi", "to_casadi"]
