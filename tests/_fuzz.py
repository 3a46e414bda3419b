"""What the fuzz suites share: one signal spoiled in one of the ways a user's data can be wrong."""

import numpy as np

#: The ways :func:`spoil` knows; "huge" multiplies by ``huge`` (1e300 unless said).
KINDS = ("nan", "inf", "huge", "tiny", "complex", "strings", "3d", "1d", "none-value", "short", "empty", "scalar",
         "ragged", "constant", "offset")


def spoil(a, kind, *, index=0, huge=1e300):
    """``a`` (2-D) spoiled as ``kind`` says; ``index``: the flat position of a "nan" or "inf" sample."""
    if kind in ("nan", "inf"):
        if a.size:
            a = a.copy()
            a.flat[index % a.size] = np.nan if kind == "nan" else np.inf
        return a
    changes = {
        "huge": lambda: a * huge, "tiny": lambda: a * 1e-300, "complex": lambda: a + 1j,
        "strings": lambda: a.astype(str), "3d": lambda: a[:, :, None],
        "1d": lambda: a[:, 0] if a.shape[1] else a.reshape(-1), "none-value": lambda: None,
        "short": lambda: a[: max(0, a.shape[0] - 3)], "empty": lambda: a[:0], "scalar": lambda: 1.0,
        "ragged": lambda: [list(row) for row in np.asarray(a)][:3] + [[1.0] * 5],
        "constant": lambda: np.ones_like(a), "offset": lambda: a + 1e3,
    }
    return changes[kind]() if kind in changes else a


def nan_index(draw, a, kind, integers):
    """The flat position of the NaN or inf sample of ``spoil`` (drawn only for those kinds, from ``integers``)."""
    return draw(integers(0, a.size - 1)) if kind in ("nan", "inf") and a.size else 0
