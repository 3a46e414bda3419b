"""The latent family's hard terms: hinges of the latent state, at levels the fit decides.

The order-1 latent family (one output, driven by the first input) gets one
extra candidate, ``library="linear+latent_hinge"``: the plain candidate's
terms (linear, or the family's proposed hard terms) plus the hinges of the
latent state ``z`` at an upper and a lower level, each alone and times the
inputs (:func:`~sindybench.hidden._latent_hard.hinge_terms`), and where the
output's advice proposes an indicator (a pile-up at a level: an overflow),
the indicator ``[z >= L]`` of the latent state at the upper level, alone and
times the inputs (smoothed by logistics narrowed over the refinements, exact
in the model). It is warm
started from the plain candidate (``LatentHiddenState(levels="range")``,
:func:`~sindybench.hidden._latent_hard.fit_range_levels`): the plain model is
fitted as the plain candidate is (same gauge, search and refinement), the
hinges' levels are placed at the 80 % and 20 % quantiles of its simulated
latent state, and the model is refined again from the plain one with the
hinges' coefficients at 0, kept only when the training simulation error
does not grow. The levels the library writes (the 80 % and 20 % quantiles of
``u0``) are placeholders that the warm start replaces; the refinement then
moves the levels (the level gauge: the level is held in the term, the latent
offset fitted), and the validation blocks decide whether the candidate is
kept. One candidate per derivative and hold: the cost is one refinement more
than the plain candidate's fit (which it repeats).
"""

import numpy as np

from ..dynamics import HINGE
from ..hidden._latent_hard import hinge_terms, indicator_terms
from ..libraries import PolynomialLibrary, TermsLibrary
from ..search import Uniform

__all__ = ["LATENT_HINGE", "latent_hinge_library", "offset_range"]

#: the library name of the latent family's hinge candidate
LATENT_HINGE = "linear+latent_hinge"
#: the quantiles of the first input that place the upper and the lower hinge
_QUANTILES = (0.8, 0.2)


def latent_hinge_library(X, n_outputs=1, *, base=None, lower=True, indicator=False):
    """Linear terms (or ``base``) plus hinges of the latent state (column ``n_outputs`` of ``Z = [y, z, u]``), or None.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_inputs)
        The estimation record's inputs.
    n_outputs : int, default=1
    base : library, optional
        The terms beside the hinges (default: linear).
    lower : bool, default=True
        Also the lower hinge (not for a latent state held non-negative: its
        bound is its lower level).
    indicator : bool, default=False
        Also the indicator ``[z >= L]`` at the upper level, alone and times
        the inputs (an overflow of the hidden state: proposed where the
        output's advice proposes an indicator); smoothed in the fit, exact in
        the model (:func:`~sindybench.hidden._latent_hard.fit_range_levels`).

    Returns
    -------
    ConcatLibrary or None
        None without inputs or when the first input is constant (no level to name).

    Examples
    --------
    >>> u = np.linspace(0.0, 10.0, 101)[:, None]
    >>> lib = latent_hinge_library(u).fit(np.zeros((1, 3)))
    >>> lib.get_feature_names_out(["y0", "z0", "u0"]).tolist()[4:]
    ['max(z0-8.0, 0)', 'max(z0-8.0, 0) u0', 'max(2.0-z0, 0)', 'max(2.0-z0, 0) u0']
    >>> latent_hinge_library(u, lower=False, indicator=True).fit(np.zeros((1, 3))).get_feature_names_out(
    ...     ["y0", "z0", "u0"]).tolist()[4:]
    ['max(z0-8.0, 0)', 'max(z0-8.0, 0) u0', '[z0>=8]', '[z0>=8] u0']
    """
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] == 0:
        return None
    u0 = X[:, 0][np.isfinite(X[:, 0])]
    if u0.size < 2:
        return None
    high, low = (float(np.quantile(u0, q)) for q in _QUANTILES)
    if not high > low:
        return None
    z, inputs = n_outputs, list(range(n_outputs + 1, n_outputs + 1 + X.shape[1]))
    terms = hinge_terms(z, high, side="upper", times=inputs)
    if lower:
        terms += hinge_terms(z, low, side="lower", times=inputs)
    if indicator:
        terms += indicator_terms(z, high, times=inputs)
    return (PolynomialLibrary(degree=1) if base is None else base) + TermsLibrary(terms=terms)


def offset_range(library):
    """The search range of the start's offset (``LatentHiddenState(offset=None)``) for a hinge ``library``.

    (For a start in ``u0``'s units with the library's levels: identify's
    cascade candidate; its hinge candidate places its levels by the warm start.)

    Half the gap between the upper and the lower level either way: the
    search slides the start's latent state against both levels (it is the
    levels' search; the refinement then moves them further).

    Examples
    --------
    >>> offset_range(latent_hinge_library(np.linspace(0.0, 10.0, 101)[:, None]))
    Uniform(low=-3.0, high=3.0)
    """
    levels = sorted({f[2] for term in library.libraries[-1].terms for f in term if f[1] == HINGE})
    half = 0.5 * (levels[-1] - levels[0]) if len(levels) > 1 else max(abs(levels[0]), 1.0)
    return Uniform(-half, half)
