# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Bouc-Wen oscillator: reconstruct the hidden hysteretic force, fit its law, draw the loops
#
# The study's Table 2. The displacement `y` of a mass under a force `u` is measured; the
# hysteretic restoring force `z` is not:
#
# $$m \ddot y + c \dot y + k y + z = u, \qquad
#   \dot z = \alpha \dot y - \beta (\gamma |\dot y| z + \delta \dot y |z|).$$
#
# `BoucWenHiddenState` reconstructs `z = u - c y' - k y - m y''` for a guess of `(m, c, k)`,
# fits `z'` sparsely with products of `v = y'`, `z`, `|v|`, `|z|`, and searches the guess by
# the validation simulation error. With the true `m, c, k` ("Ideal") the fit keeps the three
# terms of the true law.
#
# The benchmark records are read from `SINDYBENCH_DATA`; `SINDYBENCH_QUICK=1` shrinks the
# search budget.

# %%
# %matplotlib inline
import os

import numpy as np
from sklearn.base import clone

from sindybench import STLS, HiddenStateSINDy
from sindybench.datasets import load_bouc_wen
from sindybench.differentiation import Spectral
from sindybench.hidden import BoucWenHiddenState
from sindybench.metrics import rmse
from sindybench.plotting import plot_hidden_states, plot_hysteresis, plot_search_history, plot_simulation
from sindybench.refine import OutputErrorRefinement
from sindybench.search import LogUniform

QUICK = os.environ.get("SINDYBENCH_QUICK", "") not in ("", "0")
TRUE = {"m": 2.0, "c": 10.0, "k": 5e4}
GUESS_BOUNDS = {"m": LogUniform(1.0, 5.0), "c": LogUniform(1.0, 100.0), "k": LogUniform(1e4, 1e5)}  # searched ranges
STUDY_RMSE = {"searched m, c, k": (11.26e-4, 1.83e-4, 1.72e-4), "Ideal (true m, c, k)": (8.87e-4, 2.52e-4, 3.03e-4)}


def make_model(hidden, n_rows, **kwargs):
    return HiddenStateSINDy(
        hidden=hidden,
        # threshold on normalised columns: a tenth of a z' of RMS 1.3e4 N/s, over n_rows samples
        optimizer=STLS(threshold=0.1 * 1.3e4 * np.sqrt(n_rows), normalize_columns=True),
        differentiation=Spectral(cutoff=150.0),  # the training multisine excites 5-150 Hz: keep that band
        dt=1.0 / 750.0,
        n_substeps=2,
        input_hold="linear",  # a held force lags half a sample
        **{"library": None, "refine": None, **kwargs},  # the strategy's library; the refined row refines
    )


data = load_bouc_wen()
u, y = data.estimation.u, data.estimation.y  # training + validation, the validation block last
n_val = len(data.validation.y)

# %%
models = {
    "searched m, c, k": make_model(BoucWenHiddenState(bounds=GUESS_BOUNDS), len(y) - n_val, validation_size=n_val,
                                   n_trials=10 if QUICK else 30, random_state=0).fit(u, y),
    "Ideal (true m, c, k)": make_model(BoucWenHiddenState(**TRUE), len(data.train.y)).fit(data.train.u, data.train.y),
}
# the searched model fitted by simulation error: m, c, k (held at the search's choice, then refined), the z'
# coefficients and the initial state, by the open-loop simulation error of the estimation record
searched = models["searched m, c, k"]
models["searched, refined"] = clone(searched).set_params(
    **{f"hidden__{k}": searched.params_[k] for k in TRUE},
    refine=OutputErrorRefinement(max_samples=10000 if QUICK else None), initial_state="fit",
).fit(u, y)

tests = ("sine", "multisine", "sinesweep")
print("Bouc-Wen, open-loop simulation RMSE [1e-4 m] on", ", ".join(tests), "(study in brackets)")
for label, model in models.items():
    cells = []
    for i, name in enumerate(tests):
        test = data.test[name]
        y_sim = model.predict(test.u, y_init=test.y[: data.n_init])
        study = f"{1e4 * STUDY_RMSE[label][i]:5.2f}" if label in STUDY_RMSE else "    -"
        cells.append(f"{1e4 * rmse(test.y, y_sim):6.2f} ({study})")
    print(f"  Hidden SINDy, {label:<22}" + "  ".join(cells))
    print("    m, c, k =", {k: float(f"{v:.4g}") for k, v in model.params_.items() if k in TRUE})

# %% [markdown]
# With the true `m, c, k` the sparse fit of `z'` keeps the Bouc-Wen terms `v`, `|v| z` and
# `v |z|` (the rows `y' = v` and the force balance are fixed by the strategy):

# %%
models["Ideal (true m, c, k)"]

# %% [markdown]
# The searched model, and how its inner search over `(m, c, k)` went:

# %%
models["searched m, c, k"]

# %%
plot_search_history(models["searched m, c, k"]);

# %% [markdown]
# Open-loop simulation of the multisine test record, and the force-displacement loops on the
# low-frequency sine, where hysteresis shows most:

# %%
multisine, sine = data.test.multisine, data.test.sine
plot_simulation(multisine.u, multisine.y, models, n_init=data.n_init, dt=multisine.dt,
                output_label="displacement y [m]", input_label="force u [N]");

# %%
plot_hysteresis(sine.u, sine.y, models, n_init=data.n_init, output_label="displacement y [m]",
                input_label="force u [N]");

# %% [markdown]
# The hidden force `z` against the displacement: the hysteresis loop of the hidden state, as
# each model simulates it on the sine, and `z` as reconstructed on the training data.

# %%
plot_hysteresis(sine.u, sine.y, models, n_init=data.n_init, hidden="z", output_label="displacement y [m]");

# %%
plot_hidden_states(models["Ideal (true m, c, k)"], states=["z"]);
