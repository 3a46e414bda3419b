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
# # Quickstart: SINDy with control on a forced Duffing oscillator
#
# The true system (position `y0`, velocity `y1`, force `u0`):
#
# $$\dot y_0 = y_1, \qquad \dot y_1 = -y_0 - 0.3\, y_1 - 0.5\, y_0^3 + u_0$$
#
# is simulated on a training and a test input; SINDy learns the equations from the
# training data and is judged by an **open-loop simulation** of the test data.
# This file is a Jupytext notebook: open it in Jupyter (with `pip install jupytext`) or run
# it as a script, `python examples/quickstart.py`.

# %%
# %matplotlib inline
import tempfile
from pathlib import Path

import numpy as np

from sindybench import STLS, SINDy, load_model
from sindybench.libraries import PolynomialLibrary
from sindybench.metrics import fit_index, r2, rmse
from sindybench.plotting import plot_coefficients, plot_simulation
from sindybench.simulate import simulate

DT = 0.01


def multisine(n, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    freqs = rng.uniform(0.05, 1.0, size=6)
    phases = rng.uniform(0.0, 2 * np.pi, size=6)
    return np.sin(2 * np.pi * np.outer(t, freqs) + phases).sum(axis=1, keepdims=True) / 2


def duffing(x, u):
    return np.array([x[1], -x[0] - 0.3 * x[1] - 0.5 * x[0] ** 3 + u[0]])


u_train, u_test = multisine(5000, seed=1), multisine(3000, seed=2)
y_train = simulate(duffing, [0.0, 0.0], u_train, dt=DT, n_substeps=2, input_hold="linear")
y_test = simulate(duffing, [0.5, 0.0], u_test, dt=DT, n_substeps=2, input_hold="linear")

# %% [markdown]
# A cubic polynomial library over `[y0, y1, u0]` and sequentially thresholded least squares.
# `fit(X, y)` takes the **inputs** as `X` and the measured outputs as `y`, as every sindybench
# estimator does. In a notebook, a fitted model shows its equations.

# %%
model = SINDy(
    library=PolynomialLibrary(degree=3),
    optimizer=STLS(threshold=0.05),
    dt=DT,
    input_hold="linear",
    output_names=["y0", "y1"],
    input_names=["u0"],
)
model.fit(u_train, y_train)

# %% [markdown]
# The same equations as text (`model.equations()`), and the open-loop simulation of the test
# input, started from the test data's first sample:

# %%
print("Identified model:")
for line in model.equations():
    print("   ", line)

y_sim = model.predict(u_test, y_init=y_test)
print(f"Test (open-loop simulation of {len(y_test)} samples):")
print(f"    RMSE      = {rmse(y_test, y_sim):.2e}")
print(f"    R^2       = {r2(y_test, y_sim):.6f}")
print(f"    fit index = {fit_index(y_test, y_sim):.2f} %")

# %%
plot_simulation(u_test, y_test, {"SINDy": model}, dt=DT, output_label="position y0", input_label="force u0");

# %% [markdown]
# The coefficients as a heatmap (rows: equations, columns: library terms, blank: dropped):

# %%
plot_coefficients({"SINDy": model});

# %% [markdown]
# A fitted model is saved as plain JSON (coefficients and library) and loads back to the same
# simulation:

# %%
with tempfile.TemporaryDirectory() as folder:
    path = Path(folder) / "duffing.json"
    model.to_json(path)
    same = np.array_equal(load_model(path).predict(u_test, y_init=y_test), y_sim)
print(f"Saved to JSON and loaded back; identical simulation: {same}")
