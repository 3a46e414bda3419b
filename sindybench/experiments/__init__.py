"""The benchmarking study's three set-ups, EMPS, Silverbox and the literature's protocols, the runner and the report writers.

``sindybench run`` (:mod:`sindybench.cli`) is a thin layer over
:func:`run_benchmarks`; the same functions serve scripts and notebooks::

    from sindybench.experiments import get_benchmark, run_benchmarks
    run_benchmarks([get_benchmark("cascaded-tanks")], "results", quick=True)
"""

from ._published import PUBLISHED, PUBLISHED_REFERENCE, published
from ._registry import BENCHMARKS, get_benchmark, run_benchmarks
from ._report import (
    comparison_rows,
    fit_from_r2,
    format_number,
    results_markdown,
    staged_output_dir,
    write_report,
    write_results,
)
from ._runner import DataNotFoundError, evaluate, fit_model, load_data, run_benchmark, test_sets
from ._spec import Benchmark, ModelSpec

__all__ = [
    "BENCHMARKS",
    "Benchmark",
    "DataNotFoundError",
    "ModelSpec",
    "PUBLISHED",
    "PUBLISHED_REFERENCE",
    "comparison_rows",
    "evaluate",
    "fit_from_r2",
    "fit_model",
    "format_number",
    "get_benchmark",
    "load_data",
    "published",
    "results_markdown",
    "run_benchmark",
    "run_benchmarks",
    "staged_output_dir",
    "test_sets",
    "write_report",
    "write_results",
]
