"""The examples run in their quick form (as CI runs them)."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize(
    "script, expected",
    [
        ("quickstart.py", "identical simulation: True"),  # the README's first command (no --quick needed)
        ("pick_and_place.py", "SINDy, 2nd order"),
        ("bouc_wen.py", "Ideal"),
        ("cascaded_tanks.py", "Hidden SINDy"),
        ("sklearn_optuna_workflow.py", "tune"),
    ],
)
def test_example_runs_quick(script, expected, data_home, tmp_path):
    env = {**os.environ, "SINDYBENCH_DATA": str(data_home), "MPLBACKEND": "Agg"}
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / script), "--quick"],
        capture_output=True, text=True, timeout=600, cwd=tmp_path, env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert expected in proc.stdout
    assert not re.search(r"\bnan\b", proc.stdout, flags=re.IGNORECASE)
