"""Model factories and search spaces shared by the three benchmark set-ups.

Every factory has the signature ``make(random_state, quick, dt, n_val)`` of
:class:`~sindybench.experiments.ModelSpec`; estimators are imported lazily so
that describing a benchmark never pulls in all of the library.
"""

__all__ = ["IDENTIFIED", "IDENTIFIED_EQUATIONS", "arx_model", "arx_space", "hidden_defaults_01", "identified",
           "nnarx_model", "nnarx_space", "refinement", "sindy_model", "stls_space"]

#: simulation-error refinement budget (simulations per round) of a default and a quick run
REFINE_NFEV, REFINE_NFEV_QUICK = 30, 5


def hidden_defaults_01():
    """The :class:`~sindybench.HiddenStateSINDy` defaults before 0.2, which the rows written before it pin.

    Since 0.2 ``input_hold`` and ``refine`` default to ``"auto"``, and ``differentiation`` to
    ``FiniteDifference(accuracy=4)`` (0.2) then ``"auto"`` (0.3); a row that relied on the old defaults
    passes these, so its scores stay.
    """
    from ..differentiation import FiniteDifference

    return {"differentiation": FiniteDifference(), "input_hold": "zoh", "refine": None}


def refinement(**kwargs):
    """Settings factory of a "+ simulation-error refinement" row (:attr:`ModelSpec.refines`).

    The refined model starts new data from ``y_init`` by least squares
    (``initial_state="fit"``, all states free), with the same ``n_init``
    samples as every other row.
    """
    def make(*, random_state, quick, dt, n_val, n_samples):
        from ..refine import OutputErrorRefinement

        budget = REFINE_NFEV_QUICK if quick else REFINE_NFEV
        return {"refine": OutputErrorRefinement(max_nfev=budget, **kwargs), "initial_state": "fit"}

    return make


def prediction_refinement(**kwargs):
    """Settings factory of a "+ prediction-error refinement" row (:attr:`ModelSpec.refines`).

    As :func:`refinement`, with :class:`~sindybench.refine.PredictionErrorRefinement`:
    fitted by the errors of its one-step predictions through the observer,
    scored by free run like every other row.
    """
    def make(*, random_state, quick, dt, n_val, n_samples):
        from ..refine import PredictionErrorRefinement

        budget = REFINE_NFEV_QUICK if quick else REFINE_NFEV
        return {"refine": PredictionErrorRefinement(max_nfev=budget, **kwargs), "initial_state": "fit"}

    return make


def stls_space(*, threshold=(1e-4, 1e1), alpha=(1e-8, 1e-1), gamma=None):
    """Search space of an STLS model: log-uniform threshold and ridge alpha.

    With ``gamma=(low, high)``, the total-variation regularisation of the
    derivative is searched jointly (``differentiation__gamma``), as in the study.
    """
    def space(quick, n_init):
        from ..model_selection import LogUniform

        dims = {
            "optimizer__threshold": LogUniform(*threshold),
            "optimizer__alpha": LogUniform(*alpha),
        }
        if gamma is not None:
            dims["differentiation__gamma"] = LogUniform(*gamma)
        return dims

    return space


def _differentiation(gamma):
    if gamma is None:
        return None
    from ..differentiation import TotalVariation

    return TotalVariation(gamma=gamma)


def sindy_model(library, *, threshold=0.1, alpha=1e-6, gamma=None, bounds=None, normalize_columns=False,
                n_substeps=1):
    """Factory of a naive (first-order) :class:`~sindybench.SINDy` model.

    ``library`` is a zero-argument callable returning a fresh library.
    """
    def make(*, random_state, quick, dt, n_val, n_samples):
        from .. import STLS, SINDy

        return SINDy(
            library=library(),
            optimizer=STLS(threshold=threshold, alpha=alpha, normalize_columns=normalize_columns),
            differentiation=_differentiation(gamma),
            dt=dt,
            bounds=bounds,
            n_substeps=n_substeps,
            max_abs=float("inf"),  # SINDy's default before 0.2: the rows keep their scores
        )

    return make


def arx_model(make_kwargs=None):
    """Factory of an :class:`~sindybench.baselines.ARX` model."""
    def make(*, random_state, quick, dt, n_val, n_samples):
        from ..baselines import ARX

        return ARX(**(make_kwargs or {}))

    return make


def arx_space(max_na=10, max_nb=10):
    """Search space of ARX orders (``na``, ``nb``, ``nk``).

    A simulation starts from ``max(na, nb + nk - 1)`` measured samples, so the
    orders are also capped by the samples a test lets a model use (``n_init``).
    """
    def space(quick, n_init):
        from ..model_selection import IntRange

        return {"na": IntRange(1, min(max_na, n_init)), "nb": IntRange(1, min(max_nb, n_init)), "nk": IntRange(0, 1)}

    return space


def nnarx_model(*, hidden_layer_sizes=(16,), max_iter=300, quick_max_iter=60, dtype="float64"):
    """Factory of an :class:`~sindybench.baselines.NNARX` model (seeded; smaller with ``quick``).

    ``dtype="float32"`` trains the networks in single precision: two to four times faster, at
    the same validation error on the long records (pick-and-place, Bouc-Wen).
    """
    def make(*, random_state, quick, dt, n_val, n_samples):
        from ..baselines import NNARX

        return NNARX(na=2, nb=2, hidden_layer_sizes=(8,) if quick else hidden_layer_sizes,
                     max_iter=quick_max_iter if quick else max_iter, dtype=dtype, random_state=random_state)

    return make


def nnarx_space(max_na=5, max_nb=5, sizes=((8,), (16,), (32,), (16, 16)), alpha=(1e-1, 1e1)):
    """Search space of NN-ARX orders, network size and weight penalty (see :func:`arx_space`).

    The default penalty range suits ``NNARX(residual=True)`` (the default): the
    networks fit a small residual of a linear ARX part on standardised data.
    With ``quick`` the network size is not searched (it stays small).
    """
    def space(quick, n_init):
        from ..model_selection import Categorical, IntRange, LogUniform

        dims = {
            "na": IntRange(1, min(max_na, n_init)),
            "nb": IntRange(1, min(max_nb, n_init)),
            "alpha": LogUniform(*alpha),
        }
        if not quick:
            dims["hidden_layer_sizes"] = Categorical(sizes)
        return dims

    return space


def identified(n_init, *, equations_only=False):
    """The row "identified automatically": :class:`~sindybench.identify.IdentifyCV` given the record and ``dt`` only.

    Nothing of the benchmark's physics goes in (no family, library, bounds or
    strategy): only the number of first samples a test lets a model use to
    start (``n_init``, the protocol's), so that its validation blocks start
    the way the tests do. With ``--quick``: finite differences only. With
    ``equations_only``, the row ``"identified_equations"``: the same search
    without the discrete-time lag family, for a benchmark whose identified row
    is a lag model (the equation stays beside it).
    """
    from ._spec import ModelSpec

    def make(*, random_state, quick, dt, n_val, n_samples):
        from ..identify import IdentifyCV
        from ..identify._lag import LAG_FAMILY
        from ..identify._space import FAMILIES

        settings = {"derivatives": ["finite_difference"]} if quick else {}
        if equations_only:
            settings["families"] = [f for f in FAMILIES if f != LAG_FAMILY]
        return IdentifyCV(dt=dt, n_init=n_init, random_state=random_state, show_progress_bar=False, **settings)

    if equations_only:
        return ModelSpec(IDENTIFIED_EQUATIONS, "identified automatically, equations only", make,
                         description="sindybench.identify as in the row 'identified automatically', its "
                                     "continuous-time families only (no discrete-time lag model)")
    return ModelSpec(IDENTIFIED, "identified automatically", make,
                     description="sindybench.identify on the estimation record's inputs, outputs and sample time: "
                                 "family (continuous-time equations, a linear state-space base, or a discrete-time "
                                 "lag model), library, sparsity, derivative and input hold chosen by simulation on "
                                 "validation blocks of the estimation record (parsimony rule; an equation wins a "
                                 "tie with a lag model within one standard error)")


#: key of the "identified automatically" row of every benchmark
IDENTIFIED = "identified"
#: key of the row "identified automatically, equations only" (beside a benchmark's lag-model identified row)
IDENTIFIED_EQUATIONS = "identified_equations"
