"""Where a study lives: in memory, an SQLite/RDB database, or an Optuna journal file.

Also the bookkeeping that makes a study resumable: which trials count toward
the budget, and which RUNNING trials were left behind by a dead worker.
"""

import logging
import os
import random
import socket
import time
import warnings

import optuna
from optuna.storages import BaseStorage, InMemoryStorage, JournalStorage, RDBStorage
from optuna.storages.journal import JournalFileBackend, JournalFileOpenLock
from optuna.trial import TrialState

__all__ = ["check_storage", "count_claimed", "describe_storage", "count_done", "fail_dead_workers", "make_storage", "worker_id"]

logger = logging.getLogger(__name__)

#: Seconds between heartbeats of a running trial in an RDB storage, and the
#: silence after which another worker marks the trial FAIL.
HEARTBEAT_INTERVAL = 60
GRACE_PERIOD = 180

_JOURNAL_PREFIX = "journal://"
_JOURNAL_SUFFIXES = (".log", ".journal")
_SQLITE_SUFFIXES = (".db", ".sqlite", ".sqlite3")


def _rdb(url):
    try:
        return _open_rdb(url)
    except ImportError as exc:  # SQLAlchemy imports the URL's driver when it makes the engine
        scheme = url.split("://", 1)[0]
        raise ImportError(
            f"storage {scheme}://...: the database driver is not installed ({exc.__cause__ or exc}). For PostgreSQL: "
            "pip install 'sindybench[postgres]' (psycopg 3, URL 'postgresql+psycopg://user@host/db'); "
            "for MySQL: pip install pymysql (URL 'mysql+pymysql://user@host/db')."
        ) from exc


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
        return kind, target
    folder = os.path.dirname(path)
    if folder and not os.path.isdir(folder):
        raise ValueError(
            f"storage {storage!r}: the folder {folder!r} does not exist; expected an existing folder for the "
            f"{noun} file."
        )
    return kind, target


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
        return JournalStorage(JournalFileBackend(target))
    return _rdb(target)


def worker_id():
    """``"host:pid"`` of this process, recorded on every trial it runs."""
    return f"{socket.gethostname()}:{os.getpid()}"


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


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
    host = socket.gethostname()
    failed = []
    for trial in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        owner = trial.user_attrs.get("worker", "")
        owner_host, _, pid = owner.rpartition(":")
        if owner_host != host or not pid.isdigit() or int(pid) == os.getpid() or _alive(int(pid)):
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
            owner,
        )
        failed.append(trial.number)
    return failed
