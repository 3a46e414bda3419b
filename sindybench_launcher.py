"""The ``sindybench`` console script: :func:`sindybench.cli.main` with Ctrl-C handled from the first instant.

Importing :mod:`sindybench` takes a few seconds (NumPy, SciPy, numba, Optuna;
more on a busy machine), and a Ctrl-C in that time ended in a
``KeyboardInterrupt`` traceback. This module lives outside the package so
that the console script can guard that import too: an interrupt at any time
prints one line and exits with status 130, as an interrupt later in a run
does. (``python -m sindybench.cli`` imports the package before any code of
the command runs, so only the console script has this guard.)
"""

import sys

__all__ = ["main"]


def main(argv=None):
    """Run the ``sindybench`` command (see :func:`sindybench.cli.main`); 130 when interrupted."""
    try:
        from sindybench.cli import main as command

        return command(argv)
    except KeyboardInterrupt:
        return _interrupted()
    except Exception as exc:  # an interrupt inside a C extension's initialization arrives as a cause
        if not _caused_by_interrupt(exc):
            raise
        return _interrupted()


def _interrupted():
    print("sindybench: interrupted; no output written.", file=sys.stderr)
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
