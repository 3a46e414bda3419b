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
        print("sindybench: interrupted; no output written.", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
