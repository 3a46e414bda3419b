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
# # Pick-and-place machine: a first-order model cannot oscillate, a second-order one can
#
# The study's Table 1. Only the head position `y` is measured; its velocity, the other half of
# a mechanical state, is hidden. Naive SINDy fits `y' = f(y, u)`;
# `DerivativeHiddenState(order=2)` takes `(y, y')` as the state and fits `y'' = f(y, y', u)`
# with the same quadratic library, the derivatives estimated by total-variation regularised
# differentiation. The hyperparameters (threshold, ridge alpha, TV gamma) are tuned on the
# validation block with `sindybench.model_selection.tune`, as the study did.
#
# The benchmark records are read from `SINDYBENCH_DATA` (see `sindybench.datasets`);
# `SINDYBENCH_QUICK=1` shrinks the search budgets to a few seconds.

# %%
# %matplotlib inline
import os

import matplotlib.pyplot as plt
import optuna

from sindybench import STLS, HiddenStateSINDy, SINDy
from sindybench.datasets import load_pick_and_place
from sindybench.differentiation import TotalVariation
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.metrics import fit_index, r2, rmse
from sindybench.model_selection import HoldoutSplit, LogUniform, tune
from sindybench.plotting import plot_coefficients, plot_hidden_states, plot_search_history, plot_simulation

QUICK = os.environ.get("SINDYBENCH_QUICK", "") not in ("", "0")
optuna.logging.set_verbosity(optuna.logging.WARNING)  # the search history below tells it better than a log

data = load_pick_and_place()
train, val, test = data.train, data.validation, data.test
u, y = data.estimation.u, data.estimation.y  # training + validation, the validation block last

# %% [markdown]
# Both models search the same log-uniform space; each trial fits on the training block and is
# scored by the RMSE of an open-loop simulation of the validation block.

# %%
space = {
    "optimizer__threshold": LogUniform(1e-4, 1e2),
    "optimizer__alpha": LogUniform(1e-8, 1e-1),
    "differentiation__gamma": LogUniform(1e-6, 1e1),
}
common = dict(library=PolynomialLibrary(degree=2), optimizer=STLS(), differentiation=TotalVariation(), dt=data.dt)
candidates = {
    "SINDy, 1st order": SINDy(**common),
    "SINDy, 2nd order": HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), input_hold="zoh", refine=None,
                                         **common),  # the study's settings
}
study_r2 = {"SINDy, 1st order": 0.76, "SINDy, 2nd order": 0.94}

models, studies = {}, {}
for label, model in candidates.items():
    best, studies[label] = tune(model, space, u, y, cv=HoldoutSplit(validation_size=len(val.y)),
                                n_trials=6 if QUICK else 60, random_state=0, refit=False)
    models[label] = best.fit(train.u, train.y)  # the validated candidate, fitted on the training block

print(f"Pick-and-place, test record ({len(test.y)} samples, first {data.n_init} initialise the state)")
print(f"{'model':<20}{'RMSE':>8}{'R^2':>8}{'fit %':>8}   study R^2")
for label, model in models.items():
    y_sim = model.predict(test.u, y_init=test.y[: data.n_init])
    print(f"{label:<20}{rmse(test.y, y_sim):>8.3f}{r2(test.y, y_sim):>8.3f}{fit_index(test.y, y_sim):>8.1f}"
          f"   {study_r2[label]:.2f}")

# %% [markdown]
# The search histories: every trial's validation RMSE and the best so far.

# %%
fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
for label, study in studies.items():
    plot_search_history(study, label=label, ax=ax)

# %% [markdown]
# The open-loop simulations of the test record. The first-order model can only relax towards
# an equilibrium; the second-order one follows the head's oscillations.

# %%
plot_simulation(test.u, test.y, models, n_init=data.n_init, dt=data.dt, output_label="position y",
                input_label="voltage u");

# %% [markdown]
# The second-order model, as a notebook shows it: the fixed row `y0' = y0'` and the learned
# acceleration.

# %%
models["SINDy, 2nd order"]

# %% [markdown]
# Its hidden state, the velocity `y0'`, as differentiated from the training data, and the
# coefficients of both models side by side:

# %%
plot_hidden_states(models["SINDy, 2nd order"]);

# %%
plot_coefficients(models);
