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

import re
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


_SECTIONS = {"Parameters", "Returns", "Yields", "Attributes", "Other Parameters", "Receives"}
_TRAILING_UNDERSCORE = re.compile(r"(\w)_(?=\W|$)")


def _escape(text):
    if "``" in text or ":" in text:
        return text  # already marked up by its author
    return _TRAILING_UNDERSCORE.sub(r"\1\\_", text.replace("|", r"\|"))


def _escape_type_markup(app, what, name, obj, options, lines):
    """Escape reST markup in the type text of numpydoc parameter and return lines.

    numpydoc renders the type text (``default=("x|y|", ...)``,
    ``ndarray of shape (n_samples, n_output_features_)``) as reStructuredText,
    where ``|x|`` is a substitution and ``name_`` a link; neither is meant there.
    """
    section, indent = None, None
    for i, line in enumerate(lines):
        stripped = line.strip()
        if i + 1 < len(lines) and stripped and set(lines[i + 1].strip()) == {"-"}:
            section, indent = stripped, len(line) - len(line.lstrip())
            continue
        if section not in _SECTIONS or not stripped or set(stripped) == {"-"}:
            continue
        if len(line) - len(line.lstrip()) != indent:
            continue  # a description line
        head, sep, kind = line.partition(" : ")
        if sep:
            lines[i] = head + sep + _escape(kind)
        elif section in ("Returns", "Yields", "Receives"):
            lines[i] = _escape(line)


def setup(app):
    app.connect("autodoc-skip-member", _skip_sklearn_routing)
    app.connect("autodoc-process-docstring", _escape_type_markup, priority=100)  # before numpydoc
