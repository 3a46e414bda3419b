"""Which process left something behind, and whether that process is gone.

A search trial left RUNNING, or a staging folder of ``sindybench run``, is
tagged with its owner: host name, process id and a token drawn once per
process. A later process on the same host can then tell, without guessing,
that the owner no longer runs: its PID is free, or now belongs to a process
that started after the thing was made (a reused PID), or is its own PID with
another token (a restarted container, where the worker is PID 1 again).
"""

import os
import socket
import uuid

__all__ = ["owner", "owner_is_gone"]

_TOKEN = {}


def _token():
    """A random token of this process (a forked child draws its own)."""
    pid = os.getpid()
    if pid not in _TOKEN:
        _TOKEN.clear()
        _TOKEN[pid] = uuid.uuid4().hex
    return _TOKEN[pid]


def owner():
    """``{"host", "pid", "token"}`` of this process.

    Examples
    --------
    >>> me = owner()
    >>> me["pid"] == os.getpid(), me == owner(), len(me["token"])
    (True, True, 32)
    """
    return {"host": socket.gethostname(), "pid": os.getpid(), "token": _token()}


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # another user's process (or a PID this system cannot have): not provably gone
    return True


def _start_time(pid):
    """Start of process ``pid`` in seconds since the epoch (Linux ``/proc``), or ``None`` where unknown."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            fields = f.read().rsplit(b")", 1)[1].split()
        with open("/proc/stat", "rb") as f:
            boot = next(int(line.split()[1]) for line in f if line.startswith(b"btime "))
        return boot + int(fields[19]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, StopIteration):
        return None


def owner_is_gone(host, pid, token=None, since=None, *, margin=60.0):
    """True when the process ``host:pid`` (with ``token``) provably no longer runs.

    Only owners on this host can be judged; on another host the answer is
    ``False``. On this host the owner is gone when ``pid`` runs no process,
    when it is this process's own PID but ``token`` is another one (or none:
    the owner was an earlier process with the same PID), or when the process
    with that PID started more than ``margin`` seconds after ``since``
    (seconds since the epoch: when the owner made the thing), a PID that was
    reused. The margin absorbs steps of the wall clock (NTP), which shift the
    start time computed from ``/proc``.

    Examples
    --------
    >>> me = owner()
    >>> owner_is_gone(**me), owner_is_gone(me["host"], me["pid"], "a restarted container's worker")
    (False, True)
    >>> owner_is_gone("another-host", 12345)
    False
    """
    if host != socket.gethostname() or isinstance(pid, bool) or not isinstance(pid, int) or pid <= 0:
        return False
    if pid == os.getpid():
        return token != _token()
    if not _alive(pid):
        return True
    if since is not None:
        started = _start_time(pid)
        return started is not None and started > since + margin
    return False
