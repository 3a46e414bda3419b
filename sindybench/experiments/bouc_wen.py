"""Bouc-Wen hysteretic oscillator (Noël and Schoukens, 2016): the study's Table 2.

Models: naive second-order SINDy in ``(y, y')`` with a polynomial library,
the structural hidden-force remedy (:class:`~sindybench.hidden.BoucWenHiddenState`)
with ``m, c, k`` searched, the same with the true ``m, c, k`` ("Ideal"), and
the ARX / NN-ARX baselines. Training: the first 40000 samples of the
multisine record, validation the next 960; tests: the low-frequency sine
(from rest), the official multisine and the sine sweep.
"""

from ._common import arx_model, arx_space, nnarx_model, nnarx_space, refinement, stls_space
from ._spec import Benchmark, ModelSpec

__all__ = ["BENCHMARK"]

TRUE_MCK = {"m": 2.0, "c": 10.0, "k": 5e4}
# plausible physical guesses (a factor of a few around the truth), as the study searched them
MCK_BOUNDS = {"m": (1.0, 5.0, True), "c": (1.0, 100.0, True), "k": (1e4, 1e5, True)}


def _load(**kwargs):
    from ..datasets import load_bouc_wen

    return load_bouc_wen(**kwargs)


def _threshold(n_rows, fraction=0.1, rate=1.3e4):
    """STLS threshold on normalised columns: ``fraction`` of a z' of RMS ``rate`` (N/s)."""
    return fraction * rate * n_rows ** 0.5


def _naive(*, random_state, quick, dt, n_val, n_samples):
    from .. import STLS, HiddenStateSINDy
    from ..differentiation import Spectral
    from ..hidden import DerivativeHiddenState
    from ..libraries import PolynomialLibrary

    return HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=2),
                            optimizer=STLS(threshold=1e-3, normalize_columns=True),
                            differentiation=Spectral(cutoff=150.0), dt=dt,
                            input_hold="linear", n_substeps=2)


def _hidden(fixed):
    def make(*, random_state, quick, dt, n_val, n_samples):
        from .. import STLS, HiddenStateSINDy
        from ..differentiation import Spectral
        from ..hidden import BoucWenHiddenState

        searched = len(fixed) < 3
        n_rows = n_samples - n_val if searched else n_samples
        return HiddenStateSINDy(
            hidden=BoucWenHiddenState(**fixed, bounds=None if not searched else MCK_BOUNDS),
            optimizer=STLS(threshold=_threshold(n_rows), normalize_columns=True),
            differentiation=Spectral(cutoff=150.0),  # the training multisine excites 5-150 Hz: keep that band
            dt=dt, n_substeps=2, input_hold="linear",  # a held force lags half a sample (see BoucWenHiddenState)
            validation_size=n_val, n_trials=10 if quick else 30, random_state=random_state,
        )

    return make


BENCHMARK = Benchmark(
    name="bouc-wen",
    title="Bouc-Wen oscillator",
    load=_load,
    output_label="displacement y [m]",
    input_label="force u [N]",
    n_init=10,
    hysteresis_test="sine",
    n_train_quick=None,
    models=(
        ModelSpec("sindy_second_order", "Naive SINDy, 2nd order", _naive,
                  stls_space(threshold=(1e-6, 1e-1)), n_trials=50, n_trials_quick=4,
                  description="states (y, y'), y'' = f(y, y', u), quadratic polynomial library, no hidden force"),
        ModelSpec("hidden_bouc_wen", "Hidden SINDy, searched m, c, k", _hidden({}), None,
                  description="z = u - c y' - k y - m y'' reconstructed, z' fitted with |.| products; "
                              "m, c, k searched on the validation block"),
        ModelSpec("hidden_bouc_wen_refined", "Hidden SINDy, searched m, c, k + simulation-error refinement",
                  refinement(), refines="hidden_bouc_wen",
                  description="the searched model with m, c, k, the z' coefficients and the initial state refined "
                              "by the simulation error of the estimation record (exact sensitivities)"),
        ModelSpec("hidden_bouc_wen_ideal", "Hidden SINDy, Ideal (true m, c, k)", _hidden(TRUE_MCK), None,
                  description="the same with the true m = 2, c = 10, k = 5e4"),
        ModelSpec("arx", "ARX", arx_model(), arx_space(max_na=8, max_nb=8), n_trials=50, n_trials_quick=5,
                  description="linear ARX, orders chosen on the validation block"),
        ModelSpec("nnarx", "NN-ARX", nnarx_model(dtype="float32"), nnarx_space(max_na=4, max_nb=4), n_trials=10,
                  n_trials_quick=2, max_train=10000, max_train_quick=3000,
                  description="linear ARX plus an MLP on its residual, both on the lags, trained one step ahead (first 10000 training samples), "
                              "simulated free run"),
    ),
)
