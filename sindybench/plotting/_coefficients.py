"""Coefficient tables and heatmaps of fitted models."""

import numpy as np

from .._validation import check_integer
from ._common import _as_models, _check_axes, _new_axes


# ------------------------------------------------------------- coefficients
def coefficient_table(models, *, learned_only=True):
    """The coefficients of several fitted models in one table.

    Parameters
    ----------
    models : estimator, list or dict
        Fitted :class:`~sindybench.SINDy` or :class:`~sindybench.HiddenStateSINDy`
        models; a dict gives the row labels.
    learned_only : bool, default=True
        Leave out the rows a hidden-state strategy fixes by physics (``y' = v``).

    Returns
    -------
    rows : list of str
        ``"<model>: <state>'"``, one per equation.
    terms : list of str
        The union of the models' terms, in order of first appearance.
    values : ndarray of shape (len(rows), len(terms))
        Zero where a model lacks the term or dropped it.

    Examples
    --------
    >>> from sindybench import SINDy
    >>> from sindybench.libraries import PolynomialLibrary
    >>> t = np.arange(0, 3, 0.01)
    >>> y = np.exp(-2 * t)[:, None]
    >>> model = SINDy(library=PolynomialLibrary(degree=1), dt=0.01).fit(None, y)
    >>> rows, terms, values = coefficient_table({"A": model})
    >>> rows, terms, np.round(values, 1)
    (["A: y0'"], ['1', 'y0'], array([[ 0., -2.]]))
    """
    entries = []
    for label, model in _as_models(models):
        rows = getattr(model, "_equation_rows", None)
        if rows is None:
            raise ValueError(f"model {label!r} ({type(model).__name__}) has no equations; expected a fitted "
                             "SINDy or HiddenStateSINDy.")
        for row in rows():
            if row.fixed is None and (row.learned or not learned_only):
                entries.append((f"{label}: {row.name}'", dict(zip(row.features, row.coef))))
    terms = list(dict.fromkeys(term for _, coefs in entries for term in coefs))
    values = np.array([[coefs.get(term, 0.0) for term in terms] for _, coefs in entries]).reshape(len(entries),
                                                                                                  len(terms))
    return [label for label, _ in entries], terms, values


def plot_coefficients(models, *, learned_only=True, annotate=True, precision=2, drop_zero_terms=True, ax=None):
    """Heatmap of the coefficients of several models (rows: equations, columns: terms).

    Colours follow the sign and, on a symmetric log scale, the magnitude;
    zero coefficients stay blank.

    Parameters
    ----------
    models : estimator, list or dict
        As in :func:`coefficient_table`.
    learned_only : bool, default=True
    annotate : bool, default=True
        Write each non-zero coefficient in its cell.
    precision : int, default=2
        Significant digits of the annotations.
    drop_zero_terms : bool, default=True
        Leave out the terms no model uses.
    ax : Axes, optional

    Returns
    -------
    Axes

    Examples
    --------
    >>> from sindybench import SINDy
    >>> from sindybench.libraries import PolynomialLibrary
    >>> t = np.arange(0, 3, 0.01)
    >>> y = np.column_stack([np.exp(-2 * t), 1 + np.exp(-t)])
    >>> model = SINDy(library=PolynomialLibrary(degree=1), dt=0.01).fit(None, y)
    >>> ax = plot_coefficients({"A": model})
    >>> [label.get_text() for label in ax.get_yticklabels()]
    ["A: y0'", "A: y1'"]
    """
    from matplotlib.colors import SymLogNorm

    rows, terms, values = coefficient_table(models, learned_only=learned_only)
    if not rows:
        raise ValueError("no equations to draw; expected at least one fitted model with learned rows.")
    precision = check_integer(precision, "precision")
    if drop_zero_terms:
        keep = np.any(values != 0, axis=0)
        terms, values = [t for t, k in zip(terms, keep) if k], values[:, keep]
    (ax,) = _check_axes(ax, 1) or _new_axes(1, figsize=(max(4.0, 0.75 * len(terms) + 2.5), 1.0 + 0.45 * len(rows)))
    nonzero = np.abs(values[values != 0])
    top = float(nonzero.max()) if nonzero.size else 1.0
    # a linear band around zero of at most four decades below the largest magnitude
    linthresh = min(max(float(nonzero.min()) if nonzero.size else 1.0, 1e-4 * top), top)
    norm = SymLogNorm(linthresh=linthresh, vmin=-top, vmax=top)
    image = ax.imshow(np.ma.masked_equal(values, 0.0), cmap="RdBu_r", norm=norm, aspect="auto")
    ax.set_xticks(range(len(terms)), terms, rotation=45, ha="right")
    ax.set_yticks(range(len(rows)), rows)
    if annotate:
        for (i, j), c in np.ndenumerate(values):
            if c != 0:  # white on the dark ends of the colour map
                ax.text(j, i, f"{c:.{precision}g}", ha="center", va="center", fontsize=7,
                        color="white" if abs(float(norm(c)) - 0.5) > 0.3 else "black")
    mid = float(np.sqrt(top * linthresh))  # halfway on the log part of the scale
    ticks = [-top, 0.0, top] if linthresh >= top else [-top, -mid, 0.0, mid, top]
    bar = ax.figure.colorbar(image, ax=ax, label="coefficient", ticks=ticks)
    bar.ax.set_yticklabels([f"{t:.2g}" for t in ticks])
    return ax
