"""Write ``api.rst``: an autosummary of every public module's ``__all__`` (run by conf.py)."""

import importlib
from pathlib import Path

MODULES = (
    ("sindybench", "Top level"),
    ("sindybench.hidden", "Hidden-state strategies"),
    ("sindybench.libraries", "Feature libraries"),
    ("sindybench.optimizers", "Sparse optimizers"),
    ("sindybench.differentiation", "Derivative estimation"),
    ("sindybench.dynamics", "Fitted dynamics: Dynamics, term operations, the one-step map and its Jacobians"),
    ("sindybench.simulate", "Simulation"),
    ("sindybench.identify", "Identify a system from data: the data advice and the structure search"),
    ("sindybench.refine", "Fitting by simulation error"),
    ("sindybench.estimation", "State estimation, prediction, linearization"),
    ("sindybench.export", "Export (CasADi)"),
    ("sindybench.uncertainty", "Uncertainty: residual analysis, calibrated bands, covariance, ensembles"),
    ("sindybench.metrics", "Metrics and scorers"),
    ("sindybench.plotting", "Plotting"),
    ("sindybench.report", "Reports: one self-contained HTML page per model and per benchmark"),
    ("sindybench.search", "Search spaces and the Optuna driver"),
    ("sindybench.model_selection", "Model selection"),
    ("sindybench.baselines", "Baselines"),
    ("sindybench.io", "Saving and loading models"),
    ("sindybench.datasets", "Datasets"),
    ("sindybench.systems", "Simulated systems"),
    ("sindybench.experiments", "The study's experiments"),
)


def _public(module):
    names = []
    for name in getattr(module, "__all__", ()):
        obj = getattr(module, name)
        if name.startswith("_") or not callable(obj):
            continue  # constants and version strings are described in the module text
        if getattr(obj, "__module__", "").split(".")[0] != "sindybench":
            continue
        names.append(name)
    return names


def write_api_reference(path, modules=MODULES):
    """Write the API page body; modules that are not importable are skipped."""
    lines = [
        "API reference",
        "=============",
        "",
        "Generated from the docstrings of each public module's ``__all__``. The most used names",
        "are re-exported from the top-level package (``from sindybench import SINDy, HiddenStateSINDy``).",
        "",
    ]
    seen = set()
    for modname, title in modules:
        try:
            module = importlib.import_module(modname)
        except ImportError:
            continue
        # a name that is also a module of the list (sindybench.identify) is documented in that module's section
        names = [n for n in _public(module) if (id(getattr(module, n))) not in seen
                 and f"{modname}.{n}" not in {m for m, _ in modules}]
        seen.update(id(getattr(module, n)) for n in names)
        lines += [title, "-" * len(title), "", f".. automodule:: {modname}", "   :no-members:", ""]
        if names:
            lines += [f".. currentmodule:: {modname}", "", ".. autosummary::", "   :toctree: generated", ""]
            lines += [f"   {n}" for n in sorted(names)] + [""]
    text = "\n".join(lines) + "\n"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)
