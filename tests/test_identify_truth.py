"""``identify`` on simulated systems of known truth: the true support, and a test fit near the best hand-built model.

Four kinds of system, each simulated here with low measurement noise (0.1 % of the output's
standard deviation) and a random-phase multisine input: a hidden actuator (a first-order lag
drives a spring-mass-damper; only the position is measured: third order in derivative
coordinates), a mass with viscous and Coulomb friction on a spring, a first-order level whose
inflow valve shuts above a level (the output slides along that level: a saturation), and a
Duffing oscillator (cubic stiffness, as Silverbox).

For each, ``identify`` (seeded) must choose the truth's family and return exactly the truth's
terms in that family's coordinates, and its fit index on a fresh test record, started from the
same first samples, must be within 1 point of the best hand-built model of the same family:
the identified model with its library replaced by the true terms and refined by simulation
error to convergence. The default tests search the derivative-coordinate families (a few seconds
each); the slow ones run ``identify`` with every default.
"""

import re

import numpy as np
import pytest
from sklearn.base import clone

from sindybench.dynamics import POW, SIGN, STEP
from sindybench.identify import identify
from sindybench.libraries import TermsLibrary
from sindybench.optimizers import STLS
from sindybench.refine import OutputErrorRefinement
from sindybench.simulate import simulate

DT = 0.01
N_INIT = 20
NOISE = 1e-3  # measurement noise, relative to the output's standard deviation
LEVEL = 1.5  # the saturation level


def _actuator(x, u):  # position, velocity, the hidden actuator's force (a lag of the input)
    return np.array([x[1], -4.0 * x[0] - 0.8 * x[1] + 3.0 * x[2], -5.0 * x[2] + 5.0 * u[0]])


def _friction(x, u):  # a mass on a spring with viscous and Coulomb friction
    return np.array([x[1], -2.0 * x[0] - 0.5 * x[1] - 0.6 * np.sign(x[1]) + 2.0 * u[0]])


def _saturation(x, u):  # a level whose inflow valve shuts and a drain opens at LEVEL: it slides along LEVEL
    on = float(x[0] >= LEVEL)
    return np.array([-1.0 * x[0] + 1.5 * u[0] - 1.5 * on * u[0] + 0.75 * on])


def _duffing(x, u):  # a softly damped oscillator with cubic stiffness
    return np.array([x[1], -4.0 * x[0] - 0.3 * x[1] - 2.0 * x[0] ** 3 + 2.0 * u[0]])


def _y(i, power=1):
    return (i, POW, power, 0)


# name -> (right-hand side, states, multisine (lowest, highest frequency in Hz, std, mean), family, true terms:
# {name: (factors, coefficient)} over Z = [y, y', ..., u] in the family's coordinates)
SYSTEMS = {
    "actuator": (_actuator, 3, (0.05, 1.5, 1.0, 0.0), "order3", {
        # y''' = -4 y' - 0.8 y'' + 3 f' and f = (y'' + 4 y + 0.8 y') / 3, f' = -5 f + 5 u
        "y0": ((_y(0),), -20.0), "y0'": ((_y(1),), -8.0), "y0''": ((_y(2),), -5.8), "u0": ((_y(3),), 15.0)}),
    "friction": (_friction, 2, (0.05, 1.0, 1.5, 0.0), "order2", {
        "y0": ((_y(0),), -2.0), "y0'": ((_y(1),), -0.5), "sign(y0')": (((1, SIGN, 0, 0),), -0.6),
        "u0": ((_y(2),), 2.0)}),
    "saturation": (_saturation, 1, (0.02, 0.5, 1.0, 0.4), "first_order", {
        "y0": ((_y(0),), -1.0), "u0": ((_y(1),), 1.5), "[y0>=L]": (((0, STEP, LEVEL, np.inf),), 0.75),
        "[y0>=L] u0": (((0, STEP, LEVEL, np.inf), _y(1)), -1.5)}),
    "duffing": (_duffing, 2, (0.05, 1.0, 1.5, 0.0), "order2", {
        "y0": ((_y(0),), -4.0), "y0'": ((_y(1),), -0.3), "y0^3": ((_y(0, 3),), -2.0), "u0": ((_y(2),), 2.0)}),
}


def record(name, n, seed):
    """A record of ``n`` samples of system ``name``: a random-phase multisine input, noisy output."""
    rhs, n_states, (f_lo, f_hi, std, mean), _, _ = SYSTEMS[name]
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    freqs = np.linspace(f_lo, f_hi, 12)
    wave = sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(freqs, rng.uniform(0, 2 * np.pi, freqs.size)))
    u = (mean + std * wave / np.std(wave))[:, None]
    x = simulate(rhs, np.zeros(n_states), u, dt=DT, n_substeps=4, input_hold="linear")
    y = x[:, :1] + NOISE * np.std(x[:, 0]) * rng.standard_normal((n, 1))
    return u, y


def fit_index(y, y_hat):
    """``100 (1 - ||y - y_hat|| / ||y - mean y||)``."""
    return float(100.0 * (1.0 - np.linalg.norm(y - y_hat) / np.linalg.norm(y - np.mean(y, axis=0))))


def fit_on_test(model, u, y):
    """Fit index of the model's open-loop simulation of a test record, started from its first ``N_INIT`` samples."""
    y_hat = model.predict(u, y_init=y[:N_INIT])
    return fit_index(y[N_INIT:], np.asarray(y_hat).reshape(y.shape)[N_INIT:])


def support(model):
    """The learned row's terms, a saturation level written ``L``: ``{name: coefficient}``."""
    names = model.library_.get_feature_names_out(list(model.state_names_) + ["u0"])
    row = np.asarray(model.coef_)[-1]
    return {re.sub(r"\[y0>=[-+0-9.e]+\]", "[y0>=L]", str(n)): float(c) for n, c in zip(names, row) if c != 0}


def hand_built(model, name, u, y):
    """The identified model of the truth's family with the true terms only, refined to convergence on ``(u, y)``."""
    truth = SYSTEMS[name][4]
    est = clone(model).set_params(library=TermsLibrary(terms=[factors for factors, _ in truth.values()]),
                                  optimizer=STLS(threshold=0.0), input_hold="linear", input_delay=0,
                                  refine=OutputErrorRefinement(max_nfev=200))
    if "initial_state" in est.get_params():
        est.set_params(initial_state="fit")
    return est.fit(u, y)


# the derivative-coordinate families (the latent ones are searched by the slow tests)
QUICK = dict(families=["first_order", "order2", "order3"])


def _check(name, **kwargs):
    u, y = record(name, 3000, seed=0)
    u_test, y_test = record(name, 2000, seed=1)
    model = identify(u, y, dt=DT, random_state=0, show_progress_bar=False, **kwargs)
    family, truth = SYSTEMS[name][3], SYSTEMS[name][4]
    assert model.identification_["settings"]["family"] == family
    chosen = support(model)
    assert set(chosen) == set(truth)
    # the coefficients too, but for the saturation's regime terms: any pair that turns the flow back at the level
    # makes the output slide along it (the data pins the sliding, not the pair)
    for term, (_, value) in truth.items():
        if "[y0>=L]" not in term:
            assert chosen[term] == pytest.approx(value, rel=0.03), term
    reference = hand_built(model, name, u, y)
    assert set(support(reference)) == set(truth)
    fit, best = fit_on_test(model, u_test, y_test), fit_on_test(reference, u_test, y_test)
    assert best > 99.0  # the hand-built model of the truth's family is near perfect at this noise
    assert fit >= best - 1.0


@pytest.mark.parametrize("name", list(SYSTEMS))
def test_true_support_and_test_fit(name):
    _check(name, **QUICK)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SYSTEMS))
def test_true_support_and_test_fit_with_every_default(name):
    _check(name)
