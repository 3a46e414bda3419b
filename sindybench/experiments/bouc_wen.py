"""Bouc-Wen hysteretic oscillator (Noël and Schoukens, 2016): the study's Table 2.

Models: naive second-order SINDy in ``(y, y')`` with a polynomial library,
the structural hidden-force remedy (:class:`~sindybench.hidden.BoucWenHiddenState`)
with ``m, c, k`` searched, the same with the true ``m, c, k`` ("Ideal"), and
the ARX / NN-ARX baselines. Training: the first 40000 samples of the
multisine record, validation the next 960; tests: the low-frequency sine
(from rest), the official multisine and the sine sweep.
"""

from ..search import LogUniform
from ._common import (REFINE_NFEV_QUICK, arx_model, arx_space, identified, nnarx_model, nnarx_space, refinement,
                      stls_space)
from ._spec import Benchmark, ModelSpec

__all__ = []  # the module's BENCHMARK is read through experiments.get_benchmark (every set-up has one)

TRUE_MCK = {"m": 2.0, "c": 10.0, "k": 5e4}
# plausible physical guesses (a factor of a few around the truth), as the study searched them
MCK_BOUNDS = {"m": LogUniform(1.0, 5.0), "c": LogUniform(1.0, 100.0), "k": LogUniform(1e4, 1e5)}


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
                            input_hold="linear", n_substeps=2, refine=None)


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
            library=None, refine=None,  # the defaults before 0.2: the strategy's library, no refinement
        )

    return make


def _latent(*, random_state, quick, dt, n_val, n_samples):
    """The hysteretic force discovered as a latent state: m, c, k not given, no z' law given.

    :class:`~sindybench.hidden.LatentHiddenState` with ``order=2`` (states y,
    v = y', z) and ``driver="velocity"`` (gauge: the coefficient of v in z'
    is 1): v' and z' are learned over [y, v, z, u] from a linear library plus
    the absolute products v|z|, |v|z, |v||z|. The latent z starts as a lag of v
    (its time constant searched on the validation block), then every term of
    z' is fitted by simulation error on the first 8000 training samples and
    pruned (the pruning level searched on the validation block by the outer
    search).
    """
    from .. import STLS, HiddenStateSINDy
    from ..differentiation import Spectral
    from ..hidden import LatentHiddenState
    from ..libraries import AbsProductLibrary, ConcatLibrary, PolynomialLibrary
    from ..refine import OutputErrorRefinement

    return HiddenStateSINDy(
        hidden=LatentHiddenState(order=2, driver="velocity", bounds={"tau": LogUniform(1e-4, 1.0)}),
        library=ConcatLibrary([PolynomialLibrary(degree=1), AbsProductLibrary(pairs=[(1, 2)])]),
        optimizer=STLS(threshold=1e-6, normalize_columns=True), differentiation=Spectral(cutoff=150.0),
        dt=dt, n_substeps=2, input_hold="linear", validation_size=n_val, n_trials=6 if quick else 12,
        random_state=random_state,
        refine=OutputErrorRefinement(max_nfev=REFINE_NFEV_QUICK if quick else 100, max_samples=8000),
        initial_state="fit",
    )


def _prune_space(quick, n_init):
    from ..model_selection import Categorical

    return {"refine__prune": Categorical([0.005, 0.02])}


BENCHMARK = Benchmark(
    name="bouc-wen",
    cost=86,  # CPU seconds of run all (seed 0, fresh clone, after its warm-up); orders a parallel run
    title="Bouc-Wen oscillator",
    load=_load,
    output_label="displacement y [m]",
    input_label="force u [N]",
    n_init=10,
    reported_model="hidden_bouc_wen_refined",  # the richest physical structure, refined (fixed before any test score)
    band_members=0, band_members_quick=0,
    band_skip_reason="each member refits the 40,000-sample refinement (about 2 s): 10 members would take a third of the run's time budget",
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
        ModelSpec("latent_bouc_wen", "SINDy with discovered latent state", _latent, _prune_space, n_trials=2,
                  n_trials_quick=1,
                  description="states (y, v, z) with z latent: v' and z' learned from [1, y, v, z, u] and the "
                              "absolute products of v and z, fitted by simulation error and pruned; m, c, k and "
                              "the z' law not given; gauge: the coefficient of v in z' is 1"),
        ModelSpec("arx", "ARX", arx_model(), arx_space(max_na=8, max_nb=8), n_trials=50, n_trials_quick=5,
                  description="linear ARX, orders chosen on the validation block"),
        ModelSpec("nnarx", "NN-ARX", nnarx_model(dtype="float32"), nnarx_space(max_na=4, max_nb=4), n_trials=10,
                  n_trials_quick=2, max_train=10000, max_train_quick=3000,
                  description="linear ARX plus an MLP on its residual, both on the lags, trained one step ahead (first 10000 training samples), "
                              "simulated free run"),
        identified(10),
    ),
)
