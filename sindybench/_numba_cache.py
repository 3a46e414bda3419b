"""numba's on-disk cache: kept fresh when the term operations change, and shared by processes that compile at once.

**Freshness.** numba reuses a cached kernel while the kernel's own source file is unchanged; it
does not see a change in a function the kernel calls from another file. Every compiled user of
the terms calls the dispatch that :mod:`sindybench.dynamics._ops` writes from the table of
:mod:`sindybench.dynamics._optable`, so a new or changed operation (code 5, ``HINGE``) left
kernels compiled against the old table in ``__pycache__``: they ran, and gave the old values.
:func:`stamp_kernels_with_op_table` (called first thing by ``import sindybench``) adds a
fingerprint of those two files to the source stamp of every sindybench kernel, so a cache
written against another table is stale and is recompiled. (Not with
``NUMBA_CACHE_LOCATOR_CLASSES`` set: numba then uses only the classes it names.)

**Processes at once** (``run all``'s workers, ``sindybench.warm``).
numba saves a kernel by reading the function's index, adding its entry and writing the index
back: two processes saving two specializations of one function at once can both take the same
data file, and the index can then point one signature at the other's machine code (numba issue
#10128). :func:`lock_numba_cache` makes a process save under a file lock that the other
processes of the same run share; reading the cache needs no lock (numba replaces its files
atomically).
"""

import functools
import hashlib
import importlib
import os
from pathlib import Path

__all__ = ["lock_numba_cache", "numba_cache_lockable", "op_table_fingerprint", "stamp_kernels_with_op_table"]

# the save method whose read-modify-write of the index the lock covers
_NUMBA_SAVE = ("numba.core.caching", "IndexDataCacheFile", "save")


def _save_method():
    """``(class, method)`` of numba's index save; None if this numba has no such method."""
    module, name, method = _NUMBA_SAVE
    try:
        cls = getattr(importlib.import_module(module), name)
        return cls, getattr(cls, method)
    except (ImportError, AttributeError):
        return None


def numba_cache_lockable():
    """Whether :func:`lock_numba_cache` finds numba's save method (else processes must not compile at once)."""
    return _save_method() is not None


def lock_numba_cache(path):
    """Make this process save numba's cache entries under the file lock ``path``; False if numba has no hook.

    Every process that calls it with the same ``path`` saves one at a time
    (see the module text). Calling it again changes the lock file.
    """
    from filelock import FileLock

    found = _save_method()
    if found is None:
        return False
    cls, save = found
    original = getattr(save, "__wrapped__", save)
    lock = FileLock(os.fspath(path))

    @functools.wraps(original)
    def save_locked(self, key, data):
        with lock:
            return original(self, key, data)

    save_locked.lock_file = os.fspath(path)
    setattr(cls, _NUMBA_SAVE[2], save_locked)
    return True


# the files whose content every compiled user of the terms depends on (the table and its dispatch)
_OP_TABLE_FILES = ("dynamics/_optable.py", "dynamics/_ops.py")
_PACKAGE = __name__.partition(".")[0]


def op_table_fingerprint(root=None):
    """A hash of the term operations' source (:data:`_OP_TABLE_FILES` under the package ``root``)."""
    root = Path(__file__).parent if root is None else Path(root)
    digest = hashlib.sha256()
    for name in _OP_TABLE_FILES:
        digest.update((root / name).read_bytes())
    return digest.hexdigest()


def stamp_kernels_with_op_table():
    """Make numba's cache of every sindybench kernel depend on the table of term operations; False without a hook.

    numba picks a *locator* for each ``cache=True`` function when it is decorated: it says where the
    cache lives and stamps the source it was compiled from. The locator put first here takes the
    sindybench functions, lets numba's own locators choose the place, and adds
    :func:`op_table_fingerprint` to their stamp (see the module text). Functions decorated before
    the call keep numba's stamp; calling it again changes nothing.
    """
    try:
        caching = importlib.import_module("numba.core.caching")
        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl  # _CacheImpl before numba 0.61
        classes, base = impl._locator_classes, caching._CacheLocator
    except (ImportError, AttributeError):
        return False
    if any(getattr(cls, "op_table_stamp", None) for cls in classes):
        return True
    fingerprint = op_table_fingerprint()

    class OpTableLocator(base):
        """numba's locator of a sindybench function, its source stamp joined by the op table's fingerprint."""

        op_table_stamp = fingerprint

        def __init__(self, inner):
            self._inner = inner
            self._py_file = getattr(inner, "_py_file", None)  # numba's warning of an uncachable kernel names it

        def ensure_cache_path(self):
            self._inner.ensure_cache_path()

        def get_cache_path(self):
            return self._inner.get_cache_path()

        def get_source_stamp(self):
            return self._inner.get_source_stamp(), "op table", fingerprint

        def get_disambiguator(self):
            return self._inner.get_disambiguator()

        @classmethod
        def from_function(cls, py_func, py_file):
            if (getattr(py_func, "__module__", None) or "").partition(".")[0] != _PACKAGE:
                return None
            for other in classes:
                inner = None if other is cls else other.from_function(py_func, py_file)
                if inner is not None:
                    return cls(inner)
            return None

    classes.insert(0, OpTableLocator)
    return True
