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
# # The scikit-learn / Optuna workflow: a Pipeline ending in HiddenStateSINDy, tuned three ways
#
# sindybench estimators take the **inputs** as `X` and the measured **outputs** as `y`, and
# `predict(X, y_init=...)` returns an open-loop simulation started from the first samples of
# `y`. So they sit at the end of a scikit-learn `Pipeline` (whose earlier steps transform the
# inputs), and the pipeline is tuned by any search scored with `make_simulation_scorer` on a
# `HoldoutSplit` (the study's validation block at the end of the record):
#
# 1. `GridSearchCV` over a small grid,
# 2. `optuna_integration.OptunaSearchCV` with Optuna distributions,
# 3. `sindybench.model_selection.tune` (seeded TPE, resumable with `storage=`).
#
# Data: the pick-and-place machine (second-order model), read from `SINDYBENCH_DATA`;
# `SINDYBENCH_QUICK=1` shrinks the budgets.

# %%
# %matplotlib inline
import os
import warnings

import optuna
from sklearn.model_selection import GridSearchCV
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from sindybench import STLS, HiddenStateSINDy
from sindybench.datasets import load_pick_and_place
from sindybench.differentiation import TotalVariation
from sindybench.hidden import DerivativeHiddenState
from sindybench.libraries import PolynomialLibrary
from sindybench.metrics import make_simulation_scorer, r2
from sindybench.model_selection import HoldoutSplit, LogUniform, tune
from sindybench.plotting import plot_search_history, plot_simulation

QUICK = os.environ.get("SINDYBENCH_QUICK", "") not in ("", "0")
optuna.logging.set_verbosity(optuna.logging.WARNING)

data = load_pick_and_place()
u, y = data.estimation.u, data.estimation.y  # training + validation, the validation block last
cv = HoldoutSplit(validation_size=len(data.validation.y))  # fit on the first block, validate on the last
scoring = make_simulation_scorer("rmse")  # open-loop simulation error (negated: greater is better)
test = data.test
best = {}


def report(name, estimator):
    y_sim = estimator.predict(test.u, y_init=test.y[: data.n_init])  # predict params reach the last step
    print(f"{name:<16} test R^2 = {r2(test.y, y_sim):.3f}   (study, 2nd order: 0.94)")
    best[name] = estimator


pipe = Pipeline([
    ("inputs", StandardScaler()),  # transforms X, the inputs; y (the measured output) passes through
    ("sindy", HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=PolynomialLibrary(degree=2),
                               optimizer=STLS(threshold=0.1), differentiation=TotalVariation(gamma=1e-4),
                               dt=data.dt, input_hold="zoh", refine=None)),
])
pipe

# %% [markdown]
# ## 1. GridSearchCV

# %%
grid = {"sindy__optimizer__threshold": [0.03, 0.1, 0.3], "sindy__differentiation__gamma": [1e-5, 1e-4]}
if QUICK:
    grid = {"sindy__optimizer__threshold": [0.1, 0.3], "sindy__differentiation__gamma": [1e-5]}
search = GridSearchCV(pipe, grid, scoring=scoring, cv=cv).fit(u, y)
print("GridSearchCV    best:", search.best_params_)
report("GridSearchCV", search.best_estimator_)

# %% [markdown]
# ## 2. OptunaSearchCV (optuna-integration)

# %%
try:
    from optuna_integration import OptunaSearchCV
except ImportError:
    print("OptunaSearchCV  skipped: pip install optuna-integration")
else:
    # with one validation split, OptunaSearchCV's terminator callback has no spread to report
    warnings.filterwarnings("ignore", message="Failed to report cross validation scores")
    warnings.filterwarnings("ignore", category=FutureWarning, module="optuna")
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    distributions = {
        "sindy__optimizer__threshold": optuna.distributions.FloatDistribution(1e-3, 10.0, log=True),
        "sindy__differentiation__gamma": optuna.distributions.FloatDistribution(1e-6, 1e-2, log=True),
    }
    search = OptunaSearchCV(pipe, distributions, cv=cv, scoring=scoring, n_trials=4 if QUICK else 30,
                            random_state=0, verbose=0).fit(u, y)
    print("OptunaSearchCV  best:", {k: round(v, 6) for k, v in search.best_params_.items()})
    report("OptunaSearchCV", search.best_estimator_)

# %% [markdown]
# ## 3. `sindybench.model_selection.tune`
#
# The study's log-uniform spaces; add `storage="sqlite:///pp.db"` to make the search resumable
# and shareable between processes (see the scaling guide). In a notebook or a terminal it shows
# a progress bar (`show_progress_bar=False` or `SINDYBENCH_PROGRESS=0` turn it off).

# %%
space = {
    "sindy__optimizer__threshold": LogUniform(1e-3, 10.0),
    "sindy__optimizer__alpha": LogUniform(1e-8, 1e-1),
    "sindy__differentiation__gamma": LogUniform(1e-6, 1e-2),
}
estimator, study = tune(pipe, space, u, y, cv=cv, scoring="rmse", n_trials=4 if QUICK else 40, random_state=0)
print(f"tune            best: {study.best_value:.4f} validation RMSE after {len(study.trials)} trials")
report("tune", estimator)

# %%
plot_search_history(study);

# %% [markdown]
# The three winners on the test record:

# %%
plot_simulation(test.u, test.y, best, n_init=data.n_init, dt=data.dt, output_label="position y",
                input_label="voltage u");
