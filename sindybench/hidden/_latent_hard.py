"""Hard terms of latent states: hinges ``max(z - L, 0)`` whose level the fit decides.

A latent state's hinge (alone, and times an input) is a library term over
``Z = [y, z, u]`` with the ``HINGE`` operation (:mod:`sindybench.dynamics`),
its level ``L`` written in the term. A latent state is defined up to its scale
and its offset; the scale gauge of :class:`~sindybench.hidden.LatentHiddenState`
fixes the scale, and the *level gauge* fixes the offset: the level in the
library is held, the constant term of the latent row (the offset) is fitted
with every other coefficient by the simulation-error refinement (the hinge is
continuous, its exact sensitivity a step, so no smoothing is needed). With
only linear and hinge terms of ``z`` this is the same family of models as a
free level with the latent state's rest point held: ``z -> z + k`` moves the
level to ``L + k`` and the constant terms absorb the rest. :func:`latent_levels`
reads the fitted level in those coordinates (where ``z' = a z + c + ...`` has
no constant: the level is ``L + c / a``).
"""

import numpy as np

from ..dynamics import HINGE, POW
from ..libraries._base import canonical_term

__all__ = ["hinge_terms", "latent_levels"]


def hinge_terms(column, level, *, side="upper", times=()):
    """The hinge of column ``column`` at ``level``, alone and times each column of ``times``.

    Parameters
    ----------
    column : int
        The latent state's column of ``Z``.
    level : float
        The kink (held in the term; see the module's level gauge).
    side : {"upper", "lower"}, default="upper"
        ``max(z - level, 0)`` (upper) or ``max(level - z, 0)`` (lower).
    times : sequence of int
        Columns (inputs) that multiply the hinge, one term each.

    Returns
    -------
    list of term

    Examples
    --------
    >>> from sindybench.libraries import TermsLibrary
    >>> lib = TermsLibrary(terms=hinge_terms(1, 7.5, times=[2])).fit(np.zeros((1, 3)))
    >>> lib.get_feature_names_out(["y0", "z0", "u0"]).tolist()
    ['max(z0-7.5, 0)', 'max(z0-7.5, 0) u0']
    """
    if side not in ("upper", "lower"):
        raise ValueError(f"side must be 'upper' or 'lower'; got {side!r}.")
    level = float(level)
    if not np.isfinite(level):
        raise ValueError(f"level must be a finite number; got {level!r}.")
    hinge = (int(column), HINGE, level, 1.0 if side == "upper" else -1.0)
    return [(hinge,)] + [canonical_term((hinge, (int(t), POW, 1.0, 0.0))) for t in times]


def latent_levels(model):
    """The hinge levels of a fitted latent model's latent states: held in the library, and fitted.

    Parameters
    ----------
    model : HiddenStateSINDy
        Fitted with a :class:`~sindybench.hidden.LatentHiddenState`.

    Returns
    -------
    list of dict
        One per hinge factor of a latent state in a term with a nonzero
        coefficient: ``state`` (its name), ``side``, ``held`` (the level in
        the library) and ``level`` (the level where the latent state rests
        at 0, ``held + c / a`` with ``c`` and ``a`` the constant and the
        linear self term of its row; None when ``a`` is 0).
    """
    s = model.structure_
    names = s.state_names
    terms = [tuple(t) for t in (getattr(model.library_, "terms_", None) or ())]
    coef = np.asarray(model.coef_, dtype=float)
    n_states = s.n_states
    n_latent = sum(name.startswith("z") for name in names)
    first = n_states - n_latent
    seen, out = set(), []
    for t, term in enumerate(terms):
        if not np.any(coef[:, t] != 0):
            continue
        for col, op, a, b in term:
            if op != HINGE or not first <= col < n_states or (col, a, b) in seen:
                continue
            seen.add((col, a, b))
            row = list(s.learned).index(col)
            const = _coefficient(coef, terms, row, ())
            slope = _coefficient(coef, terms, row, ((col, POW, 1.0, 0.0),))
            level = float(a) + const / slope if slope != 0 else None
            out.append({"state": names[col], "side": "upper" if b >= 0 else "lower", "held": float(a),
                        "level": level})
    return out


def _coefficient(coef, terms, row, term):
    return float(coef[row, terms.index(term)]) if term in terms else 0.0


def level_lines(model):
    """The lines of ``gauge(model)`` about the hinge levels of the latent states (none without hinges)."""
    lines = []
    for entry in latent_levels(model):
        fitted = (f"{entry['level']!r} where {entry['state']} rests at 0 (its row without a constant)"
                  if entry["level"] is not None else f"not defined: {entry['state']}' has no linear self term")
        lines.append(f"{entry['state']}: its {entry['side']} hinge level is held at {entry['held']!r} in the "
                     f"library and its offset fitted (level gauge); the fitted level is {fitted}")
    return lines
