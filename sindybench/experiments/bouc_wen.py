"""Bouc-Wen hysteretic oscillator (Noël and Schoukens, 2016): the study's Table 2.

Models: naive second-order SINDy in ``(y, y')`` with a polynomial library,
the structural hidden-force remedy (:class:`~sindybench.hidden.BoucWenStructure`)
with ``m, c, k`` searched, the same with the true ``m, c, k`` ("Ideal"), and
the ARX / NN-ARX baselines. Training: the first 40000 samples of the
multisine record, validation the next 960; tests: the low-frequency sine
(from rest), the official multisine and the sine sweep.
"""

from ._common import arx_model, arx_space, nnarx_model, nnarx_space, stls_space
from ._spec import Benchmark, ModelSpec

__all__ = ["BENCHMARK"]

TRUE_MCK = {"m": 2.0, "c": 10.0, "k": 5e4}


def _load(**kwargs):
    from ..datasets import load_bouc_wen

    return load_bouc_wen(**kwargs)


def _naive(*, random_state, quick, dt, n_val):
    from .. import STLS, HiddenStateSINDy
    from ..hidden import DerivativeAugmentation
    from ..libraries import PolynomialLibrary

    return HiddenStateSINDy(hidden=DerivativeAugmentation(order=2), library=PolynomialLibrary(degree=2),
                            optimizer=STLS(threshold=1e-3, normalize_columns=True), dt=dt)


def _hidden(fixed):
    def make(*, random_state, quick, dt, n_val):
        from .. import HiddenStateSINDy
        from ..hidden import BoucWenStructure

        return HiddenStateSINDy(hidden=BoucWenStructure(**fixed), dt=dt, validation_size=n_val,
                                n_trials=10 if quick else 100, random_state=random_state)

    return make


BENCHMARK = Benchmark(
    name="bouc-wen",
    title="Bouc-Wen oscillator",
    load=_load,
    output_label="displacement y [m]",
    input_label="force u [N]",
    n_init=10,
    hysteresis_test="sine",
    n_train_quick=4000,
    models=(
        ModelSpec("sindy_second_order", "Naive SINDy, 2nd order", _naive,
                  stls_space(threshold=(1e-6, 1e-1)), n_trials=30, n_trials_quick=4,
                  description="states (y, y'), y'' = f(y, y', u), quadratic polynomial library, no hidden force"),
        ModelSpec("hidden_bouc_wen", "Hidden SINDy, searched m, c, k", _hidden({}), None,
                  description="z = u - c y' - k y - m y'' reconstructed, z' fitted with |.| products; "
                              "m, c, k searched on the validation block"),
        ModelSpec("hidden_bouc_wen_ideal", "Hidden SINDy, Ideal (true m, c, k)", _hidden(TRUE_MCK), None,
                  description="the same with the true m = 2, c = 10, k = 5e4"),
        ModelSpec("arx", "ARX", arx_model(), arx_space(max_na=8, max_nb=8), n_trials=30, n_trials_quick=5,
                  description="linear ARX, orders chosen on the validation block"),
        ModelSpec("nnarx", "NN-ARX", nnarx_model(), nnarx_space(max_na=4, max_nb=4), n_trials=15,
                  n_trials_quick=2, description="MLP on ARX lags, trained one step ahead, simulated free run"),
    ),
)
