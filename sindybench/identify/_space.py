"""The candidate structures of ``identify``: model families, graded libraries, settings the data decides.

A *structure* is a plain dict of named settings (``family``, ``library``,
``derivative``, ``input_hold``, ``input_delay``); :func:`make_estimator` turns
a structure and a threshold into an ordinary, unfitted
:class:`~sindybench.SINDy` or :class:`~sindybench.HiddenStateSINDy`.
Everything here reads the estimation record only (never a benchmark's
physics): the data advice (:func:`~sindybench.identify.advice`: input delay,
input hold, the hard terms that features of the signals propose), and the
derivative's bandwidth from the output's spectrum.
"""

import logging

import numpy as np
from sklearn.base import clone

from .._sindy import SINDy
from ..differentiation import FiniteDifference, SavitzkyGolay, Spectral, bandwidth, savgol_window
from ..hidden import DerivativeHiddenState, HiddenStateSINDy, LatentHiddenState
from ..libraries import AbsProductLibrary, FrictionLibrary, IndicatorLibrary, PolynomialLibrary, SqrtLibrary
from ..optimizers import STLS
from ..refine import OutputErrorRefinement
from ..search import LogUniform
from ._advice import advice, detect_input_hold
from ._lag import LAG_FAMILY, make_lag
from ._latent_hard import LATENT_HINGE, latent_hinge_library, offset_range
from ._linear import LINEAR_FAMILY, linear_order, make_linear, propose_linear
from ._linear_nl import LINEAR_NL_FAMILY, make_linear_nl, propose_linear_nl

__all__ = ["FAMILIES", "LIBRARIES", "data_settings", "make_estimator", "n_terms", "structures"]

logger = logging.getLogger(__name__)

#: the families of one module each: ``name -> (propose, make)``. ``propose(settings, n_outputs, n_inputs, hold,
#: delay)`` gives the family's ``(structure, library)`` pairs from the data's settings (see
#: :func:`data_settings`); ``make(structure, library, dt, differentiation, settings, random_state=)`` its unfitted
#: estimator, which runs its own search and refinement inside ``fit`` (scored on every block at once, never screened
#: on a pruning path). Adding a family: its module and one entry here (and its settings in ``data_settings``).
FAMILY_TABLE = {LINEAR_FAMILY: (propose_linear, make_linear), LINEAR_NL_FAMILY: (propose_linear_nl, make_linear_nl)}
#: model families, in the order they are tried: plain first-order SINDy, derivative coordinates of order 2 and 3,
#: one latent state (one output only) at order 1 (driven by the input) and 2 (driven by the velocity), and the
#: linear base (a linear state-space model whose order the data decide), and the discrete-time lag model on delay
#: coordinates (returned only when it validates better than the equations' pick by more than its standard error)
FAMILIES = ("first_order", "order2", "order3", "order1+latent", "order2+latent", LINEAR_FAMILY, LAG_FAMILY)
#: every family a search may name: the default ones, two latent states (a chain of two lags of the input, at
#: order 1; off the default list for its cost), and the linear base's
#: states plus the outputs' polynomial and the proposed hard terms (:mod:`~sindybench.identify._linear_nl`; off the
#: default list for its cost and its many-state starts)
ALL_FAMILIES = FAMILIES + ("order1+latent2", LINEAR_NL_FAMILY)
#: the families with their own search and refinement inside ``fit`` (not screened on a pruning path)
LATENT_FAMILIES = ("order1+latent", "order2+latent", "order1+latent2", LAG_FAMILY) + tuple(FAMILY_TABLE)
_ORDER = {"first_order": 1, "order2": 2, "order3": 3, "order1+latent": 1, "order2+latent": 2, "order1+latent2": 1,
          "lag": 1}
#: the order-2 latent family's library: linear, plus the absolute products of the velocity and the latent state
LATENT_LIBRARY = "linear+abs"
# the latent family's own search (the lag's time constant, in samples) and refinement
_LATENT_TRIALS, _LATENT_TRIALS_1, _LATENT_TAU = 12, 20, (1.0, 1000.0)
_LATENT_REFINEMENT = {"max_nfev": 30, "max_samples": 5000}
#: how the latent families search their start: an even grid of time constants (log-spaced, the same at every seed),
#: the two best starts refined side by side on the training part and the best after refinement kept
_LATENT_SEARCH = {"sampler": "grid", "n_refined": 2}
#: the latent families' kinds of start: "lag" (the driver's lag only) or "auto" (with the output lag and the
#: subspace model in the same refined pool; measured in docs/latent.rst)
_LATENT_START = "lag"
_MAX_ABS = 1e6  # the estimators' default divergence bound
#: the order-1 latent family's cascade candidate: the hinge candidate's library with the latent row free of the
#: output's terms (``LatentHiddenState(cascade=True)``: z' = f(z, u), y' = g(y, z, u)), so that the hard terms
#: reach the latent row on the latent state only; proposed for a positive output (a stored quantity)
LATENT_CASCADE = "cascade+hard"
#: graded libraries, from the poorest; ``"+hard"`` adds the terms the data proposes to the library before it
LIBRARIES = ("linear", "poly2", "poly3", "linear+hard", "poly2+hard")
_DEGREE = {"linear": 1, "poly2": 2, "poly3": 3}


def data_settings(X, y, dt, families=FAMILIES):
    """What the estimation record decides before any fit: advice, bandwidth, derivative methods, proposed terms.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_inputs)
    y : ndarray of shape (n_samples, n_outputs)
    dt : float

    Returns
    -------
    dict
        ``advice`` (the :class:`~sindybench.identify.DataAdvice`, logged),
        ``input_delay`` and ``input_hold`` (the advice's; several inputs: the
        hold of the first), ``bandwidth`` (Hz for seconds: 99.99 % of the
        detrended outputs' power below it), ``derivatives`` (name -> method
        parameters), ``proposed`` (the advice's proposed terms, as text),
        ``positive`` (outputs with a proposed square root), ``saturation``
        (per output, the upper level where it saturates, or None) and
        ``indicator`` (per output, the lower end of the proposed indicator of
        that level, or None), ``friction`` (outputs with a proposed Coulomb
        friction term), ``max_abs`` (the candidates' divergence bound: the
        estimators' 1e6, or 1000 times the record's largest magnitude) and
        ``linear``: the linear base's order and Hankel depth
        (:func:`~sindybench.identify._linear.linear_order`; None when
        ``families`` has neither ``"linear_ss"`` nor ``"linear_ss+nl"``, or no model fits).

    Examples
    --------
    >>> t = np.arange(2000) * 0.01
    >>> s = data_settings(np.sin(t)[:, None], np.cos(t)[:, None] + 2.0, 0.01)
    >>> s["input_hold"], s["input_delay"], s["positive"], s["saturation"]
    ('linear', 0, [0], [None])
    """
    report = _advice(X, y, dt)
    max_abs = max(_MAX_ABS, 1e3 * float(max(np.max(np.abs(X), initial=0.0), np.max(np.abs(y)))))
    linear = linear_order(X, y) if {LINEAR_FAMILY, LINEAR_NL_FAMILY} & set(families) else None
    f_c = bandwidth(y, dt)
    window = savgol_window(f_c, dt)
    derivatives = {"finite_difference": {}, f"savgol_{window}": {"window_length": window},
                   f"spectral_{f_c:.3g}": {"cutoff": f_c}}
    if report is None:  # too short for the advice: no delay, the input's shape for the hold, no proposed terms
        hold = detect_input_hold(X)[0] if X.shape[1] else "zoh"
        return {"advice": None, "linear": linear, "input_delay": 0, "input_hold": hold, "bandwidth": f_c,
                "derivatives": derivatives,
                "proposed": [], "positive": [], "saturation": [None] * y.shape[1], "indicator": [None] * y.shape[1],
                "friction": [], "max_abs": max_abs}
    terms = report.proposed_terms
    saturation, indicator = [None] * y.shape[1], [None] * y.shape[1]
    for j, side, level, _ in report.saturation:
        if side == "upper":
            saturation[j] = float(level)
    for p in terms:
        if p.kind == "indicator" and np.isinf(p.high):
            indicator[p.output] = float(p.low)
    return {"advice": report, "linear": linear, "input_delay": int(report.input_delay),
            "input_hold": report.input_hold,
            "bandwidth": f_c, "derivatives": derivatives, "proposed": [str(p) for p in terms],
            "positive": [p.output for p in terms if p.kind == "sqrt"], "saturation": saturation, "indicator": indicator,
            "friction": [p.output for p in terms if p.kind == "friction"], "max_abs": max_abs}


def _advice(X, y, dt):
    """The data advice with the longest delay search (up to 20 samples) the record allows; None if it allows none."""
    for max_delay in (20, 10, 5, 2, 0):
        try:
            return advice(X, y, dt=dt, max_delay=max_delay, within_identify=True)
        except ValueError as exc:
            if "too few" not in str(exc):
                raise
            reason = exc
    logger.warning("identify: no data advice (%s): no input delay, the input's shape decides the hold", reason)
    return None


def _differentiation(name, params):
    if name.startswith("savgol"):
        return SavitzkyGolay(window_length=params["window_length"], polyorder=3)
    if name.startswith("spectral"):
        return Spectral(cutoff=params["cutoff"], taper=0.5)
    return FiniteDifference()


def _hard_terms(family, settings, n_outputs, n_inputs):
    """The proposed hard-term libraries of a family over ``Z = [states, inputs]`` (a list, maybe empty)."""
    order = _ORDER[family]
    libs = []
    if order >= 2 and settings["friction"]:  # a velocity that changes sign: Coulomb friction of that velocity
        libs.append(FrictionLibrary(variables=[n_outputs + j for j in settings["friction"]]))
    if settings["positive"]:
        libs.append(SqrtLibrary(variables=list(settings["positive"]), lower=0.0))
    n_states = order * n_outputs
    for i, level in enumerate(settings["indicator"]):
        if level is not None:
            libs.append(IndicatorLibrary(variables=[i], lower=level,
                                         times=list(range(n_states, n_states + n_inputs)) or None))
    return libs


def _latent_hard_terms(settings, n_inputs):
    """Linear terms plus the proposed hard terms over ``Z = [y, z, u]`` of the order-1 latent family (or None)."""
    libs = []
    if settings["positive"]:  # a positive output proposes roots of it and of the latent state (held >= 0)
        libs.append(SqrtLibrary(variables=[0, 1], lower=0.0))
    if settings["indicator"][0] is not None:
        libs.append(IndicatorLibrary(variables=[0], lower=settings["indicator"][0], times=list(range(2, 2 + n_inputs))))
    if not libs:
        return None
    lib = PolynomialLibrary(degree=1)
    for extra in libs:
        lib = lib + extra
    return lib


def _latent_hinges(X, settings, n_inputs, libraries, *, indicator=True):
    """The order-1 latent family's hinge library (when a ``+hard`` library is searched), or None.

    With ``indicator``, also the latent indicator where the output's advice proposes one (the
    warm-started hinge candidate; the cascade's hinges start at the library's levels instead).
    """
    if not any(name.endswith("+hard") for name in libraries):
        return None
    positive = bool(settings["positive"])  # the latent state held >= 0: its bound is its lower level
    return latent_hinge_library(X, 1, base=_latent_hard_terms(settings, n_inputs), lower=not positive,
                                indicator=indicator and settings["indicator"][0] is not None)  # a hidden overflow


def _latent_cascade(X, settings, n_inputs, libraries):
    """The order-1 latent family's cascade candidate's library: the hinges, for a stored quantity only; or None.

    Proposed where the output stays positive (the advice's power-law flow: a level, a temperature, a
    concentration), the storage of which a hidden cascade of storages (tanks in series, thermal lags) is
    made; a signed output (a displacement, a voltage) keeps the hinge candidate alone, and the cascade's
    cost (one latent search and refinement per input hold) is not spent on it.
    """
    return _latent_hinges(X, settings, n_inputs, libraries, indicator=False) if settings["positive"] else None


def _library(name, family, settings, n_outputs, n_inputs):
    base = name.split("+")[0]
    lib = PolynomialLibrary(degree=_DEGREE[base])
    if name.endswith("+hard"):
        hard = _hard_terms(family, settings, n_outputs, n_inputs)
        if not hard:
            return None
        for extra in hard:
            lib = lib + extra
    return lib


def structures(X, y, dt, settings, *, families=FAMILIES, libraries=LIBRARIES, derivatives=None, input_hold=None,
               input_delay=None):
    """Every candidate structure (family x library x derivative) with its library object.

    Returns
    -------
    list of (dict, library)
        The structure's settings (strings, for the results table) and the library of
        :func:`make_estimator`; ``"+hard"`` libraries appear only where the data proposes terms.
    """
    n_outputs, n_inputs = y.shape[1], X.shape[1]
    derivs = settings["derivatives"] if derivatives is None else {
        k: v for k, v in settings["derivatives"].items() if k in derivatives or k.split("_")[0] in derivatives}
    hold = settings["input_hold"] if input_hold is None else input_hold
    delay = settings["input_delay"] if input_delay is None else input_delay
    out = []
    for family in families:
        if family in FAMILY_TABLE:
            out += FAMILY_TABLE[family][0](settings, n_outputs, n_inputs, hold, delay)
            continue
        if family == "order2+latent":
            if n_outputs == 1:  # states (y, v, z): the latent state's products with the velocity
                lib = PolynomialLibrary(degree=1) + AbsProductLibrary(pairs=[(1, 2)])
                out += [({"family": family, "library": LATENT_LIBRARY, "derivative": d, "input_hold": hold,
                         "input_delay": delay}, lib)
                        for d in derivs]
            continue
        if family == "order1+latent2":
            if n_outputs == 1 and n_inputs >= 1:  # states (y, z0, z1), a chain of two lags of u0; linear library
                out.append(({"family": family, "library": "linear", "derivative": "finite_difference",
                             "input_hold": hold, "input_delay": delay}, PolynomialLibrary(degree=1)))
            continue
        if family == LAG_FAMILY:  # no derivative, the input held by construction: the richest polynomial library
            degrees = [lib_name for lib_name in libraries if lib_name in _DEGREE]  # its terms selected in the fit
            if degrees:
                lib_name = max(degrees, key=_DEGREE.get)
                out.append(({"family": family, "library": lib_name, "derivative": "none", "input_hold": "zoh",
                             "input_delay": delay}, PolynomialLibrary(degree=_DEGREE[lib_name])))
            continue
        if family == "order1+latent":
            if n_outputs == 1 and n_inputs >= 1:  # states (y, z), driven by u0; refined, so one derivative
                for lib_name, lib in (("linear", PolynomialLibrary(degree=1)),
                                      ("linear+hard", _latent_hard_terms(settings, n_inputs)),
                                      (LATENT_HINGE, _latent_hinges(X, settings, n_inputs, libraries)),
                                      (LATENT_CASCADE, _latent_cascade(X, settings, n_inputs, libraries))):
                    if lib is not None:
                        out.append(({"family": family, "library": lib_name, "derivative": "finite_difference",
                                     "input_hold": hold, "input_delay": delay}, lib))
            continue
        for lib_name in libraries:
            lib = _library(lib_name, family, settings, n_outputs, n_inputs)
            if lib is None:
                continue
            for d_name in derivs:
                if family == "first_order" and lib_name.endswith("+hard") and d_name != next(iter(derivs)):
                    continue
                out.append(({"family": family, "library": lib_name, "derivative": d_name, "input_hold": hold,
                             "input_delay": delay}, lib))
    return out


def make_estimator(structure, library, threshold, dt, settings, *, refine=None, random_state=0):
    """An unfitted estimator of ``structure`` with an STLS threshold on normalized columns.

    Its divergence bound ``max_abs`` is the estimators' (1e6) or, for a
    record whose signals are larger, 1000 times their largest magnitude
    (``settings["max_abs"]``), so that a record in large units simulates.
    """
    estimator = _make(structure, library, threshold, dt, settings, refine=refine, random_state=random_state)
    max_abs = settings.get("max_abs", _MAX_ABS)
    return estimator.set_params(max_abs=max_abs) if max_abs > _MAX_ABS else estimator


def _make(structure, library, threshold, dt, settings, *, refine, random_state):
    """The estimator of :func:`make_estimator`.

    ``first_order`` is :class:`~sindybench.SINDy`; ``lag`` is :class:`~sindybench.LagSINDy`
    (:func:`~sindybench.identify._lag.make_lag`: its orders and terms chosen in its fit); ``order2`` and ``order3``
    are :class:`~sindybench.HiddenStateSINDy` with
    :class:`~sindybench.hidden.DerivativeHiddenState`; ``order1+latent`` and
    ``order2+latent`` are :class:`~sindybench.hidden.LatentHiddenState`
    (order 1 driven by the input, the latent state and the output held
    non-negative when the output is positive and the output below its
    saturation level; order 2 driven by the velocity), the lag start searched
    inside ``fit`` on an even grid of time constants (20 and 12 of them, log-spaced
    from 1 to 1000 samples; the same at every seed), the two best starts refined
    by simulation error side by side and the best after refinement kept
    (``n_refined=2``); the hinge candidate is warm-started from the plain
    latent model (``levels="range"``), and the ``cascade+hard`` candidate has
    its hinges (no latent indicator) in a cascade
    (``LatentHiddenState(cascade=True)``: no output term in the latent row),
    the latent state in u0's units and the hinges at the library's levels.
    ``refine`` (an
    :class:`~sindybench.refine.OutputErrorRefinement`) refines the fit by its
    simulation error, and a refined hidden-state model starts new data by
    least squares on its first samples (``initial_state="fit"``).
    ``random_state`` is passed to the hidden-state estimators (their grids do not use it).
    """
    optimizer = STLS(threshold=float(threshold), alpha=1e-9, normalize_columns=True)
    if structure["family"] == LAG_FAMILY:  # its orders and terms searched, and refined, in its fit
        return make_lag(structure, library, dt)
    d_name = structure["derivative"]
    differentiation = _differentiation(d_name, settings["derivatives"].get(d_name, {}))
    hold, delay = structure["input_hold"], structure["input_delay"]
    if structure["family"] in FAMILY_TABLE:
        return FAMILY_TABLE[structure["family"]][1](structure, library, dt, differentiation, settings,
                                                    random_state=random_state)
    if structure["family"] == "first_order":
        return SINDy(library=clone(library), optimizer=optimizer, differentiation=differentiation, dt=dt,
                     input_hold=hold, input_delay=delay, refine=refine)
    order = _ORDER[structure["family"]]
    if structure["family"] in ("order1+latent", "order1+latent2"):  # lags of the input as the start, then refined
        positive, top = bool(settings["positive"]), settings["saturation"][0]
        # the hinge candidate warm-starts from the plain one (its own fit), hinges at its latent state's quantiles
        hinge = structure["library"] == LATENT_HINGE
        # the cascade starts in u0's units, its hinges at the library's levels (named in them)
        cascade = structure["library"] == LATENT_CASCADE
        search = cascade and not positive  # the start's offset searched (a latent state held >= 0 keeps its zero)
        tau = LogUniform(_LATENT_TAU[0] * dt, _LATENT_TAU[1] * dt)
        hidden = LatentHiddenState(n_latent=2 if structure["family"] == "order1+latent2" else 1, order=1,
                                   driver="input", scale="units" if cascade else "driver",
                                   bounds={"tau": tau, "offset": offset_range(library)} if search else {"tau": tau},
                                   offset=None if search else 0.0, start=_LATENT_START,
                                   levels="range" if hinge else "library",
                                   latent_bounds=(0.0, np.inf) if positive else None,
                                   output_bounds=(0.0, np.inf if top is None else top) if positive else None,
                                   cascade=cascade)
        return HiddenStateSINDy(hidden=hidden, library=clone(library), optimizer=optimizer,
                                differentiation=differentiation, dt=dt, input_hold=hold, input_delay=delay,
                                validation_size=0.15,
                                validation="full", n_trials=_LATENT_TRIALS_1, random_state=random_state,
                                refine=OutputErrorRefinement(**_LATENT_REFINEMENT), initial_state="fit",
                                show_progress_bar=False, **_LATENT_SEARCH)
    if structure["family"] == "order2+latent":  # its own search of the lag start, then refined by simulation
        tau = LogUniform(_LATENT_TAU[0] * dt, _LATENT_TAU[1] * dt)
        hidden = LatentHiddenState(order=2, driver="velocity", bounds={"tau": tau}, start=_LATENT_START)
        return HiddenStateSINDy(hidden=hidden,
                                library=clone(library), optimizer=optimizer, differentiation=differentiation, dt=dt,
                                input_hold=hold, input_delay=delay, validation_size=0.15, n_trials=_LATENT_TRIALS,
                                random_state=random_state,
                                refine=OutputErrorRefinement(**_LATENT_REFINEMENT), initial_state="fit",
                                show_progress_bar=False, **_LATENT_SEARCH)
    return HiddenStateSINDy(hidden=DerivativeHiddenState(order=order), library=clone(library), optimizer=optimizer,
                            differentiation=differentiation, dt=dt, input_hold=hold, input_delay=delay,
                            refine=refine,
                            initial_state="fit" if refine is not None else "strategy", show_progress_bar=False)


def n_terms(estimator):
    """Nonzero learned coefficients of a fitted estimator (its complexity), the most and the fewest in one row."""
    nonzero = np.asarray(estimator.coef_) != 0
    per_row = nonzero.sum(axis=1) if nonzero.size else np.zeros(1, dtype=int)
    return int(nonzero.sum()), int(per_row.max()), int(per_row.min())
