"""The fitted dynamics: term operations, simulation, the one-step map and its Jacobians, the ``Dynamics`` value.

The bottom layer of sindybench's numerical core. Term operations (value and
derivative, built-in and user-registered) are defined once here and compiled
by numba; the simulator, the one-step map and the sensitivity kernel share
one integrator (:mod:`sindybench.dynamics._kernels`). A fitted model is one
:class:`Dynamics` value, built by :func:`assemble` (the one place that decides
compiled or Python right-hand side).
"""

from ._model import Dynamics, assemble, check_output_index, make_rhs
from ._ops import ABS_POW, BUILTIN_OPS, HINGE, LOGISTIC, POW, SIGN, SQRT, STEP, USER
from ._simulate import Settings, SimulationError, TermsRHS, simulate, simulation_settings
from ._step import (
    StepModel,
    coefficient_directions,
    jacobian_workspace,
    sensitivity_arrays,
    step,
    step_into,
    step_jacobian,
    step_jacobian_into,
    step_jacobian_kernel,
    step_kernel,
    step_model,
    step_workspace,
)
from ._terms import check_terms, evaluate_terms, evaluate_terms_jacobian, terms_to_arrays
from ._user import OpCompileError, UserOp, register_op, user_table

# Importable from here but not listed: SimulationError (exported from sindybench), TermsRHS, make_rhs and simulate
# (exported from sindybench.simulate), and the kernels' internals (BUILTIN_OPS, Settings, simulation_settings,
# coefficient_directions, sensitivity_arrays, step_into, step_jacobian_into, step_workspace, jacobian_workspace,
# terms_to_arrays, user_table), which the packages above use.
__all__ = [
    "ABS_POW",
    "HINGE",
    "LOGISTIC",
    "Dynamics",
    "OpCompileError",
    "POW",
    "SIGN",
    "SQRT",
    "STEP",
    "StepModel",
    "USER",
    "UserOp",
    "assemble",
    "check_output_index",
    "check_terms",
    "evaluate_terms",
    "evaluate_terms_jacobian",
    "register_op",
    "step",
    "step_jacobian",
    "step_jacobian_kernel",
    "step_kernel",
    "step_model",
]
