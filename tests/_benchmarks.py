"""A script of ``benchmarks/`` imported as a module by the tests of that script."""

import contextlib
import importlib
import os
import sys
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@contextlib.contextmanager
def benchmark_script(name):
    """The module ``benchmarks/<name>.py``; the thread pins it sets in the environment at import are undone after."""
    saved = dict(os.environ)
    sys.path.insert(0, str(BENCHMARKS))
    try:
        yield importlib.import_module(name)
    finally:
        sys.path.remove(str(BENCHMARKS))
        os.environ.clear()
        os.environ.update(saved)
