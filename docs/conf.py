"""Sphinx configuration for the sindybench documentation.

Build with warnings as errors (as CI does)::

    sindybench run all --quick --out docs/_generated   # figures and tables (optional)
    python -m sphinx -W -b html docs docs/_build/html

The case-study pages include ``_generated/<benchmark>.rst``, which
``_casestudy.py`` writes here from the runner's output in
``docs/_generated/<benchmark>/`` (``results.json`` and PNG figures). When a
benchmark has not been run, the snippet says how to produce it, so the build
never refers to a missing image.
"""

import sys
from pathlib import Path

import sindybench

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _apiref import write_api_reference  # noqa: E402  (docs helpers beside this file)
from _casestudy import write_case_study_snippets  # noqa: E402

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
]

autosummary_generate = True
autodoc_default_options = {"members": True}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
nitpicky = False

templates_path = ["_templates"]
exclude_patterns = ["_build", "_generated", "Thumbs.db", ".DS_Store"]
html_theme = "alabaster"
html_static_path = ["_static"]
html_theme_options = {"description": "SINDy with control for hidden states and hard nonlinearities"}

write_case_study_snippets(HERE / "_generated", ("pick-and-place", "bouc-wen", "cascaded-tanks"))
write_api_reference(HERE / "api.rst")  # generated: lists every public name


def _skip_sklearn_routing(app, what, name, obj, skip, options):
    """Leave out the ``set_*_request`` methods scikit-learn adds to every estimator."""
    if name.startswith("set_") and name.endswith("_request"):
        return True
    return None


def setup(app):
    app.connect("autodoc-skip-member", _skip_sklearn_routing)
