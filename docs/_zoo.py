"""Write ``_generated/zoo_systems.rst``: every system of the zoo with its equations, tags and experiment (run by conf.py)."""

from pathlib import Path


def _rst_text(text):
    return text.replace("*", "\\*").replace("|", "\\|").replace("_", "\\_")


def write_zoo_systems(path):
    """The zoo's registry as a docs section per system, in registry order."""
    from sindybench.systems import zoo_systems
    from sindybench.systems._zoo_hidden import SYSTEMS as HIDDEN_HARD  # issue 35's set

    issue_35 = {s.name for s in HIDDEN_HARD}
    lines = [".. This file is written by docs/_zoo.py from sindybench.systems.ZOO; do not edit by hand.", ""]
    for system in zoo_systems():
        title = f"``{system.name}``"
        lines += [title, "^" * len(title), "", _rst_text(system.description), "", ".. code-block:: text", ""]
        lines += [f"   {eq}" for eq in system.equations] + [""]
        noise = f"{100 * system.noise:g} % {system.noise_colour}"
        reference = "reference (closed loop)" if system.closed_loop else "input"
        if system.name in issue_35:
            lines += ["- one of the hidden hard systems of issue 35 (a hard nonlinearity on a state that is not "
                      "measured)"]
        lines += [
            f"- tags: {', '.join(f'``{t}``' for t in system.tags)}",
            f"- {reference}: {_rst_text(system.excitation.describe())}",
            f"- dt = {system.dt:g}; {system.n_samples} estimation and {system.n_test} test samples; "
            f"{system.n_inputs} input(s), {system.n_outputs} output(s); noise {noise}",
            "",
        ]
    text = "\n".join(lines) + "\n"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)
