"""Sphinx configuration for the sindybench documentation.

Build with warnings as errors (as CI does)::

    sindybench run all --quick --out docs/_generated   # figures and tables (optional)
    python -m sphinx -W -b html docs docs/_build/html

The case-study pages include ``_generated/<benchmark>.rst``, which
``_casestudy.py`` writes here from the runner's output in
``docs/_generated/<benchmark>/`` (``results.json`` and PNG figures). When a
benchmark has not been run, the snippet says how to produce it, so the build
never refers to a missing image.

The example notebooks (``examples/*.py``, Jupytext text notebooks) are rendered
by myst-nb from ``notebooks/``, which ``_notebooks.py`` fills: with the outputs
of an earlier run when ``_generated/notebooks/`` holds them (the test suite's),
else myst-nb executes them here (set ``SINDYBENCH_QUICK=1`` for small budgets
and ``SINDYBENCH_DATA`` to the benchmark records). The plotting API's figures
are drawn by matplotlib's plot directive.
"""

import sys
from pathlib import Path

import sindybench
from sindybench.experiments import BENCHMARKS

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _apiref import write_api_reference  # noqa: E402  (docs helpers beside this file)
from _casestudy import write_case_study_snippets  # noqa: E402
from _notebooks import write_notebooks  # noqa: E402
from _zoo import write_zoo_systems  # noqa: E402

project = "sindybench"
author = "sindybench developers"
copyright = "2024, sindybench developers"
release = sindybench.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_nb",
    "matplotlib.sphinxext.plot_directive",
]

autosummary_generate = True
autodoc_default_options = {"members": True}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
nitpicky = False

templates_path = ["_templates"]
# zoo_table.rst: written by benchmarks/bench_zoo.py, included by zoo.rst
exclude_patterns = ["_build", "_generated", "jupyter_execute", "zoo_table.rst", "Thumbs.db", ".DS_Store"]
html_theme = "alabaster"
html_static_path = ["_static"]
html_theme_options = {"description": "SINDy with control for hidden states and hard nonlinearities"}

write_case_study_snippets(HERE / "_generated", tuple(BENCHMARKS))  # the registry's benchmarks
write_api_reference(HERE / "api.rst")  # generated: lists every public name
write_zoo_systems(HERE / "_generated" / "zoo_systems.rst")  # the zoo's registry, for zoo.rst
write_notebooks(HERE / "notebooks", HERE / "_generated" / "notebooks", HERE.parent / "examples")

# myst-nb: executed outputs are reused (see _notebooks.py); a failing cell fails the build
nb_execution_mode = "auto"
nb_execution_raise_on_error = True
nb_execution_timeout = 1800
nb_merge_streams = True
# a fitted model's equations: the LaTeX rendering rather than the HTML (which holds the diagram too)
nb_mime_priority_overrides = [("html", "text/latex", 25)]
myst_enable_extensions = ["dollarmath"]

# matplotlib's plot directive (figures of sindybench.plotting)
plot_include_source = True
plot_html_show_source_link = False
plot_html_show_formats = False
plot_formats = [("png", 90)]


def _skip_sklearn_routing(app, what, name, obj, skip, options):
    """Leave out the ``set_*_request`` methods scikit-learn adds to every estimator."""
    if name.startswith("set_") and name.endswith("_request"):
        return True
    return None


def setup(app):
    app.connect("autodoc-skip-member", _skip_sklearn_routing)
