"""The example notebooks execute from a clean Jupyter kernel in quick mode and show what they promise.

The notebooks are Jupytext text notebooks (``examples/*.py``, percent format); each is read
with jupytext and executed by nbclient in an ipykernel (see ``NotebookRunner`` in
conftest.py). The executed copies are what the documentation renders
(``test_docs_build_with_generated_figures`` in test_cli.py), so every notebook runs once.
"""

import re

import pytest

NOTEBOOKS = {
    # name: (text its outputs must show, figures at least, typeset equations expected)
    "quickstart": ("identical simulation: True", 2, True),
    "pick_and_place": ("SINDy, 2nd order", 4, True),
    "bouc_wen": ("Ideal (true m, c, k)", 5, True),
    "cascaded_tanks": ("Hidden SINDy", 3, True),
    "sklearn_optuna_workflow": ("tune", 2, False),
    "mpc_tanks": ("closed loop over", 1, True),
}


def _outputs(notebook, kind):
    return [out for cell in notebook.cells if cell.cell_type == "code" for out in cell.outputs
            if out.output_type == kind or kind in out.get("data", {})]


@pytest.mark.parametrize("name", sorted(NOTEBOOKS))
def test_notebook_executes_in_quick_mode(notebooks, name):
    text, n_figures, latex = NOTEBOOKS[name]
    notebook = notebooks.run(name)
    assert not _outputs(notebook, "error")
    streams = "".join(out.text for out in _outputs(notebook, "stream") if out.name == "stdout")
    assert text in streams
    assert not re.search(r"\bnan\b", streams, flags=re.IGNORECASE)
    assert len(_outputs(notebook, "image/png")) >= n_figures
    typeset = [out["data"]["text/latex"] for out in _outputs(notebook, "text/latex")]
    assert bool(typeset) == latex
    assert all(t.startswith("$$\\begin{aligned}") for t in typeset)
    stderr = "".join(out.text for out in _outputs(notebook, "stream") if out.name == "stderr")
    assert stderr == ""  # no warnings, logs or progress bars (SINDYBENCH_PROGRESS=0) in the rendered outputs
