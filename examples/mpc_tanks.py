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
# # Cascaded tanks: model predictive control with an identified hidden-state model
#
# The identified model of the cascaded tanks (`HiddenStateSINDy` with `TanksHiddenState`,
# fitted on the benchmark's estimation record) closes a loop: an extended Kalman filter
# estimates the unmeasured upper tank from the measured lower level, and a nonlinear model
# predictive controller, written with CasADi and solved by IPOPT, moves the pump voltage so
# that the lower level follows a set-point. The plant is the known-truth simulator
# `sindybench.systems.CascadedTanks` (a stand-in fitted to the real rig) with measurement
# noise, so the model the controller uses is not the plant.
#
# * `sindybench.estimation.extended_kalman_filter`: the filter over the record so far,
#   propagated with the model's own integrator;
# * `sindybench.export.to_casadi`: the model's sample step (RK4, sub-steps, the tanks'
#   bounds) as a CasADi function, the same numbers as `simulate`;
# * `sindybench.estimation.linearize`: the model's gain at the operating point, a quick check
#   of what the controller sees.
#
# Needs CasADi (`pip install "sindybench[casadi]"`). `SINDYBENCH_QUICK=1` shrinks the
# search budget and the closed-loop horizon.

# %%
# %matplotlib inline
import os
import time

import casadi as ca
import matplotlib.pyplot as plt
import numpy as np

from sindybench import STLS
from sindybench.datasets import load_cascaded_tanks
from sindybench.differentiation import FiniteDifference
from sindybench.estimation import estimate_noise, extended_kalman_filter, linearize, model_step
from sindybench.export import to_casadi
from sindybench.hidden import HiddenStateSINDy, TanksHiddenState
from sindybench.systems import CascadedTanks

QUICK = os.environ.get("SINDYBENCH_QUICK", "") not in ("", "0")
BOUNDS = (0.0, 10.0)

data = load_cascaded_tanks()
model = HiddenStateSINDy(
    hidden=TanksHiddenState(bounds=BOUNDS, k_bounds=(0.02, 0.08), ratio_bounds=(0.3, 3.0), output_bounds=BOUNDS),
    optimizer=STLS(threshold=0.0), dt=data.dt, n_substeps=4, validation_size=len(data.validation.y),
    validation="full", n_trials=30 if QUICK else 100, local_trials=10 if QUICK else 33, random_state=0,
    show_progress_bar=False, differentiation=FiniteDifference(), input_hold="zoh", refine=None,
).fit(data.estimation.u, data.estimation.y)
model

# %% [markdown]
# Process and measurement noise for the filter, from the training record (the diagonal
# covariances that maximise the likelihood of the filter's innovations), and the model
# linearized at its steady state for a pump voltage of 2.5 V:

# %%
m = model_step(model)
Q, R = estimate_noise(model, data.estimation.u, data.estimation.y)
print(f"Q diagonal (y, x1): {np.diag(Q)[0]:.3g}, {np.diag(Q)[1]:.3g} V^2 per sample; R: {R[0, 0]:.3g} V^2")

x_ss = model.simulate(np.full((400, 1), 2.5), x0=m.x0)[-1]
lin = linearize(model, x_ss, [2.5])
gain = (lin.C @ np.linalg.solve(-lin.A, lin.B)).item()
print(f"model's steady state at u = 2.5 V: y = {x_ss[0]:.2f} V, x1 = {x_ss[1]:.2f} V; "
      f"linearized static gain dy/du = {gain:.2f}; discrete poles {np.round(np.linalg.eigvals(lin.Ad), 4)}")

# %% [markdown]
# The controller: a horizon of `H` samples, single shooting with the exported step
# (`x[k+1] = step(x[k], u[k], u[k])`, so the only unknowns are the moves), the pump within
# 0-10 V, and a cost on the level's distance to the set-point plus a small penalty on moves.

# %%
cm = to_casadi(model)
H = 15
opti = ca.Opti()
U = opti.variable(1, H)
x_now, ref, u_last = opti.parameter(m.n_states), opti.parameter(), opti.parameter()
x, levels = x_now, []
for k in range(H):
    x = cm.step(x, U[:, k], U[:, k])
    levels.append(cm.output(x))
opti.subject_to(opti.bounded(0.0, U, 10.0))
moves = ca.diff(ca.hcat([u_last, U]))
opti.minimize(ca.sumsqr(ca.hcat(levels) - ref) + 0.5 * ca.sumsqr(moves))
opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "max_iter": 100})

solves = []


def control(x, r, u_prev, guess):
    opti.set_value(x_now, x)
    opti.set_value(ref, r)
    opti.set_value(u_last, u_prev)
    opti.set_initial(U, guess)
    sol = opti.solve_limited()  # a solve that stops at max_iter still returns its best plan
    solves.append(sol.stats()["return_status"])
    return np.atleast_1d(sol.value(U))


# %% [markdown]
# The loop: measure, filter, solve, apply the first move, let the plant run one sample. The
# model is not the plant and this controller has no integral action, so the level settles
# near the set-point but not on it: what is left is the model's steady-state error at that
# level (an offset-free design would add a disturbance state to the filter and the
# predictions).

# %%
plant = CascadedTanks(noise_std=0.02)
rng = np.random.default_rng(0)
n_steps = 120 if QUICK else 300
reference = np.select([np.arange(n_steps) < n_steps // 3, np.arange(n_steps) < 2 * n_steps // 3], [4.0, 7.0], 5.5)
x_plant = plant.equilibrium(2.5)  # the plant at rest at 2.5 V; the filter starts from the model's rest state
u_hist, y_hist, x_true, x_est, solve_s = [2.5], [], [], [], []
guess = np.full(H, 2.5)
for t in range(n_steps):
    y_hist.append(x_plant[1] + plant.noise_std * rng.standard_normal())
    x_true.append(x_plant)
    # the filter over the record so far (the same as running it sample by sample)
    filtered = extended_kalman_filter(model, np.array(u_hist)[:, None], np.array(y_hist)[:, None], Q=Q, R=R,
                                      x0=x_ss, P0=np.eye(2))
    x_est.append(filtered.states[-1])
    start = time.perf_counter()
    plan = control(x_est[-1], reference[t], u_hist[-1], guess)
    solve_s.append(time.perf_counter() - start)
    guess = np.concatenate([plan[1:], plan[-1:]])
    x_plant = plant.simulate_states(np.full(2, plan[0]), dt=data.dt, x0=x_plant)[1]
    u_hist.append(float(plan[0]))

y_hist, x_true, x_est = np.array(y_hist), np.array(x_true), np.array(x_est)
print(f"closed loop over {n_steps} samples ({n_steps * data.dt:.0f} s): level RMSE to the set-point "
      f"{np.sqrt(np.mean((x_true[:, 1] - reference) ** 2)):.3f} V (set-point changes included); "
      f"IPOPT {1e3 * np.median(solve_s):.0f} ms per solve (median), {solves.count('Solve_Succeeded')} of "
      f"{len(solves)} solves converged")
ends = [n_steps // 3 - 1, 2 * n_steps // 3 - 1, n_steps - 1]
print("level at the end of each set-point:", [f"{x_true[i, 1]:.2f} V (set {reference[i]:.1f})" for i in ends])
print(f"lower tank: filter RMSE {np.sqrt(np.mean((x_est[:, 0] - x_true[:, 1]) ** 2)):.3f} V, "
      f"measurement noise {plant.noise_std:.3f} V")

# %%
t = np.arange(n_steps) * data.dt
fig, ax = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
ax[0].plot(t, reference, "k--", label="set-point")
ax[0].plot(t, y_hist, ".", ms=3, alpha=0.5, label="measured lower level")
ax[0].plot(t, x_est[:, 0], label="filtered lower level")
ax[0].set_ylabel("lower tank [V]")
ax[0].legend(loc="lower right")
ax[1].plot(t, x_true[:, 0], label="plant's upper tank (never measured)")
ax[1].plot(t, x_est[:, 1], label="filtered hidden state")
ax[1].set_ylabel("upper tank [V]")
ax[1].legend(loc="lower right")
ax[2].step(t, u_hist[1:], where="post")
ax[2].set_ylabel("pump u [V]")
ax[2].set_xlabel("time [s]")
fig.tight_layout()
