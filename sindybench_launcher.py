"""The ``sindybench`` console script: :func:`sindybench.cli.main` with Ctrl-C handled from the first instant.

Importing :mod:`sindybench` takes a few seconds (NumPy, SciPy, numba, Optuna;
more on a busy machine), and a Ctrl-C in that time ended in a
``KeyboardInterrupt`` traceback. This module lives outside the package so
that the console script can guard that import too: an interrupt at any time
prints one line and exits with status 130, as an interrupt later in a run
does. (``python -m sindybench.cli`` imports the package before any code of
the command runs, so only the console script has this guard.)

While the package imports, a Ctrl-C ends the process at once (exit status 130,
the one line) instead of raising ``KeyboardInterrupt`` inside the libraries'
imports: there, an interrupt could be swallowed (a library's ``except`` around
an optional import, a finalizer; the run then went on as if no Ctrl-C had
come) or turned into another error (NumPy's ``ImportError: PyCapsule_Import
could not import module "datetime"``, with a traceback). Nothing has been
written before the command runs, so nothing needs unwinding.
"""

import os
import signal
import sys

__all__ = ["main"]

_MESSAGE = "sindybench: interrupted; no output written."


def main(argv=None):
    """Run the ``sindybench`` command (see :func:`sindybench.cli.main`); 130 when interrupted."""
    try:
        restore = _exit_on_interrupt()
        try:
            from sindybench.cli import main as command
        finally:
            restore()
        return command(argv)
    except KeyboardInterrupt:
        return _interrupted()
    except Exception as exc:  # an interrupt inside a C extension's initialization arrives as a cause
        if not _caused_by_interrupt(exc):
            raise
        return _interrupted()


def _exit_on_interrupt():
    """Make a Ctrl-C end the process at once (:func:`_exit_now`) until the returned function restores the handler.

    Only over Python's own handler (a SIGINT ignored or handled by the caller stays so), in the main thread.
    """
    try:
        if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
            return lambda: None
        previous = signal.signal(signal.SIGINT, _exit_now)
    except ValueError:  # not the main thread: signals are not ours to handle
        return lambda: None
    return lambda: signal.signal(signal.SIGINT, previous)


def _exit_now(signum, frame):
    """The SIGINT handler while the package imports: the one line, then exit 130 without unwinding the imports."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):  # a closed or missing stream
            pass
    try:
        sys.stderr.write(_MESSAGE + "\n")
        sys.stderr.flush()
    except (OSError, ValueError, AttributeError):
        pass
    os._exit(130)


def _interrupted():
    print(_MESSAGE, file=sys.stderr)
    return 130


def _caused_by_interrupt(exc):
    """Whether a ``KeyboardInterrupt`` stands in ``exc``'s chain of causes (for example SciPy's ``ImportError:
    initialization failed`` of a module whose initialization was interrupted)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
