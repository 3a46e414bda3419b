"""Nonlinear models on the linear base of ``identify``: its states plus sparse nonlinear terms (``"linear_ss+nl"``).

The linear base (:mod:`~sindybench.identify._linear`) holds as many states as
the data ask (orders 1 to 10), but only linear terms; the other nonlinear
families hold at most three states. This family joins the two: the linear
base's order and Hankel depth (``settings["linear"]``), its
:class:`~sindybench.hidden.LatentHiddenState` with the subspace start (the
``n - n_outputs`` latent states of the MOESP model, the start the linear base
is fitted from), and a library of the linear terms of every state and input
plus the monomials of degree 2 and 3 of the *outputs* (few terms: with ``p``
outputs, ``p (p + 1) / 2 + p (p + 1) (p + 2) / 6`` more per row, 2 for one
output), and, in a second structure, the hard terms the data advice proposes
(square roots of a positive output, the indicator of an output above its
saturation level alone and times each input, the sign of an output that
changes sign).

The start simulates: the latent rows are regressed on the subspace model's
exact state derivatives, which are linear in the states and inputs, so their
nonlinear coefficients start near zero, and the outputs' rows are the linear
base's regression plus small equation-error terms. The refinement by
simulation error (:class:`~sindybench.refine.OutputErrorRefinement`) then frees
every term of the latent rows (nonlinear ones included) and the outputs'
nonzero ones, fits them, prunes the terms that contribute less than
``_PRUNE`` of their state's derivative and refits: the sparse selection. The
choice between this family and the linear base is the search's: both are
scored on every validation block, and the parsimony rule returns the
nonlinear model only when it validates better than the linear base by more
than its standard error.
"""

import numpy as np
from sklearn.base import clone

from ..hidden import HiddenStateSINDy, LatentHiddenState
from ..libraries import FrictionLibrary, IndicatorLibrary, PolynomialLibrary, SqrtLibrary
from ..optimizers import STLS
from ..refine import OutputErrorRefinement
from ._linear import START, _parse

__all__ = ["LINEAR_NL_FAMILY", "make_linear_nl", "propose_linear_nl"]

LINEAR_NL_FAMILY = "linear_ss+nl"
#: the outputs' monomials up to this degree join the linear base's linear terms
_DEGREE = 3
#: the refinement: as the linear base's, then the terms below this share of their state's derivative pruned
_PRUNE = 0.02
_REFINEMENT = {"max_nfev": 30, "max_samples": 5000}


def output_library(n_outputs, degree=_DEGREE):
    """Linear terms of every column of ``Z = [states, inputs]`` and the monomials of the outputs up to ``degree``.

    The outputs are the first ``n_outputs`` columns of ``Z``.

    Examples
    --------
    >>> lib = output_library(1).fit(np.zeros((1, 3)))
    >>> lib.get_feature_names_out(["y0", "z0", "u0"]).tolist()
    ['1', 'y0', 'z0', 'u0', 'y0^2', 'y0^3']
    """
    return PolynomialLibrary(degree=1) + PolynomialLibrary(degree=degree, include_bias=False,
                                                           variables=list(range(n_outputs)))


def hard_library(settings, n_outputs, n_states, n_inputs):
    """The hard terms the advice proposes over ``Z = [outputs, latent states, inputs]`` (a list, maybe empty).

    Square roots of the positive outputs (clipped at 0), the indicator of an
    output above its saturation level (alone and times each input), and the
    sign of an output that changes sign (Coulomb friction, when the output is
    a velocity).

    Examples
    --------
    >>> s = {"positive": [], "indicator": [1.5], "friction": []}
    >>> [type(lib).__name__ for lib in hard_library(s, 1, 4, 1)]
    ['IndicatorLibrary']
    """
    libs = []
    if settings.get("positive"):
        libs.append(SqrtLibrary(variables=list(settings["positive"]), lower=0.0))
    for i, level in enumerate(settings.get("indicator") or ()):
        if level is not None and i < n_outputs:
            libs.append(IndicatorLibrary(variables=[i], lower=level,
                                         times=list(range(n_states, n_states + n_inputs)) or None))
    if settings.get("friction"):
        libs.append(FrictionLibrary(variables=list(settings["friction"])))
    return libs


def propose_linear_nl(settings, n_outputs, n_inputs, hold, delay):
    """The family's structures: the linear base's order with the outputs' polynomial, and with the proposed hard
    terms too (when the advice proposes any); none without an input or when the linear base has no latent state.

    Examples
    --------
    >>> s = {"linear": {"order": 4, "block_rows": 40, "n_outputs": 1}, "positive": [], "indicator": [None],
    ...      "friction": []}
    >>> [st["library"] for st, _ in propose_linear_nl(s, 1, 1, "zoh", 0)]
    ['poly3 n=4 rows=40']
    >>> [st["library"] for st, _ in propose_linear_nl(dict(s, indicator=[0.8]), 1, 1, "zoh", 0)]
    ['poly3 n=4 rows=40', 'poly3+hard n=4 rows=40']
    """
    base = settings.get("linear")
    if base is None or n_inputs == 0 or int(base["order"]) <= n_outputs:
        return []
    order, rows = int(base["order"]), int(base["block_rows"])
    lib = output_library(n_outputs)
    structure = {"family": LINEAR_NL_FAMILY, "library": f"poly{_DEGREE} n={order} rows={rows}",
                 "derivative": "finite_difference", "input_hold": hold, "input_delay": delay}
    out = [(structure, lib)]
    hard = hard_library(settings, n_outputs, order, n_inputs)
    if hard:
        for extra in hard:
            lib = lib + extra
        out.append((dict(structure, library=f"poly{_DEGREE}+hard n={order} rows={rows}"), lib))
    return out


def make_linear_nl(structure, library, dt, differentiation, settings, *, random_state=0):
    """The unfitted model of ``structure``: the linear base's latent states and start, the nonlinear library,
    refined by simulation error with pruning."""
    order, rows = _parse(structure["library"])
    n_outputs = int(settings["linear"]["n_outputs"])
    hidden = LatentHiddenState(n_latent=order - n_outputs, order=1, driver="input", start="subspace",
                               block_rows=rows)
    return HiddenStateSINDy(hidden=hidden, library=clone(library),
                            optimizer=STLS(threshold=0.0, alpha=1e-9, normalize_columns=True),
                            differentiation=differentiation, dt=dt, input_hold=structure["input_hold"],
                            input_delay=structure["input_delay"], random_state=random_state,
                            refine=OutputErrorRefinement(prune=_PRUNE, **_REFINEMENT), initial_state=START,
                            show_progress_bar=False)
