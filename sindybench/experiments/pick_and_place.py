"""Pick-and-place machine (Juloski et al., 2004): the study's Table 1.

Models: naive first-order SINDy ``y' = f(y, u)`` with a quadratic polynomial
library, the second-order remedy (derivative-coordinate augmentation,
:class:`~sindybench.hidden.DerivativeHiddenState`), its Coulomb-friction
variant refined by simulation error and by prediction error (scored by free
run, with its k-step scores), and the ARX / NN-ARX baselines. Data decimated to 400 Hz and standardised; training 3840,
validation 960, test the last 1201 samples.
"""

from ._common import (
    arx_model,
    arx_space,
    identified,
    nnarx_model,
    nnarx_space,
    prediction_refinement,
    refinement,
    sindy_model,
    stls_space,
)
from ._spec import Benchmark, ModelSpec

__all__ = []  # the module's BENCHMARK is read through experiments.get_benchmark (every set-up has one)


def _load(**kwargs):
    from ..datasets import load_pick_and_place

    return load_pick_and_place(**kwargs)


def _poly():
    from ..libraries import PolynomialLibrary

    return PolynomialLibrary(degree=2)


def _friction():
    """Quadratic polynomial plus Coulomb friction ``sign(y')`` (column 1 of ``Z = [y, y', u]``)."""
    from ..libraries import SIGN, ConcatLibrary, TermsLibrary

    return ConcatLibrary([_poly(), TermsLibrary(terms=[[[1, SIGN, 0.0, 0.0]]])])


def _second_order_with(library):
    def make(*, random_state, quick, dt, n_val, n_samples):
        from .. import STLS, HiddenStateSINDy
        from ..differentiation import TotalVariation
        from ..hidden import DerivativeHiddenState

        return HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=library(),
                                optimizer=STLS(threshold=0.1, alpha=1e-6),
                                differentiation=TotalVariation(gamma=1e-3), dt=dt, input_hold="zoh", refine=None)

    return make


_second_order = _second_order_with(_poly)


BENCHMARK = Benchmark(
    name="pick-and-place",
    cost=34,  # CPU seconds of run all (seed 0, fresh clone, after its warm-up); orders a parallel run
    title="Pick-and-place machine",
    load=_load,
    output_label="head position y (standardised)",
    input_label="motor voltage u (standardised)",
    n_init=10,
    reported_model="sindy_friction_refined",  # the richest physical structure, refined (fixed before any test score)
    models=(
        ModelSpec("sindy_poly", "SINDy, 1st order", sindy_model(_poly, gamma=1e-3),
                  stls_space(threshold=(1e-4, 1e2), gamma=(1e-6, 1e1)), n_trials=100, n_trials_quick=6,
                  description="naive first-order SINDy, y' = f(y, u), quadratic polynomial library"),
        ModelSpec("sindy_second_order", "SINDy, 2nd order", _second_order,
                  stls_space(threshold=(1e-4, 1e2), gamma=(1e-6, 1e1)), n_trials=100, n_trials_quick=6,
                  description="states (y, y'), y'' = f(y, y', u) with a quadratic polynomial library"),
        ModelSpec("sindy_second_order_refined", "SINDy, 2nd order + simulation-error refinement", refinement(),
                  refines="sindy_second_order",
                  description="the tuned second-order model with its nonzero coefficients and initial state refined "
                              "by the simulation error of the estimation record"),
        ModelSpec("sindy_friction", "SINDy, 2nd order, Coulomb friction term", _second_order_with(_friction),
                  stls_space(threshold=(1e-4, 1e2), gamma=(1e-6, 1e1)), n_trials=100, n_trials_quick=6,
                  description="the second-order model with sign(y') (Coulomb friction of the head) added to the "
                              "library; the threshold chosen on the validation block decides whether it stays"),
        ModelSpec("sindy_friction_refined", "SINDy, 2nd order, Coulomb friction + simulation-error refinement",
                  refinement(), refines="sindy_friction",
                  description="the friction model refined by the simulation error of the estimation record"),
        ModelSpec("sindy_friction_pem", "SINDy, 2nd order, Coulomb friction + prediction-error refinement",
                  prediction_refinement(), refines="sindy_friction", k_step=True,
                  description="the friction model refined by its one-step prediction errors through a fitted "
                              "observer gain on the estimation record, scored by free run"),
        ModelSpec("arx", "ARX", arx_model(), arx_space(), n_trials=50, n_trials_quick=6,
                  description="linear ARX, orders chosen on the validation block"),
        ModelSpec("nnarx", "NN-ARX", nnarx_model(dtype="float32"), nnarx_space(), n_trials=20, n_trials_quick=3,
                  description="linear ARX plus an MLP on its residual, both on the lags, trained one step ahead, simulated free run"),
        identified(5),
    ),
)
