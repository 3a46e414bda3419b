"""Reports a person opens: one self-contained HTML file on an identified model, and on a ``run all``.

* :func:`identification_report`: the chosen model's equations, its errors
  on the validation blocks and the test record (output and error on one
  axis, a zoomed window, the error spectrum in dB), the data advice, the
  Pareto front, the residual analysis, the calibrated band, the standard
  errors and every candidate;
* :func:`benchmark_report` and :func:`benchmark_index`: one page per
  benchmark of ``sindybench run all``, and the index linking them.

Every page is one HTML file with its figures inline (PNG drawn by
:mod:`sindybench.plotting`) and its equations in MathML: it opens offline
and can be mailed. What a page shows: :doc:`/report`.
"""

from ._benchmark import benchmark_index, benchmark_report
from ._identification import identification_report

__all__ = ["benchmark_index", "benchmark_report", "identification_report"]
