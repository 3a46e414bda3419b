"""numba's on-disk cache: a kernel cached against one table of term operations does not run with another."""

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import sindybench
from sindybench import _numba_cache

PACKAGE = Path(sindybench.__file__).parent

# HINGE(3; level 1) through a cached kernel of _ops.py, and whether it came from numba's cache
SCRIPT = textwrap.dedent("""
    import numpy as np
    from sindybench.dynamics._ops import HINGE, evaluate_kernel
    out = np.zeros((1, 1))
    evaluate_kernel(np.array([[3.0]]), np.array([0, 1]), np.array([0]), np.array([HINGE]), np.array([1.0]),
                    np.array([1.0]), None, out)
    print(out[0, 0], sum(evaluate_kernel.stats.cache_hits.values()))
    assert evaluate_kernel.py_func.__code__.co_filename.startswith({root!r})
""")


def _run(root, cache):
    env = {**os.environ, "PYTHONPATH": str(root), "NUMBA_CACHE_DIR": str(cache)}
    env.pop("NUMBA_CACHE_LOCATOR_CLASSES", None)
    done = subprocess.run([sys.executable, "-c", SCRIPT.format(root=str(root))], env=env, cwd=root, capture_output=True, text=True,
                          timeout=600, check=False)  # cwd: `-c` puts it first on the path
    assert done.returncode == 0, done.stderr
    value, hits = done.stdout.split()
    return float(value), int(hits)


@pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT") == "1", reason="nothing is compiled, nothing cached")
def test_a_kernel_cached_against_another_op_table_is_recompiled(tmp_path):
    # a copy of the package, so that its op table can change (as when code 5, HINGE, was added)
    shutil.copytree(PACKAGE, tmp_path / "pkg" / "sindybench", ignore=shutil.ignore_patterns("__pycache__"))
    cache = tmp_path / "cache"
    assert _run(tmp_path / "pkg", cache) == (2.0, 0)  # compiled and saved
    assert _run(tmp_path / "pkg", cache) == (2.0, 1)  # the same table: the cached kernel is loaded
    table = tmp_path / "pkg" / "sindybench" / "dynamics" / "_optable.py"
    old = "    return 0.0 if d <= 0.0 else d  # NaN stays NaN\n"
    assert old in table.read_text()
    table.write_text(table.read_text().replace(old, "    return 0.0 if d <= 0.0 else 2.0 * d\n"))
    fingerprint = _numba_cache.op_table_fingerprint(tmp_path / "pkg" / "sindybench")
    assert fingerprint != _numba_cache.op_table_fingerprint(PACKAGE)
    assert _run(tmp_path / "pkg", cache) == (4.0, 0)  # the new table's value, not the stale kernel's 2.0


def test_stamping_twice_adds_one_locator():
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    before = list(impl._locator_classes)
    assert _numba_cache.stamp_kernels_with_op_table()  # done once by `import sindybench`
    assert impl._locator_classes == before
    assert sum(hasattr(cls, "op_table_stamp") for cls in before) == 1
    locator = sindybench.dynamics._ops.evaluate_kernel._cache._impl.locator
    assert locator.get_source_stamp()[-1] == _numba_cache.op_table_fingerprint()
