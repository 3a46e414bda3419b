"""Progress bars of long searches: ``tqdm.auto`` in a notebook or a terminal, nothing in a log.

A bar is drawn only when it was asked for, ``SINDYBENCH_PROGRESS`` does not
turn bars off (``0``, ``false``, ``no`` or ``off``), and there is somewhere to
draw it: a Jupyter kernel (a notebook widget with ipywidgets, else text) or a
standard error that is a terminal. Piped or redirected into a file, a run
writes no carriage-return updates.
"""

import os
import sys

from ._validation import check_bool

__all__ = ["ENV_VAR", "progress_bar", "show_progress"]

ENV_VAR = "SINDYBENCH_PROGRESS"
_OFF = ("0", "false", "no", "off")


def _in_notebook():
    """True inside a Jupyter kernel (the test tqdm.auto makes)."""
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    try:
        shell = ipython.get_ipython()
    except Exception:  # an IPython stand-in without get_ipython
        return False
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


def show_progress(show=True, *, name="show_progress_bar"):
    """Whether a progress bar asked for with ``show`` is drawn (see the module text).

    Examples
    --------
    >>> show_progress(False)
    False
    >>> show_progress("yes")
    Traceback (most recent call last):
    ...
    ValueError: show_progress_bar must be True or False; got 'yes'.
    """
    check_bool(show, name)
    if not show or os.environ.get(ENV_VAR, "").strip().lower() in _OFF:
        return False
    if _in_notebook():
        return True
    isatty = getattr(sys.stderr, "isatty", None)
    return bool(isatty is not None and isatty())


def progress_bar(total, *, desc, show=True, leave=True):
    """A ``tqdm.auto`` bar of ``total`` steps, disabled unless :func:`show_progress` says so."""
    from tqdm.auto import tqdm

    # every step redraws (a search trial takes milliseconds at least): a bar of fast trials shows its count
    return tqdm(total=total, desc=desc, leave=leave, disable=not show_progress(show), dynamic_ncols=True,
                mininterval=0)
