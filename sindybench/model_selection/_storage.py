"""Where a study lives: in memory, an SQLite/RDB database, or an Optuna journal file.

Also the bookkeeping that makes a study resumable: which trials count toward
the budget, and which RUNNING trials were left behind by a dead worker.
"""

import contextlib
import datetime
import json
import logging
import os
import random
import socket
import time
import warnings

import optuna
from optuna.storages import BaseStorage, InMemoryStorage, JournalStorage, RDBStorage
from optuna.storages.journal import JournalFileBackend, JournalFileOpenLock, JournalFileSymlinkLock
from optuna.trial import TrialState

from .._process import owner, owner_is_gone

__all__ = [
    "check_storage",
    "count_claimed",
    "count_done",
    "describe_storage",
    "fail_dead_workers",
    "make_storage",
    "mend_journal_tail",
    "tag_trial",
    "this_call_trials",
    "worker_id",
]

logger = logging.getLogger(__name__)

#: Seconds between heartbeats of a running trial in an RDB storage, and the
#: silence after which another worker marks the trial FAIL.
HEARTBEAT_INTERVAL = 60
GRACE_PERIOD = 180

#: Seconds after which a RUNNING trial that names no worker is an orphan: its worker could not write its
#: name (a full disk), which it does a few milliseconds after creating the trial.
UNTAGGED_GRACE = 60

#: A process that started this many seconds after a trial cannot be the trial's worker (a reused PID).
_START_MARGIN = 7200.0

_JOURNAL_PREFIX = "journal://"
_JOURNAL_SUFFIXES = (".log", ".journal")
_SQLITE_SUFFIXES = (".db", ".sqlite", ".sqlite3")


def _rdb(url):
    from sqlalchemy.exc import ArgumentError, DatabaseError, OperationalError  # SQLAlchemy comes with optuna

    where = describe_storage(url)
    try:
        return _open_rdb(url)
    except ImportError as exc:  # SQLAlchemy imports the URL's driver when it makes the engine
        scheme = url.split("://", 1)[0]
        raise ImportError(
            f"storage {scheme}://...: the database driver is not installed ({exc.__cause__ or exc}). For PostgreSQL: "
            "pip install 'sindybench[postgres]' (psycopg 3, URL 'postgresql+psycopg://user@host/db'); "
            "for MySQL: pip install pymysql (URL 'mysql+pymysql://user@host/db')."
        ) from exc
    except ArgumentError as exc:  # an unknown database kind (NoSuchModuleError) or a URL that does not parse
        raise ValueError(_bad_url_message(where, exc)) from None
    except OperationalError as exc:
        if url.startswith("sqlite:///"):
            raise OSError(f"storage {where!r}: cannot open the SQLite file {url[len('sqlite:///'):]!r} "
                          f"({getattr(exc, 'orig', exc)}).") from exc
        raise ConnectionError(
            f"storage {where!r}: cannot reach the database ({_first_line(getattr(exc, 'orig', exc))}); expected a "
            "running server that accepts this URL (host, port, user, password, database name)."
        ) from exc
    except DatabaseError as exc:  # sqlite: "file is not a database"
        raise ValueError(
            f"storage {where!r}: {url[len('sqlite:///'):]!r} is not an SQLite database ({getattr(exc, 'orig', exc)}); "
            "expected an SQLite file written by Optuna, or the name of a new file."
        ) from exc


def _first_line(exc):
    return str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__


def _bad_url_message(where, exc):
    scheme = where.split("://", 1)[0]
    if type(exc).__name__ == "NoSuchModuleError":
        return (f"storage {where!r}: {scheme!r} is not a database kind SQLAlchemy knows; expected a URL such as "
                "'sqlite:///study.db', 'postgresql+psycopg://user@host/db' or 'mysql+pymysql://user@host/db'.")
    return f"storage {where!r} is not a database URL ({exc}); expected e.g. 'sqlite:///study.db'."


def _open_rdb(url):
    engine_kwargs, path = None, None
    if url.startswith("sqlite:///"):
        # several local workers write to one file: wait for the lock instead of failing
        engine_kwargs = {"connect_args": {"timeout": 60}}
        path = url[len("sqlite:///") :]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        if not path:
            return _create_server_rdb(url)
        # two workers creating the tables of a new SQLite file at once collide: take turns
        lock = JournalFileOpenLock(path)
        lock.acquire()  # blocks; a lock older than 30 s (a killed worker) is broken
        try:
            return RDBStorage(
                url, engine_kwargs=engine_kwargs, heartbeat_interval=HEARTBEAT_INTERVAL, grace_period=GRACE_PERIOD
            )
        finally:
            lock.release()


def _create_server_rdb(url, attempts=8):
    """``RDBStorage`` on a database server, whose tables several workers may be creating at once.

    Workers started together on a new database all create Optuna's tables; the
    server lets one win and the others fail on a duplicate name (an
    ``IntegrityError`` or ``ProgrammingError``). A loser tries again after a short
    pause, when the tables exist.
    """
    from sqlalchemy.exc import IntegrityError, ProgrammingError  # SQLAlchemy comes with optuna

    for attempt in range(attempts):
        try:
            return RDBStorage(url, heartbeat_interval=HEARTBEAT_INTERVAL, grace_period=GRACE_PERIOD)
        except (IntegrityError, ProgrammingError) as exc:
            if attempt == attempts - 1:
                raise
            logger.debug("creating the tables of %s collided with another worker (%s); retrying", url, exc)
            time.sleep(0.1 * 2**attempt * (1 + random.random()))
    raise AssertionError("unreachable")  # pragma: no cover


def _parse(storage):
    """Return ``(kind, target)`` for ``storage`` without opening anything (see :func:`make_storage`)."""
    if storage is None:
        return "memory", None
    if isinstance(storage, BaseStorage):
        return "object", storage
    if isinstance(storage, (str, os.PathLike)):
        text = os.fspath(storage)
        if text.startswith(_JOURNAL_PREFIX):
            return "journal", text[len(_JOURNAL_PREFIX) :]
        if "://" in text:
            return "rdb", text
        if text.endswith(_JOURNAL_SUFFIXES):
            return "journal", text
        if text.endswith(_SQLITE_SUFFIXES):
            return "rdb", "sqlite:///" + os.path.abspath(text)
    raise ValueError(
        f"storage {storage!r} is not understood; expected None, a database URL ('sqlite:///study.db', "
        "'postgresql://...'), 'journal:///path/study.log', a path ending in .log/.journal (journal file) "
        "or .db/.sqlite/.sqlite3 (SQLite), or an optuna storage."
    )


def check_storage(storage):
    """Check a ``storage`` argument of :func:`~sindybench.model_selection.tune` without opening it.

    Raises ``ValueError`` when the form is not understood (see :func:`make_storage`)
    or when the folder of a journal or SQLite file does not exist. Nothing is
    created and no database is contacted, so a command line can check its
    arguments before any work starts.

    Parameters
    ----------
    storage : None, str, path-like or optuna.storages.BaseStorage

    Returns
    -------
    storage
        The argument, unchanged.

    Examples
    --------
    >>> check_storage("sqlite:///study.db")
    'sqlite:///study.db'
    >>> check_storage("no_such_folder/study.log")
    Traceback (most recent call last):
    ...
    ValueError: storage 'no_such_folder/study.log': the folder 'no_such_folder' does not exist; expected an existing folder for the journal file.
    """
    _parse_checked(storage)
    return storage


def _parse_checked(storage):
    kind, target = _parse(storage)
    if kind == "journal":
        path, noun = target, "journal"
    elif kind == "rdb" and target.startswith("sqlite:///"):
        path, noun = target[len("sqlite:///") :], "SQLite"
    else:
        if kind == "rdb":
            _check_url(target)
        return kind, target
    folder = os.path.dirname(path)
    if folder and not os.path.isdir(folder):
        raise ValueError(
            f"storage {storage!r}: the folder {folder!r} does not exist; expected an existing folder for the "
            f"{noun} file."
        )
    if os.path.isdir(path):
        raise ValueError(f"storage {storage!r}: {path!r} is a folder; expected the name of a {noun} file.")
    if noun == "SQLite":
        _check_sqlite_file(storage, path)
    else:
        _check_journal_file(storage, path)
    return kind, target


def _check_url(url):
    """``ValueError`` for a URL SQLAlchemy cannot parse or whose database kind it does not know (nothing opened)."""
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        make_url(url).get_dialect()  # loads SQLAlchemy's dialect module, never the driver, never connects
    except ArgumentError as exc:
        raise ValueError(_bad_url_message(describe_storage(url), exc)) from None


def _read_start(path, size, *, line=False):
    """The first ``size`` bytes (or first line, at most ``size`` bytes) of ``path``; ``None`` when it does not exist."""
    try:
        with open(path, "rb") as f:
            return f.readline(size) if line else f.read(size)
    except FileNotFoundError:
        return None  # a new file
    except OSError as exc:
        raise OSError(f"storage file {path!r} cannot be read: {exc}") from exc


def _check_sqlite_file(storage, path):
    head = _read_start(path, 16)
    if head and head != b"SQLite format 3\x00":
        raise ValueError(
            f"storage {storage!r}: {path!r} is not an SQLite database (it does not start with the SQLite header); "
            "expected an SQLite file written by Optuna, or the name of a new file."
        )


def _check_journal_file(storage, path):
    line = _read_start(path, 1 << 20, line=True)
    if not line:
        return
    try:
        entry = json.loads(line) if line.endswith(b"\n") else {"op_code": None}  # a first write in progress
    except ValueError:
        entry = None
    if not isinstance(entry, dict) or "op_code" not in entry:
        raise ValueError(
            f"storage {storage!r}: {path!r} is not an Optuna journal file (line 1 is not a journal entry); "
            "expected a journal written by Optuna, or the name of a new file."
        )


def describe_storage(storage):
    """A text naming ``storage`` for logs and result files, with any password in a URL masked.

    Examples
    --------
    >>> describe_storage("postgresql+psycopg://optuna:secret@db.example.org/studies")
    'postgresql+psycopg://optuna:***@db.example.org/studies'
    >>> describe_storage("study.log"), describe_storage(None)
    ('study.log', None)
    """
    if storage is None:
        return None
    if isinstance(storage, BaseStorage):
        return type(storage).__name__
    text = os.fspath(storage)
    scheme, sep, rest = text.partition("://")
    credentials, at, location = rest.rpartition("@")
    if not (sep and at and ":" in credentials):
        return text
    return f"{scheme}://{credentials.split(':', 1)[0]}:***@{location}"


def make_storage(storage):
    """Turn ``storage`` into an Optuna storage.

    Parameters
    ----------
    storage : None, str, path-like or optuna.storages.BaseStorage
        - ``None``: in memory (lost when the process ends);
        - a database URL (``"sqlite:///study.db"``, ``"postgresql://user:pw@host/db"``,
          ``"mysql+pymysql://..."``): Optuna's ``RDBStorage`` with a heartbeat;
        - ``"journal:///abs/path/study.log"`` (or ``"journal://relative.log"``), or a
          path ending in ``.log`` / ``.journal``: Optuna's journal file;
        - a path ending in ``.db``, ``.sqlite`` or ``.sqlite3``: that SQLite file;
        - a ready Optuna storage object, used as it is.

    Returns
    -------
    optuna.storages.BaseStorage

    Examples
    --------
    >>> type(make_storage(None)).__name__
    'InMemoryStorage'
    >>> make_storage("study.csv")
    Traceback (most recent call last):
    ...
    ValueError: storage 'study.csv' is not understood; expected None, a database URL ('sqlite:///study.db', 'postgresql://...'), 'journal:///path/study.log', a path ending in .log/.journal (journal file) or .db/.sqlite/.sqlite3 (SQLite), or an optuna storage.
    """
    kind, target = _parse_checked(storage)
    if kind == "memory":
        return InMemoryStorage()
    if kind == "object":
        return target
    if kind == "journal":
        return _journal(target)
    return _rdb(target)


def _journal(path):
    try:
        return JournalStorage(_JournalFile(path))
    except (ValueError, KeyError, TypeError, AttributeError, IndexError) as exc:  # garbage in the log
        raise ValueError(
            f"storage {path!r}: the journal file cannot be read ({type(exc).__name__}: {exc}); expected a journal "
            "written by Optuna. Move it away or pass another file."
        ) from exc


class _JournalFile(JournalFileBackend):
    """Optuna's journal file, which a write cut short (a full disk, a killed worker) can no longer poison.

    Optuna appends each record as one line under the file's lock, and a reader
    stops at a last line without its newline. A write that fails half-way
    (``ENOSPC``, ``EFBIG``) is undone here: the file is cut back to its size
    before the write, under the lock, and the error says so. A torn last record
    left by a process that died while writing is mended under the lock before
    every write and when the file is opened (:func:`mend_journal_tail`): so a
    resumed study never appends to an unterminated line (which turned the next
    record and every later one into unreadable text).
    """

    def __init__(self, file_path):
        self._lock_file = JournalFileSymlinkLock(file_path)  # the lock Optuna's backend takes by default
        super().__init__(file_path, lock_obj=self._lock_file)
        self._where = file_path
        self._locked(mend_journal_tail, file_path)

    def _locked(self, func, *args):
        self._lock_file.acquire()
        try:
            return func(*args)
        finally:
            self._lock_file.release()

    def append_logs(self, logs):
        data = ("\n".join(json.dumps(log, separators=(",", ":")) for log in logs) + "\n").encode("utf-8")
        self._locked(self._append, data)

    def _append(self, data):
        mend_journal_tail(self._where)
        fd = os.open(self._where, os.O_WRONLY | os.O_APPEND)
        try:
            size = os.fstat(fd).st_size
            try:
                view = memoryview(data)
                while view:
                    view = view[os.write(fd, view):]
                os.fsync(fd)
            except OSError as exc:
                with contextlib.suppress(OSError):  # else the next open sets the torn record aside
                    os.ftruncate(fd, size)
                raise OSError(exc.errno, f"storage {self._where!r}: the journal file could not be written "
                              f"({exc.strerror}); the record was taken back and the finished trials are kept. "
                              "Free some space and call again to resume.") from exc
        finally:
            os.close(fd)


def mend_journal_tail(path):
    r"""Mend the end of an Optuna journal file whose last line has no newline (a write cut short).

    A last line that is a whole record (only its newline is missing) gets its
    newline and is kept. Anything else is a torn record: its bytes are appended
    to ``path + ".torn"`` (set aside, never overwritten) and cut from the
    journal, with a warning. Call it under the journal's lock.

    Returns
    -------
    str or None
        ``"completed"``, ``"set aside"``, or None when the file ended cleanly.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "study.log")
    >>> with open(path, "w") as f:
    ...     _ = f.write('{"op_code":0,"worker_id":"w"}\n{"op_code":4,"wor')
    >>> mend_journal_tail(path)
    'set aside'
    >>> open(path).read(), open(path + ".torn").read()
    ('{"op_code":0,"worker_id":"w"}\n', '{"op_code":4,"wor\n')
    """
    with open(path, "r+b") as f:
        end = f.seek(0, os.SEEK_END)
        if end == 0:
            return None
        f.seek(end - 1)
        if f.read(1) == b"\n":
            return None
        start, pos = 0, end
        while pos > 0:  # the last line starts after the last newline
            low = max(0, pos - 65536)
            f.seek(low)
            newline = f.read(pos - low).rfind(b"\n")
            if newline >= 0:
                start = low + newline + 1
                break
            pos = low
        f.seek(start)
        tail = f.read()
        if _is_record(tail):
            f.seek(end)
            f.write(b"\n")
            logger.warning("storage %r: the last journal record had lost its newline; completed", path)
            return "completed"
        try:
            with open(path + ".torn", "ab") as aside:
                aside.write(tail + b"\n")
        except OSError as exc:
            raise OSError(exc.errno, f"storage {path!r}: the journal file ends in a torn record ({len(tail)} bytes "
                          f"of an unfinished write) that could not be set aside in {path + '.torn'!r} "
                          f"({exc.strerror}); free some space and call again.") from exc
        f.truncate(start)
        logger.warning("storage %r: the journal ended in a torn record (%d bytes of an unfinished write); set aside "
                       "in %r, the finished trials are kept", path, len(tail), path + ".torn")
        return "set aside"


def _is_record(line):
    try:
        entry = json.loads(line)
    except ValueError:
        return False
    return isinstance(entry, dict) and "op_code" in entry


def worker_id():
    """``"host:pid"`` of this process, recorded on every trial it runs."""
    return f"{socket.gethostname()}:{os.getpid()}"


#: ``(study name, trial number)`` of the trials that this process is running (see :func:`tag_trial`).
_RUNNING_HERE = set()


def tag_trial(trial, running=None):
    """Record on ``trial`` the worker that runs it: ``worker`` (``host:pid``) and ``worker_token``.

    The token (drawn once per process) is written first, so a trial that names
    a worker names its token too: a worker restarted with the same host and
    PID (a container's PID 1) tells its predecessor's trials from its own. The
    trial is also noted as running in this process (and added to the set
    ``running``, which the caller discards from :data:`_RUNNING_HERE` when its
    trials ended), so that a trial of this process left RUNNING by a lost
    connection is reclaimed by the next call in the same process.
    """
    key = (trial.study.study_name, trial.number)
    _RUNNING_HERE.add(key)
    if running is not None:
        running.add(key)
    trial.set_user_attr("worker_token", owner()["token"])
    trial.set_user_attr("worker", worker_id())


@contextlib.contextmanager
def this_call_trials():
    """Yield the set to pass to :func:`tag_trial`; on exit its trials no longer run in this process."""
    running = set()
    try:
        yield running
    finally:
        _RUNNING_HERE.difference_update(running)


def _is_orphan(study, trial, me):
    owner_host, _, pid = trial.user_attrs.get("worker", "").rpartition(":")
    if not pid.isdigit():  # a worker tags its trial right after creating it, unless that write failed (full disk)
        start = trial.datetime_start
        return start is not None and (datetime.datetime.now() - start).total_seconds() > UNTAGGED_GRACE
    token = trial.user_attrs.get("worker_token")
    if (owner_host, int(pid), token) == (me["host"], me["pid"], me["token"]):
        return (study.study_name, trial.number) not in _RUNNING_HERE
    since = trial.datetime_start.timestamp() if trial.datetime_start is not None else None
    # Optuna records local wall-clock times without a zone: allow for a daylight-saving change
    return owner_is_gone(owner_host, int(pid), token, since, margin=_START_MARGIN)


def count_done(study):
    """Trials that count toward the budget ``n_trials``.

    Evaluated trials count: COMPLETE ones, and PRUNED ones (a failed fit or a
    diverged simulation, see :func:`~sindybench.model_selection.tune`). FAIL
    trials were interrupted before an evaluation finished (killed worker,
    KeyboardInterrupt, stale heartbeat) and do not count: their budget is
    spent again.
    """
    return len(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.PRUNED)))


def count_claimed(study, *, before=None):
    """Trials that hold a place in the budget: finished (see :func:`count_done`) or RUNNING.

    With ``before``, only trials numbered below it. Trial numbers are given in
    the order trials start, so a trial that finds ``n_trials`` places claimed
    below its own number is one too many: the workers sharing the study then
    end with exactly ``n_trials`` finished trials. A RUNNING trial of a dead
    worker holds its place until it is marked FAIL (:func:`fail_dead_workers`,
    or the heartbeat of a database storage).
    """
    states = (TrialState.COMPLETE, TrialState.PRUNED, TrialState.RUNNING)
    trials = study.get_trials(deepcopy=False, states=states)
    return len(trials) if before is None else sum(t.number < before for t in trials)


def fail_dead_workers(study):
    """Mark FAIL the RUNNING trials whose worker, on this machine, no longer exists.

    A worker killed with SIGKILL leaves its current trial RUNNING. On resume,
    a trial whose ``worker`` user attribute names this host and a process id
    that no longer runs is told FAIL (so TPE no longer treats it as pending).
    Trials of workers on other machines are left to the RDB heartbeat
    (:data:`GRACE_PERIOD` seconds of silence).

    Returns
    -------
    list of int
        Numbers of the trials marked FAIL.
    """
    failed, me = [], owner()
    for trial in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        if not _is_orphan(study, trial, me):
            continue
        try:
            study.tell(trial.number, state=TrialState.FAIL)
        except (ValueError, RuntimeError) as exc:  # another worker was faster
            logger.debug("trial %d of %s already finished: %s", trial.number, study.study_name, exc)
            continue
        logger.warning(
            "trial %d of study %r was left RUNNING by worker %s, which no longer runs: marked FAIL",
            trial.number,
            study.study_name,
            trial.user_attrs.get("worker", "(unnamed: its name could not be written)"),
        )
        failed.append(trial.number)
    return failed
