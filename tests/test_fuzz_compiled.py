"""Property-based tests of the index and size arguments that reach the compiled kernels (Hypothesis).

The filter, the smoother, the k-step prediction, the noise estimate, the linearization and
the one-step map index states and inputs inside numba code, which checks no bounds. Every
generated model (output indices, input counts, sample lengths, sub-steps, prior sizes,
inputs of any width) must end in results of the expected shape or a ``ValueError`` naming
the argument: never garbage, an ``IndexError`` or an aborted interpreter.

By default each property runs a fixed, derandomized set of examples; ``pytest --runslow``
runs many more, freshly drawn.
"""

import math

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is missing")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from sindybench.dynamics import POW, step, step_jacobian  # noqa: E402
from sindybench.estimation import (  # noqa: E402
    ModelStep,
    extended_kalman_filter,
    linearize,
    predict_k_step,
    rts_smoother,
    smooth_initial_state,
)
from sindybench.simulate import TermsRHS, simulate  # noqa: E402

QUICK_EXAMPLES, SLOW_EXAMPLES = 40, 800
DT = 0.05
# x0' = x1, x1' = -4 x0 - 0.2 x1 + u (column 2): the model uses one input
RHS = TermsRHS.from_equations([{((1, POW, 1, 0),): 1.0},
                               {((0, POW, 1, 0),): -4.0, ((1, POW, 1, 0),): -0.2, ((2, POW, 1, 0),): 1.0}])
INDEX = st.one_of(st.integers(-3, 4), st.sampled_from([10**6, 2**31, 2**63 - 1, -(2**63)]))
FIELDS = {
    "output_index": st.one_of(st.lists(INDEX, max_size=3).map(tuple), st.sampled_from([None, 0, "0", (0.5,), (True,)])),
    "n_inputs": st.one_of(st.integers(-2, 4), st.sampled_from([10**6, 1.0, None, True])),
    "dt": st.one_of(st.sampled_from([0.0, -1.0, math.nan, math.inf, 1e-300, None, "0.1"]), st.floats(1e-3, 1.0)),
    "n_substeps": st.one_of(st.integers(-1, 3), st.sampled_from([1.5, None])),
    "x0": st.sampled_from([[0.1, 0.0], [0.1], [0.1, 0.0, 0.0], [math.nan, 0.0], [[0.1, 0.0]]]),
}
PATHS = ("filter", "smoother", "k_step", "initial_state", "linearize", "step", "step_jacobian", "simulate")


@st.composite
def cases(draw):
    """A model (a few fields edited, or built from them), a path and the width of the inputs given."""
    kw = {name: draw(FIELDS[name]) for name in draw(st.lists(st.sampled_from(sorted(FIELDS)), max_size=3,
                                                               unique=True))}
    how = draw(st.sampled_from(["from_rhs", "replace"]))
    return kw, how, draw(st.sampled_from(PATHS)), draw(st.integers(0, 3))


def _check_case(kw, how, path, n_u):
    args = dict(dt=DT, n_inputs=1, output_index=(0,))
    args.update(kw)
    u = np.tile(np.sin(np.arange(30) * 0.2)[:, None], (1, n_u))
    y = np.sin(np.arange(30) * 0.2)[:, None] * 0.1
    try:
        if how == "from_rhs":
            m = ModelStep.from_rhs(RHS, **args)
        else:
            m = ModelStep.from_rhs(RHS, DT, n_inputs=1)._replace(**kw)
        n_out = len(m.output_index) if how == "from_rhs" else None
        y = np.tile(y, (1, n_out or 1))
        q = dict(Q=1e-6, R=1e-4)
        if path == "filter":
            out = extended_kalman_filter(m, u, y, **q).states
        elif path == "smoother":
            out = rts_smoother(m, u, y, **q).states
        elif path == "k_step":
            out = predict_k_step(m, u, y, 2, **q)
        elif path == "initial_state":
            out = smooth_initial_state(m, u, y[:8], **q)
        elif path == "linearize":
            out = linearize(m, m.x0, np.zeros(n_u)).A
        else:
            settings_ = dict(n_substeps=m.n_substeps, method=m.method, input_hold=m.input_hold)
            if path == "step":
                out = step(RHS, m.x0, u[0], u[1], m.dt, **settings_)
            elif path == "step_jacobian":
                out = step_jacobian(RHS, m.x0, u[0], u[1], m.dt, **settings_)[1]
            else:
                out = simulate(RHS, m.x0, u, m.dt, **settings_)
    except ValueError as exc:
        assert str(exc), "an empty error message"
        return
    # it ran: then what it was given was valid, and the result is finite and of the right shape
    assert n_u >= 1, f"{path} ran with {n_u} input columns on a model that uses one input"
    out = np.asarray(out)
    assert np.all(np.isfinite(out)), f"{path} returned non-finite values for {kw}"
    if path in ("filter", "smoother", "simulate"):
        assert out.shape == (30, 2)
    elif path == "k_step":
        assert out.shape == (28, len(m.output_index))
    if path not in ("step", "step_jacobian", "simulate"):  # the paths that read the ModelStep's indices
        assert all(0 <= i < 2 for i in m.output_index) and m.dt > 0 and m.n_inputs >= 1, f"{path} ran with {kw}"


def _run(n_examples, derandomize):
    @settings(max_examples=n_examples, derandomize=derandomize, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow])
    @given(case=cases())
    def check(case):
        _check_case(*case)

    check()


def test_compiled_paths_refuse_bad_indices_and_sizes():
    _run(QUICK_EXAMPLES, derandomize=True)


@pytest.mark.slow
def test_compiled_paths_refuse_bad_indices_and_sizes_at_length():
    _run(SLOW_EXAMPLES, derandomize=False)
