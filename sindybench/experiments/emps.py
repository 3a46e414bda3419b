"""Electro-Mechanical Positioning System, EMPS (Janot, Gautier, Brunot 2019).

Official protocol (nonlinear_benchmarks' ``EMPS()``): input ``vir`` (V),
output ``qm``, estimation on DATA_EMPS, test on DATA_EMPS_PULSES by open-loop
simulation from the first 20 test samples, RMSE on the remaining samples. The
position is reported in millimetres here (the loader's metres times 1000), so
every RMSE is in mm. Validation block: the last period of the reference
(6210 samples) of the estimation record; the test record is never used to
choose anything.

Models: naive first-order SINDy, the second-order remedy
(:class:`~sindybench.hidden.DerivativeHiddenState`) with a quadratic
polynomial library, the friction model of the dataset's description
``y'' = c0 + c1 y' + c2 sign(y') + c3 u`` (least squares on a
Savitzky-Golay derivative) and its simulation-error refinement on the whole
estimation record, the friction model with position terms ``y, y^2`` (kept
or dropped by the threshold chosen on the validation block) and its
refinement, both friction models refined by prediction error instead (scored
by free run, with their k-step scores), and the ARX / NN-ARX baselines.
"""

from ._common import (
    arx_model,
    arx_space,
    identified,
    nnarx_model,
    nnarx_space,
    prediction_refinement,
    refinement,
    stls_space,
)
from ._spec import Benchmark, ModelSpec

__all__ = []  # the module's BENCHMARK is read through experiments.get_benchmark (every set-up has one)

# Savitzky-Golay derivative: a window of 19 samples (19 ms) fits inside the 20 samples that start a test
_WINDOW, _POLYORDER = 19, 3
# The refinement keeps the initial state the strategy estimates from the first samples (no free x0): a
# test starts that way too. With a free x0 the refined coefficients lean on a start that 20 samples do not
# reproduce: the friction model simulated over the estimation record from its first 20 samples scores
# 7.46 mm refined with a free x0 and 2.94 mm refined without (7.46 vs 2.94 is read on the estimation record).
_REFINEMENT = refinement(initial_state=False)
# The prediction-error rows: the same starts and held initial state, the one-step predictions through a fitted
# observer gain. One step (horizon=1) was chosen on the validation block (a fit on the training samples only,
# friction model: validation RMSE 2.79 and 2.76 mm at horizons 1 and 10 in 1.2 and 7.6 s of CPU; equation
# error 2.58 mm, output error 3.04 mm): longer horizons cost k times more and did not pay on validation.
_PREDICTION = prediction_refinement(initial_state=False)
# the columns of the library input Z = [y, y', u] of the second-order models
_Y, _V, _U = 0, 1, 2


def _load(**kwargs):
    """The EMPS records with the position in millimetres (RMSE in mm, as the benchmark reports it)."""
    from ..datasets import load_emps

    data = load_emps(**kwargs)
    for split in (data.train, data.validation, data.estimation, data.test):
        split.y = 1e3 * split.y
        split.qg = 1e3 * split.qg
    data.units.y = "mm"
    return data


def _differentiation():
    from ..differentiation import SavitzkyGolay

    return SavitzkyGolay(window_length=_WINDOW, polyorder=_POLYORDER)


def _poly():
    from ..libraries import PolynomialLibrary

    return PolynomialLibrary(degree=2)


def _friction_terms():
    from ..libraries import POW, SIGN

    return [[], [[_V, POW, 1, 0]], [[_V, SIGN, 0, 0]], [[_U, POW, 1, 0]]]


def _friction():
    """``[1, y', sign(y'), u]``: the dataset's reference model (offset, viscous and Coulomb friction, force)."""
    from ..libraries import TermsLibrary

    return TermsLibrary(terms=_friction_terms())


def _friction_position():
    """The friction library plus ``y`` and ``y^2``: a force that depends on where the cart is."""
    from ..libraries import POW, TermsLibrary

    return TermsLibrary(terms=_friction_terms() + [[[_Y, POW, 1, 0]], [[_Y, POW, 2, 0]]])


def _first_order(*, random_state, quick, dt, n_val, n_samples):
    from .. import STLS, SINDy

    return SINDy(library=_poly(), optimizer=STLS(threshold=0.1, alpha=1e-6), differentiation=_differentiation(),
                 dt=dt, max_abs=float("inf"))  # SINDy's default before 0.2: the row keeps its score


def _second_order_with(library, threshold=0.0):
    def make(*, random_state, quick, dt, n_val, n_samples):
        from .. import STLS, HiddenStateSINDy
        from ..hidden import DerivativeHiddenState

        return HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=library(),
                                optimizer=STLS(threshold=threshold, alpha=1e-8),
                                differentiation=_differentiation(), dt=dt, input_hold="zoh", refine=None)

    return make


BENCHMARK = Benchmark(
    name="emps",
    cost=50,  # CPU seconds of run all (seed 0, fresh clone, after its warm-up); orders a parallel run
    title="Electro-Mechanical Positioning System (EMPS)",
    load=_load,
    output_label="cart position qm [mm]",
    input_label="motor force command vir [V]",
    n_init=20,
    reported_model="sindy_friction_position_refined",  # the richest physical structure, refined (fixed before any test score)
    band_members=0, band_members_quick=0,
    band_skip_reason="each member refits the 24,000-sample refinement (about 2 s): 10 members would take a third of the run's time budget",
    models=(
        ModelSpec("sindy_poly", "SINDy, 1st order", _first_order,
                  stls_space(threshold=(1e-4, 1e2), alpha=(1e-10, 1e-2)), n_trials=10, n_trials_quick=3,
                  description="naive first-order SINDy, y' = f(y, u), quadratic polynomial library"),
        ModelSpec("sindy_second_order", "SINDy, 2nd order", _second_order_with(_poly),
                  stls_space(threshold=(1e-4, 1e2), alpha=(1e-10, 1e-2)), n_trials=10, n_trials_quick=3,
                  description="states (y, y'), y'' = f(y, y', u) with a quadratic polynomial library"),
        ModelSpec("sindy_friction", "SINDy, 2nd order, friction model", _second_order_with(_friction),
                  description="y'' = c0 + c1 y' + c2 sign(y') + c3 u (offset, viscous and Coulomb friction, "
                              "motor force), least squares on a Savitzky-Golay derivative of the estimation record"),
        ModelSpec("sindy_friction_refined", "SINDy, friction model + simulation-error refinement", _REFINEMENT,
                  refines="sindy_friction",
                  description="the friction model refined by the simulation error of the whole estimation record, "
                              "started as a test starts (from the first samples, not a refined initial state)"),
        ModelSpec("sindy_friction_position", "SINDy, friction + position terms", _second_order_with(_friction_position),
                  stls_space(threshold=(1e-4, 1e1), alpha=(1e-10, 1e-2)), n_trials=10, n_trials_quick=3,
                  description="the friction library plus y and y^2 (a force that depends on the position); "
                              "the threshold chosen on the validation block decides which terms stay"),
        ModelSpec("sindy_friction_position_refined", "SINDy, friction + position terms + simulation-error refinement",
                  _REFINEMENT, refines="sindy_friction_position",
                  description="the position-dependent friction model refined by the simulation error of the "
                              "whole estimation record"),
        ModelSpec("sindy_friction_pem", "SINDy, friction model + prediction-error refinement", _PREDICTION,
                  refines="sindy_friction", k_step=True,
                  description="the friction model refined by its one-step prediction errors through a fitted "
                              "observer gain on the whole estimation record, scored by free run"),
        ModelSpec("sindy_friction_position_pem", "SINDy, friction + position terms + prediction-error refinement",
                  _PREDICTION, refines="sindy_friction_position", k_step=True,
                  description="the position-dependent friction model refined by its one-step prediction errors, "
                              "scored by free run"),
        ModelSpec("arx", "ARX", arx_model(), arx_space(), n_trials=20, n_trials_quick=4,
                  description="linear ARX, orders chosen on the validation block"),
        ModelSpec("nnarx", "NN-ARX", nnarx_model(dtype="float32"), nnarx_space(), n_trials=4, n_trials_quick=2,
                  max_train=4000, max_train_quick=2000,
                  description="linear ARX plus an MLP on its residual, both on the lags, trained one step ahead on "
                              "the first 4000 training samples, simulated free run"),
        identified(20),
    ),
)
