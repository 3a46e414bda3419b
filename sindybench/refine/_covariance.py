"""The covariance of refined parameters, as the refinement's record reaches it.

Its home is :mod:`sindybench._covariance` (public names in
:mod:`sindybench.uncertainty`, with the rest of uncertainty). It sits below
``refine`` so that :class:`~sindybench.refine.RefinementResult` computes the
covariance it records in model files with imports that point down; this
re-export keeps ``from ._covariance import parameter_covariance`` working
inside ``refine``.
"""

from .._covariance import ParameterCovariance, insignificant_lag, parameter_covariance

__all__ = ["ParameterCovariance", "insignificant_lag", "parameter_covariance"]
