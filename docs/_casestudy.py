"""Write the generated part of each case-study page (used by conf.py).

For every benchmark, ``_generated/<benchmark>.rst`` holds the results table
(ours beside the study's), the figures and the fitted equations, read from
``_generated/<benchmark>/results.json`` as written by
``sindybench run all --out docs/_generated``. Without a run, it holds a note
saying how to produce them, so the documentation always builds.
"""

import json
from pathlib import Path

from sindybench.experiments import comparison_rows

COMMAND = "sindybench run all --quick --out docs/_generated"


def _list_table(rows, title):
    lines = [f".. list-table:: {title}", "   :header-rows: 1", ""]
    for row in rows:
        lines.append("   * - " + _escape(row[0]))
        lines += [f"     - {_escape(cell)}" for cell in row[1:]]
    return lines


def _escape(text):
    if text == "-":
        return "n/a"
    return str(text).replace("*", r"\*").replace("|", r"\|").replace("_", r"\_")


def _snippet(results, folder):
    mode = "quick (smoke-run) budgets" if results["quick"] else "default budgets"
    out = [
        f"Results of this build: seed {results['seed']}, {mode}, wall time "
        f"{results['wall_time_s']:.0f} s (sindybench {results['sindybench_version']}). "
        "The study's fit index (marked \\*) is derived from its R\\ :sup:`2`.",
        "",
    ]
    for name, info in results["test_sets"].items():
        out += _list_table(comparison_rows(results, name), f"Test set ``{name}`` ({info['n_samples']} samples)")
        out.append("")
    for key, fname in results.get("files", {}).get("figures", {}).items():
        out += [f".. figure:: /_generated/{folder}/{fname}", "   :width: 100%", "",
                f"   {'Hysteresis loops' if key == 'hysteresis' else 'Test set ' + key}: "
                "the measured output and each model's open-loop simulation error, a zoomed window and the "
                "spectra in dB.", ""]
    out += ["Fitted equations:", ""]
    for m in results["models"]:
        if m["equations"]:
            out += [f"*{_escape(m['label'])}*", "", ".. code-block:: text", ""]
            out += [f"   {eq}" for eq in m["equations"]] + [""]
    return out


def write_case_study_snippets(generated, benchmarks):
    """Write ``generated/<benchmark>.rst`` for each benchmark name."""
    generated = Path(generated)
    generated.mkdir(parents=True, exist_ok=True)
    for name in benchmarks:
        path = generated / name / "results.json"
        if path.is_file():
            lines = _snippet(json.loads(path.read_text()), name)
        else:
            lines = [
                ".. note::",
                "",
                "   The figures and the results table of this page are produced by the benchmark",
                "   runner and were not generated for this build. Run::",
                "",
                f"      {COMMAND}",
                "",
                "   (or without ``--quick`` for the full budgets) and build the documentation again.",
            ]
        text = "\n".join(lines) + "\n"
        target = generated / f"{name}.rst"
        if not target.is_file() or target.read_text() != text:
            target.write_text(text)
