"""A throw-away PostgreSQL server for the tests: started from the machine's binaries, removed after.

The server runs from a fresh data folder in a temporary directory, listens on a Unix
socket in that directory only (``listen_addresses = ''``: no TCP port at all), trusts
local connections, and is stopped and deleted by :func:`postgres_server` whatever
happens in between. PostgreSQL refuses to run as root: when the tests run as root,
``initdb`` and ``pg_ctl`` run as the unprivileged ``postgres`` user (Debian's package
creates it), else as ``nobody``.

Nothing here is part of sindybench: the library only ever sees the URL.
"""

import contextlib
import glob
import os
import pwd
import shutil
import subprocess
import tempfile
import uuid
from pathlib import Path

__all__ = ["create_database", "find_bindir", "postgres_server", "url"]

_TOOLS = ("initdb", "pg_ctl", "createdb")
_SUPERUSER = "sindybench"
_PORT = 5432  # only names the socket file: no TCP listener


def _has_tools(folder):
    return folder is not None and all(os.access(os.path.join(folder, t), os.X_OK) for t in _TOOLS)


def find_bindir():
    """Folder holding ``initdb``, ``pg_ctl`` and ``createdb``, or ``None``.

    Tried in order: ``pg_config --bindir``, the tools on ``PATH``, then the newest
    ``/usr/lib/postgresql/*/bin`` (Debian and Ubuntu keep the server tools there,
    off ``PATH``).
    """
    candidates = []
    pg_config = shutil.which("pg_config")
    if pg_config:
        with contextlib.suppress(OSError, subprocess.SubprocessError):
            out = subprocess.run([pg_config, "--bindir"], capture_output=True, text=True, timeout=10, check=True)
            candidates.append(out.stdout.strip())
    initdb = shutil.which("initdb")
    if initdb:
        candidates.append(os.path.dirname(initdb))

    def version(path):
        name = Path(path).parent.name
        return int(name) if name.isdigit() else -1

    candidates += sorted(glob.glob("/usr/lib/postgresql/*/bin"), key=version, reverse=True)
    return next((c for c in candidates if _has_tools(c)), None)


def _server_user():
    """``(uid, gid, name)`` to run the server as, or ``None`` to run as ourselves (not root)."""
    if os.geteuid() != 0:
        return None
    for name in ("postgres", "nobody"):
        with contextlib.suppress(KeyError):
            entry = pwd.getpwnam(name)
            return entry.pw_uid, entry.pw_gid, name
    raise RuntimeError("running as root and neither a 'postgres' nor a 'nobody' user exists to run PostgreSQL")


def _run(args, user, *, timeout=60):
    kwargs = {}
    if user is not None:
        kwargs = {"user": user[0], "group": user[1], "extra_groups": []}
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "LC_ALL": "C", "LANG": "C"}
    proc = subprocess.run(args, capture_output=True, text=True, timeout=timeout, env=env, cwd="/", **kwargs)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, args))} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    return proc


@contextlib.contextmanager
def postgres_server(bindir):
    """Start a PostgreSQL server; yield ``(socket_dir, superuser)``; stop and remove it.

    Parameters
    ----------
    bindir : str
        Folder of ``initdb`` and ``pg_ctl`` (:func:`find_bindir`).

    Yields
    ------
    socket_dir : str
        Folder of the server's Unix socket (the ``host`` of a libpq URL).
    superuser : str
        Role that may connect without a password (``trust``, local socket only).
    """
    user = _server_user()
    root = Path(tempfile.mkdtemp(prefix="sindybench-pg-"))
    data, sockets, log = root / "data", root / "socket", root / "server.log"
    started = False
    try:
        sockets.mkdir()
        if user is not None:
            for path in (root, sockets):
                os.chown(path, user[0], user[1])
        _run([f"{bindir}/initdb", "-D", data, "-U", _SUPERUSER, "--auth=trust", "-E", "UTF8", "--no-sync"], user)
        options = f"-k {sockets} -p {_PORT} -c listen_addresses='' -c fsync=off -c full_page_writes=off"
        started = True  # from here on, a failed start may still have left a server behind
        _run([f"{bindir}/pg_ctl", "-D", data, "-l", log, "-w", "-t", "60", "-o", options, "start"], user, timeout=90)
        yield str(sockets), _SUPERUSER
    finally:
        try:
            if started:
                with contextlib.suppress(RuntimeError, subprocess.SubprocessError):
                    _run([f"{bindir}/pg_ctl", "-D", data, "-m", "immediate", "-w", "-t", "30", "stop"], user)
                _kill_leftover(data)
        finally:
            shutil.rmtree(root, ignore_errors=True)


def _kill_leftover(data):
    """SIGKILL the postmaster named in ``postmaster.pid`` if ``pg_ctl stop`` left it running."""
    with contextlib.suppress(OSError, ValueError, IndexError):
        pid = int((data / "postmaster.pid").read_text().split()[0])
        os.kill(pid, 9)


def create_database(bindir, socket_dir, superuser):
    """Create a new, empty database on the server; return its name."""
    name = f"study_{uuid.uuid4().hex[:12]}"
    _run([f"{bindir}/createdb", "-h", socket_dir, "-p", str(_PORT), "-U", superuser, name], None)
    return name


def url(socket_dir, superuser, database):
    """SQLAlchemy URL of ``database`` over the Unix socket, with the psycopg (3) driver."""
    return f"postgresql+psycopg://{superuser}@/{database}?host={socket_dir}&port={_PORT}"
