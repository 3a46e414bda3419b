"""Put the example notebooks into ``notebooks/`` for myst-nb (used by conf.py).

The notebooks are Jupytext text notebooks, ``examples/<name>.py``. For each,
``notebooks/<name>.ipynb`` is written from

* ``_generated/notebooks/<name>.ipynb`` when that executed copy exists (the
  test suite writes it: ``tests/test_examples.py`` runs every notebook in a
  Jupyter kernel, and the docs-build test renders those outputs instead of
  executing the notebooks a second time); it is marked so that myst-nb does not
  execute it again;
* otherwise the text notebook itself, which myst-nb executes during the build
  (``SINDYBENCH_QUICK=1`` for small budgets).
"""

from pathlib import Path

NOTEBOOKS = ("quickstart", "pick_and_place", "bouc_wen", "cascaded_tanks", "sklearn_optuna_workflow", "mpc_tanks")


def write_notebooks(target, executed, examples, names=NOTEBOOKS):
    """Write ``target/<name>.ipynb`` for each notebook name (unchanged files are not touched)."""
    import jupytext
    import nbformat

    target, executed, examples = Path(target), Path(executed), Path(examples)
    target.mkdir(parents=True, exist_ok=True)
    for name in names:
        done = executed / f"{name}.ipynb"
        if done.is_file():
            notebook = nbformat.read(done, as_version=4)
            notebook.metadata.setdefault("mystnb", {})["execution_mode"] = "off"
        else:
            notebook = jupytext.read(examples / f"{name}.py")
        text = nbformat.writes(notebook)
        path = target / f"{name}.ipynb"
        if not path.is_file() or path.read_text() != text:
            path.write_text(text)
