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
# # Cascaded tanks: naive SINDy against a simulated hidden upper tank
#
# The study's Table 3. The lower tank's level `y` is measured; the upper tank, which feeds it,
# is not. Naive SINDy fits `y' = f(y, u)` and averages over the missing state;
# `TanksHiddenState` simulates the upper tank $\dot x_1 = -k_1 \sqrt{x_1} + k_2 u$ (within its
# bounds: it overflows), fits `y' = f(y, x1, u)` (a quadratic polynomial plus `sqrt(y)`,
# `sqrt(x1)`) and searches `k1, k2` and the initial level by the simulation error over the
# whole estimation record, the candidates being fitted without its validation block. A third
# model adds the upper tank's overflow to the library and is then fitted by simulation error
# (`refine=`). Every model is scored by open-loop simulation of the test record from its first
# `n_init` samples.
#
# The benchmark records are read from `SINDYBENCH_DATA`; `SINDYBENCH_QUICK=1` shrinks the
# search budget.

# %%
# %matplotlib inline
import os

from sklearn.base import clone

from sindybench import STLS, SINDy
from sindybench.baselines import ARX
from sindybench.datasets import load_cascaded_tanks
from sindybench.differentiation import FiniteDifference
from sindybench.hidden import HiddenStateSINDy, TanksHiddenState
from sindybench.libraries import ConcatLibrary, IndicatorLibrary, PolynomialLibrary, SqrtLibrary
from sindybench.metrics import fit_index, r2, rmse
from sindybench.plotting import plot_hidden_states, plot_search_history, plot_simulation
from sindybench.refine import OutputErrorRefinement

QUICK = os.environ.get("SINDYBENCH_QUICK", "") not in ("", "0")
BOUNDS = (0.0, 10.0)  # sensor range (V); the tanks overflow at the top of it

data = load_cascaded_tanks()
train, val, test = data.train, data.validation, data.test
u, y = data.estimation.u, data.estimation.y  # training + validation, the validation block last

# %%
naive = SINDy(library=PolynomialLibrary(degree=2), optimizer=STLS(threshold=1e-3, alpha=1e-6),
              dt=data.dt, bounds=BOUNDS).fit(train.u, train.y)
hidden = HiddenStateSINDy(
    # k1 and the ratio k2/k1 searched on log scales
    hidden=TanksHiddenState(bounds=BOUNDS, k_bounds=(0.02, 0.08), ratio_bounds=(0.3, 3.0), output_bounds=BOUNDS),
    optimizer=STLS(threshold=0.0),  # least squares on the strategy's default library
    dt=data.dt,
    n_substeps=4,
    validation_size=len(val.y),  # candidates are fitted without the validation block ...
    validation="full",  # ... and scored by simulating the whole record from its start
    n_trials=60 if QUICK else 100,
    local_trials=20 if QUICK else 33,  # Nelder-Mead refinement of the best TPE candidates
    random_state=0,
    differentiation=FiniteDifference(), input_hold="zoh", refine=None,  # held input; refined below
).fit(u, y)
# the overflow regime of the upper tank ([x1>=10], [x1>=10] u0: its spill into the lower tank),
# then the coefficients, k1, k2 and both initial levels refined by the simulation error (with a budget of
# 100 simulations a round the refinement converges; the default 30 stops early and says so with a warning)
overflow = ConcatLibrary([PolynomialLibrary(degree=2), SqrtLibrary(variables=[0, 1]),
                          IndicatorLibrary(variables=[1], lower=BOUNDS[1], times=[2])])
refined = clone(hidden).set_params(library=overflow, refine=OutputErrorRefinement(max_nfev=100),
                                   initial_state="fit").fit(u, y)
arx = ARX(na=5, nb=5, nk=1).fit(train.u, train.y)
models = {"SINDy, polynomial": naive, "Hidden SINDy": hidden, "Hidden SINDy, refined": refined, "ARX": arx}

print(f"Cascaded tanks, test record ({len(test.y)} samples, first {data.n_init} initialise the state)")
print(f"{'model':<28}{'RMSE [V]':>10}{'R^2':>8}{'fit %':>8}   study: RMSE, R^2")
study = {"SINDy, polynomial": "1.09, 0.73", "Hidden SINDy": "0.55, 0.93", "ARX": "0.77, 0.87"}
for label, model in models.items():
    y_sim = model.predict(test.u, y_init=test.y[: data.n_init])
    print(f"{label:<28}{rmse(test.y, y_sim):>10.3f}{r2(test.y, y_sim):>8.3f}{fit_index(test.y, y_sim):>8.1f}"
          f"   {study.get(label, '-')}")
print("searched:", {k: round(v, 4) for k, v in hidden.best_params_.items()})

# %% [markdown]
# The hidden-state model: the lower tank's law and the simulated upper tank.

# %%
hidden

# %% [markdown]
# The refined model with its overflow terms, and what the refinement did (costs, simulations,
# the refined `k1`, `k2`):

# %%
refined

# %%
refined.refinement_

# %%
plot_simulation(test.u, test.y, models, n_init=data.n_init, dt=data.dt, output_label="lower tank y [V]",
                input_label="pump u [V]");

# %% [markdown]
# The upper tank the model simulates on the test record (never measured; it overflows at
# 10 V), and the inner search that chose `k1`, `k2` and the initial level:

# %%
plot_hidden_states(hidden, test.u, test.y, n_init=data.n_init);

# %%
plot_search_history(hidden);
