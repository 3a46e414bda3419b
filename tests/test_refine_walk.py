"""The refinement's walk from HiddenStateSINDy: hidden/ hands over its physical map once, then is not called back."""

import sys

import numpy as np
import pytest

import sindybench.refine._core as core
from sindybench import STLS, HiddenStateSINDy
from sindybench.differentiation import FiniteDifference
from sindybench.hidden import BoucWenHiddenState, ParametricHiddenState
from sindybench.libraries import POW, PolynomialLibrary
from sindybench.refine import OutputErrorRefinement
from sindybench.simulate import TermsRHS, simulate

DT = 0.05
OLD = {"differentiation": FiniteDifference(), "input_hold": "zoh"}  # the settings these fits were written with
pytestmark = pytest.mark.filterwarnings("ignore:the refinement stopped on its evaluation budget")


def _record(n=600):
    """A damped oscillator with a cubic spring (one displacement output)."""
    rng = np.random.default_rng(0)
    t = np.arange(n) * DT
    u = (np.sin(0.9 * t + 0.3) + 0.6 * np.sin(2.3 * t) + 0.3 * rng.standard_normal(n).cumsum() / 30)[:, None]
    terms = [((1, POW, 1, 0),), ((0, POW, 1, 0),), ((2, POW, 1, 0),), ((0, POW, 3, 0),)]
    coef = np.array([[1.0, -0.5], [0.0, -4.0], [0.0, 2.0], [0.0, -1.0]])
    y = simulate(TermsRHS(coef, terms, 2), [0.3, -0.2], u, DT)[:, :1]
    return u, y + 1e-2 * rng.standard_normal(y.shape)


class _Undeclared(BoucWenHiddenState):
    """Bouc-Wen without its declared map: the refinement must call ``structure`` back."""

    def physical_map(self, params, *, n_outputs, n_inputs):
        return None


def _modules_per_evaluation(monkeypatch, model, u, y):
    """Fit ``model``; the sindybench modules entered inside the optimizer's residual and Jacobian calls."""
    entered, n_calls, real = set(), [0], core.least_squares

    def profile(frame, event, arg):
        if event == "call":
            entered.add(frame.f_globals.get("__name__", ""))

    def watched(f):
        def call(p):
            n_calls[0] += 1
            sys.setprofile(profile)
            try:
                return f(p)
            finally:
                sys.setprofile(None)
        return call

    def spy(fun, x0, *, jac, **kwargs):
        return real(watched(fun), x0, jac=watched(jac) if callable(jac) else jac, **kwargs)

    monkeypatch.setattr(core, "least_squares", spy)
    model.fit(u, y)
    assert model.refinement_["status"] >= 0 and n_calls[0] > 2
    return {m for m in entered if m.startswith("sindybench")}


@pytest.mark.parametrize("hidden, path, n", [
    (BoucWenHiddenState(m=1.0, c=0.5, k=4.0), "sensitivity", 600),  # compiled: m, c, k through the declared map
    (ParametricHiddenState(lambda xh, y, u, *, a: -a * xh + y, params={"a": 0.8}, x0_bounds=(0.2, 0.6)),
     "2-point", 300),  # Python path: a through the fixed rows' with_params (a short record: Python steps)
])
def test_no_hidden_module_is_entered_per_evaluation(monkeypatch, hidden, path, n):
    u, y = _record()
    u, y = u[:n], y[:n]
    model = HiddenStateSINDy(hidden=hidden, library=PolynomialLibrary(degree=2), optimizer=STLS(threshold=0.05),
                             dt=DT, n_trials=1, random_state=0, refine=OutputErrorRefinement(max_nfev=3), **OLD)
    modules = _modules_per_evaluation(monkeypatch, model, u, y)
    assert model.refinement_["jacobian"] == path and list(model.refinement_["physical"]) in (["m", "c", "k"], ["a"])
    assert "sindybench.refine._parametrized" in modules  # the view builds every evaluation's model
    assert not [m for m in modules if m.startswith("sindybench.hidden")], sorted(modules)


def test_a_strategy_without_a_declared_map_is_called_back(monkeypatch):
    """The measurement sees the climb back into hidden/ where a strategy gives no map (so it can fail)."""
    u, y = _record()
    model = HiddenStateSINDy(hidden=_Undeclared(m=1.0, c=0.5, k=4.0), library=PolynomialLibrary(degree=2),
                             optimizer=STLS(threshold=0.05), dt=DT, refine=OutputErrorRefinement(max_nfev=4), **OLD)
    modules = _modules_per_evaluation(monkeypatch, model, u, y)
    assert {"sindybench.hidden._refinement", "sindybench.hidden._bouc_wen"} <= modules


def test_the_declared_map_is_the_structure_bit_for_bit():
    """BoucWen's fixed rows are its map's matrix: the refinement's start is the estimator's model exactly."""
    s = BoucWenHiddenState()
    rng = np.random.default_rng(1)
    for m, c, k in rng.uniform(0.1, 10.0, size=(5, 3)):
        params = {"m": m, "c": c, "k": k}
        fixed = s.structure(params, n_outputs=1, n_inputs=1).fixed_coef
        block = s.physical_map(params, n_outputs=1, n_inputs=1).placed(("m", "c", "k"), 2)([m, c, k])
        np.testing.assert_array_equal(block[2:], fixed)
        np.testing.assert_array_equal(fixed[:, 1], [-c / m, -k / m, -1.0 / m, 1.0 / m])
