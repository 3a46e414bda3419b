"""numba's on-disk cache shared by processes that compile at once (``run all``'s workers, ``sindybench.warm``).

numba saves a kernel by reading the function's index, adding its entry and writing the index
back: two processes saving two specializations of one function at once can both take the same
data file, and the index can then point one signature at the other's machine code (numba issue
#10128). :func:`lock_numba_cache` makes a process save under a file lock that the other
processes of the same run share; reading the cache needs no lock (numba replaces its files
atomically).
"""

import functools
import importlib
import os

__all__ = ["lock_numba_cache", "numba_cache_lockable"]

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
