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

**Warm start** (``LatentHiddenState(levels="range")``, :func:`fit_range_levels`):
the model without the hinges is fitted first (its own search and
refinement: the plain latent model), the hinges' levels are then placed at
quantiles of that model's simulated latent state (:func:`range_levels`: 80 %
for an upper hinge, 20 % for a lower one, where the hinge is active on a
fifth of the record and its coefficient has a nonzero sensitivity), and the
model is refined again from the plain one with the hinges' coefficients at
0. The refined model is kept only when its simulation error on the training
record is not larger than the plain model's, so the hinge model never starts
in, or ends at, a worse fit than the plain one.
"""

import logging

import numpy as np
from sklearn.base import clone

from ..dynamics import HINGE, LOGISTIC, POW, STEP
from ..libraries import ConcatLibrary, TermsLibrary
from ..libraries._base import canonical_term

__all__ = ["fit_range_levels", "hinge_terms", "indicator_terms", "latent_levels", "range_levels"]

logger = logging.getLogger(__name__)

#: the quantiles of the simulated latent state that place an upper and a lower hinge (``levels="range"``)
RANGE_QUANTILES = (0.8, 0.2)


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
    return _alone_and_times((int(column), HINGE, _level(level), 1.0 if side == "upper" else -1.0), times)


def latent_levels(model):
    """The hinge levels of a fitted latent model's latent states: held in the library, and fitted.

    Parameters
    ----------
    model : HiddenStateSINDy
        Fitted with a :class:`~sindybench.hidden.LatentHiddenState`.

    Returns
    -------
    list of dict
        One per hinge or indicator ``[z>=a]`` factor of a latent state in a
        term with a nonzero coefficient: ``state`` (its name), ``kind``
        (``"hinge"`` or ``"indicator"``), ``side``, ``held`` (the level in
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
            if not _is_level((col, op, a, b)) or not first <= col < n_states or (col, op, a, b) in seen:
                continue
            seen.add((col, op, a, b))
            row = list(s.learned).index(col)
            const = _coefficient(coef, terms, row, ())
            slope = _coefficient(coef, terms, row, ((col, POW, 1.0, 0.0),))
            level = float(a) + const / slope if slope != 0 else None
            out.append({"state": names[col], "kind": "hinge" if op == HINGE else "indicator",
                        "side": "upper" if b >= 0 else "lower", "held": float(a), "level": level})
    return out


def _coefficient(coef, terms, row, term):
    return float(coef[row, terms.index(term)]) if term in terms else 0.0


def level_lines(model):
    """The lines of ``gauge(model)`` about the hinge levels of the latent states (none without hinges)."""
    lines = []
    for entry in latent_levels(model):
        fitted = (f"{entry['level']!r} where {entry['state']} rests at 0 (its row without a constant)"
                  if entry["level"] is not None else f"not defined: {entry['state']}' has no linear self term")
        lines.append(f"{entry['state']}: its {entry['side']} {entry['kind']} level is held at {entry['held']!r} in the "
                     f"library and its offset fitted (level gauge); the fitted level is {fitted}")
    return lines


def range_levels(z, quantiles=RANGE_QUANTILES):
    """The upper and lower levels of hinges of a latent state from its simulated trajectory ``z``: its quantiles.

    Parameters
    ----------
    z : array-like of shape (n_samples,)
        The latent state's simulation (non-finite samples are ignored).
    quantiles : (float, float), default=(0.8, 0.2)
        The quantiles of the upper and of the lower level, in ``[0, 1]``.

    Returns
    -------
    (float, float)

    Examples
    --------
    >>> range_levels(np.arange(101.0))
    (80.0, 20.0)
    """
    z = np.asarray(z, dtype=float).reshape(-1)
    z = z[np.isfinite(z)]
    q = np.asarray(quantiles, dtype=float)
    if q.shape != (2,) or not np.all((q >= 0) & (q <= 1)):
        raise ValueError(f"quantiles must be two numbers in [0, 1]; got {quantiles!r}.")
    if z.size == 0:
        raise ValueError("z has no finite sample: no range to place a level in.")
    return float(np.quantile(z, q[0])), float(np.quantile(z, q[1]))


def indicator_terms(column, level, *, times=()):
    """The indicator ``[z >= level]`` of column ``column``, alone and times each column of ``times``.

    With ``LatentHiddenState(levels="range")`` the level is a placeholder: the
    warm start places it in the latent state's simulated range and refines
    it smoothed (:func:`fit_range_levels`); the final model holds the exact
    indicator.

    Examples
    --------
    >>> from sindybench.libraries import TermsLibrary
    >>> lib = TermsLibrary(terms=indicator_terms(1, 9.5, times=[2])).fit(np.zeros((1, 3)))
    >>> lib.get_feature_names_out(["y0", "z0", "u0"]).tolist()
    ['[z0>=9.5]', '[z0>=9.5] u0']
    """
    return _alone_and_times((int(column), STEP, _level(level), np.inf), times)


def _level(level):
    level = float(level)
    if not np.isfinite(level):
        raise ValueError(f"level must be a finite number; got {level!r}.")
    return level


def _alone_and_times(factor, times):
    """The terms ``factor`` and ``factor * u`` for each column ``u`` of ``times``."""
    return [(factor,)] + [canonical_term((factor, (int(t), POW, 1.0, 0.0))) for t in times]


def _is_level(factor):
    """A factor whose level the warm start places: a hinge, or an indicator ``[z>=a]`` (exact or smoothed)."""
    return factor[1] == HINGE or factor[1] == LOGISTIC or (factor[1] == STEP and np.isinf(factor[3]))


def _split_hinges(library):
    """``(base, level terms)`` of a library whose last part is a ``TermsLibrary`` of hinge or indicator terms, else None."""
    parts = list(getattr(library, "libraries", None) or ()) if isinstance(library, ConcatLibrary) else []
    if len(parts) < 2 or not isinstance(parts[-1], TermsLibrary) or not parts[-1].terms:
        return None
    terms = [tuple(tuple(f) for f in t) for t in parts[-1].terms]
    if not all(any(_is_level(f) for f in t) for t in terms):
        return None
    return (parts[0] if len(parts) == 2 else ConcatLibrary(parts[:-1])), terms


def _stage_terms(terms, states, latent, width):
    """The level ``terms`` with their latent levels placed, indicators smoothed to ``width`` (None: exact).

    A hinge's level is :func:`range_levels` of its column of ``states``
    (upper or lower by its side), an indicator's the upper one; ``width`` is
    a fraction of the column's 5-95 % spread (the logistic's width).
    """
    levels = {col: range_levels(states[:, col]) for col in latent}
    spread = {col: float(np.subtract(*np.nanquantile(states[:, col], [0.95, 0.05]))) for col in latent}

    def place(c, op, a, b):
        if c not in levels or not _is_level((c, op, a, b)):
            return (c, op, a, b)
        if op == HINGE:
            return (c, op, levels[c][0 if b >= 0 else 1], b)
        level = float(f"{levels[c][0]:.6g}")  # six digits: the indicator's text writes its level exactly
        if width is None:
            return (c, STEP, level, np.inf)
        return (c, LOGISTIC, level, 1.0 / (width * (spread[c] if spread[c] > 0 else 1.0)))  # its slope

    return [canonical_term(tuple(place(*f) for f in term)) for term in terms]


#: the widths of the smoothed indicators, narrowed over the refinements (fractions of the latent state's spread;
#: None: the exact indicator, the last refinement)
WIDTHS = (0.1, 0.03, 0.01, None)


def fit_range_levels(estimator, X, y, dt):
    """``LatentHiddenState(levels="range")``: the plain latent model first, then its hard terms from 0 (see the module).

    ``estimator`` is a :class:`~sindybench.HiddenStateSINDy` whose library's
    last part is a :class:`~sindybench.libraries.TermsLibrary` of hinge
    terms (:func:`hinge_terms`) or indicator terms (:func:`indicator_terms`)
    of the latent states; ``X`` and ``y`` one record. A clone without that
    part is fitted (its search and refinement), then those terms, their
    levels in the clone's simulated latent range and their coefficients at
    0, are refined beside the rest: once for hinges; for indicators, as
    logistics of the widths :data:`WIDTHS` (narrowed, each refinement
    starting from the last) and finally exact. ``estimator`` takes the
    refined model when its refinement cost is not larger than the plain
    model's, else the plain model; ``refinement_["range_levels"]`` records
    the levels, the costs and which was kept. Returns ``estimator``.
    """
    from ._auto import auto_refinement
    from ._base import Design
    from ._candidate import Candidate, structure_dynamics
    from ._derivative import Derivative

    hidden = estimator.hidden
    split = _split_hinges(estimator.library)
    if split is None:
        raise ValueError("levels='range' needs a library whose last part is a TermsLibrary of hinge or indicator "
                         "terms (base + TermsLibrary(terms=hinge_terms(...))); got "
                         f"{estimator.library!r}.")
    base, terms = split
    plain = clone(estimator).set_params(library=base, hidden=clone(hidden).set_params(levels="library"))
    plain.fit(X, y, dt=dt)
    s = plain.structure_
    n_meas = len(s.output_index) * int(hidden.order)
    latent = range(n_meas, n_meas + int(hidden.n_latent))
    Xd = plain.delayed_inputs(np.asarray(X, dtype=float).reshape(len(y), -1))
    y2 = np.asarray(y, dtype=float).reshape(len(y), -1)
    smoothed = any(f[1] == STEP for t in terms for f in t)
    widths = WIDTHS if smoothed else (None,)

    def library_of(width):
        lib = clone(estimator.library)
        lib.set_params(libraries=list(lib.libraries[:-1]) +
                       [TermsLibrary(terms=_stage_terms(terms, plain.states_, latent, width))])
        return lib.fit(np.c_[plain.states_[:2], Xd[:2]])

    library = library_of(None)
    n_base = len(plain.library_.terms_)
    placed = {(int(f[0]), int(f[1]), float(f[2]), float(f[3])) for t in library.libraries_[-1].terms_ for f in t
              if _is_level(f)}
    record = {"levels": [[c, "hinge" if op == HINGE else "indicator", a, b if np.isfinite(b) else None]
                         for c, op, a, b in sorted(placed, key=lambda h: (h[0], h[1], -h[2]))],
              "widths": [w for w in widths if w is not None], "plain_cost": None, "cost": None, "costs": [],
              "kept": False}
    estimator.__dict__.update({k: v for k, v in vars(plain).items() if k.endswith("_") or k.startswith("_")})
    estimator.hidden_ = clone(hidden)
    if [tuple(t) for t in library.terms_[:n_base]] != [tuple(t) for t in plain.library_.terms_]:
        logger.warning("levels='range': the hard terms change the base's terms; the plain model is kept")
        return _with_record(estimator, record)
    if plain.refinement_ is None or plain.refinement_.get("status", -1) < 0:
        return _with_record(estimator, record)
    coef = np.zeros((len(library.terms_), len(s.learned)))
    coef[:n_base] = plain.coef_.T
    simulation = plain._simulation(plain.dt_)
    n = len(y2) if plain.refit else len(y2) - plain._n_validation(len(y2))
    cand = Candidate(params=dict(plain.params_), structure=s, library=None, optimizer=plain.optimizer_,
                     differentiation=plain.differentiation_, coef=coef,
                     derivative=Derivative(plain.differentiation_, plain.dt_),
                     designs=(Design(states=plain.states_, targets=np.empty((len(y2), 0))),), dynamics=None)
    for width in widths:
        lib = library_of(width)
        if len(lib.terms_) != len(library.terms_):
            return _with_record(estimator, record)  # a smoothed term merged with another: nothing to refine
        cand = cand._replace(library=lib, dynamics=structure_dynamics(cand.structure, lib, cand.coef, simulation))
        refine = auto_refinement(plain.refine, cand.dynamics)
        if refine is None:
            return _with_record(estimator, record)
        try:
            new, x0s, summary = plain._refine(plain.hidden_, cand, [Xd[:n]], [y2[:n]], refine=refine)
        except ValueError as exc:
            logger.warning("levels='range': the refinement with the hard terms failed (%s); the plain model is kept",
                           exc)
            return _with_record(estimator, record)
        if x0s is None or summary.get("status", -1) < 0:
            return _with_record(estimator, record)
        if record["plain_cost"] is None:
            record["plain_cost"] = float(summary["initial_cost"])
        record["costs"].append(float(summary["cost"]))
        design = Design(states=new.dynamics.simulate(Xd, np.asarray(x0s[0], dtype=float), on_divergence="nan"),
                        targets=np.empty((len(y2), 0)))
        cand = new._replace(designs=(design,))
    record["cost"] = record["costs"][-1]
    if not record["cost"] <= record["plain_cost"]:
        return _with_record(estimator, record)
    record["kept"] = True
    estimator.library_, estimator.coef_ = cand.library, cand.coef.T.copy()
    estimator.params_, estimator.structure_ = dict(cand.params), cand.structure
    estimator.states_ = cand.design.states
    estimator.x0_ = np.asarray(cand.design.states[0], dtype=float)
    estimator.refinement_ = summary
    estimator._rebuild_model()
    return _with_record(estimator, record)


def _with_record(estimator, record):
    if estimator.refinement_ is not None:  # no refinement ran: nothing was tried, nothing to record
        estimator.refinement_ = {**estimator.refinement_, "range_levels": record}
    return estimator
