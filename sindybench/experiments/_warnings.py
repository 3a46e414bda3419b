"""What a benchmark run warned, collected for its report instead of printed line by line.

:func:`collect_warnings` records, while one benchmark runs, the Python warnings
(``ConvergenceWarning`` of a small budget, a divergence) and the WARNING
records of the ``sindybench`` loggers (the data advice), each distinct message
once with its count. ``sindybench run`` writes them into ``results.json`` and
``report.md`` and logs each once at INFO, so ``-q`` keeps the terminal quiet.
"""

import contextlib
import logging
import re
import warnings

__all__ = ["collect_warnings", "warnings_markdown"]


class _Collector(logging.Handler):
    """Keeps WARNING records, hands lower ones to the handlers it stands in for."""

    def __init__(self, passthrough, said):
        super().__init__(level=logging.NOTSET)
        self.passthrough, self.said = passthrough, said

    def emit(self, record):
        if record.levelno >= logging.WARNING:
            _count(self.said, "log", record.levelname, record.getMessage())
        else:
            for handler in self.passthrough:
                if record.levelno >= handler.level:
                    handler.handle(record)


_NUMBER = re.compile(r"[-+]?\d+(\.\d*)?(e[-+]?\d+)?")


def _count(said, kind, category, message):
    """Count ``message`` in ``said``: messages that differ in their figures only are one entry (the first kept)."""
    shape = _NUMBER.sub("#", message)
    for entry in said:
        if (entry["kind"], entry["category"], _NUMBER.sub("#", entry["message"])) == (kind, category, shape):
            entry["count"] += 1
            return
    said.append({"kind": kind, "category": category, "message": message, "count": 1})


@contextlib.contextmanager
def collect_warnings(logger_name="sindybench"):
    """Collect the warnings and WARNING log records of a block: yields the list it fills.

    Each entry is ``{"kind": "warning" or "log", "category", "message", "count"}``,
    in the order of first appearance; messages that differ only in their
    figures (a refinement's costs) count as one, the first one's kept.

    Examples
    --------
    >>> import logging, warnings
    >>> with collect_warnings() as said:
    ...     for cost in (0.5, 0.25, 0.125):
    ...         warnings.warn(f"small budget (cost {cost})", RuntimeWarning)
    ...     logging.getLogger("sindybench.example").warning("data advice: an offset")
    >>> [(s["kind"], s["category"], s["message"], s["count"]) for s in said]
    [('warning', 'RuntimeWarning', 'small budget (cost 0.5)', 3), ('log', 'WARNING', 'data advice: an offset', 1)]
    """
    said = []
    root = logging.getLogger(logger_name)
    handlers, propagate = root.handlers[:], root.propagate
    root.handlers[:] = [_Collector(handlers, said)]
    root.propagate = False
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield said
    finally:
        root.handlers[:] = handlers
        root.propagate = propagate
    first = said[:]  # the log records came first in time only by chance: keep them, then the warnings in order
    said.clear()
    for w in caught:
        _count(said, "warning", w.category.__name__, str(w.message))
    said.extend(first)


def warnings_markdown(said, heading):
    """The "Warnings" section of a benchmark's Markdown (nothing when it warned nothing)."""
    if not said:
        return []
    out = ["", f"{heading} Warnings", "", "What the run warned (each message once, with how often; `sindybench run -q` "
           "prints none of them):", ""]
    for entry in said:
        times = f" ({entry['count']} times; the figures are the first one's)" if entry["count"] > 1 else ""
        out.append(f"- {entry['category']}: {entry['message']}{times}")
    return out
