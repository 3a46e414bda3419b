"""dynamics: every term operation's derivative against central differences, user operations in the sensitivities."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sindybench.dynamics import (
    ABS_POW,
    HINGE,
    LOGISTIC,
    POW,
    SIGN,
    SQRT,
    STEP,
    USER,
    TermsRHS,
    check_terms,
    evaluate_terms,
    evaluate_terms_jacobian,
    register_op,
    simulate,
)
from sindybench.refine import simulate_sensitivity

FACTORS = [(0, POW, 1.0, 0.0), (0, POW, 2.0, 0.0), (0, POW, 3.0, 0.0), (0, POW, 2.5, 0.0), (0, ABS_POW, 1.0, 0.0),
           (0, ABS_POW, 1.5, 0.0), (0, SQRT, 0.1, 2.0), (0, SIGN, 0.0, 0.0), (0, STEP, 0.5, 1.5),
           (0, HINGE, 1.0, 1.0), (0, HINGE, 1.0, -1.0), (0, LOGISTIC, 0.5, 0.3)]


@pytest.mark.parametrize("factor", FACTORS, ids=lambda f: f"op{f[1]}a{f[2]}")
def test_derivative_of_each_operation_matches_central_differences(factor):
    z = np.array([0.3, 0.7, 1.2, 1.9, 2.6])[:, None]  # away from kinks, clip ends and steps
    term = ((factor[0], factor[1], factor[2], factor[3]), (1, POW, 1.0, 0.0))  # times a second column
    Z = np.hstack([z, np.full_like(z, 1.5)])
    eps = 1e-6
    fd = (evaluate_terms([term], Z + [eps, 0.0]) - evaluate_terms([term], Z - [eps, 0.0])) / (2 * eps)
    jac = evaluate_terms_jacobian([term], Z)
    assert_allclose(jac[:, 0, 0], fd[:, 0], rtol=1e-6, atol=1e-8)
    assert_allclose(jac[:, 0, 1], evaluate_terms([(factor,)], Z)[:, 0], rtol=1e-14)  # d/dz1 of f(z0) z1


def test_user_operation_joins_the_sensitivities():
    """A tanh user op: exact-sensitivity Jacobian of the simulation against differences of simulate."""
    op = register_op(lambda v: np.tanh(v / 0.2), name="tanh({}/0.2)")
    assert op >= USER and check_terms([[[0, op, 0, 0]]])[0][0][1] is op
    terms = [((0, POW, 1, 0),), ((0, op, 0.0, 0.0),), ((1, POW, 1, 0),)]
    rhs = TermsRHS([[-0.5], [-1.0], [2.0]], terms, 1)
    u = np.sin(np.linspace(0, 6, 200))[:, None]
    D = np.zeros((1, 3, 1))
    D[0, 1, 0] = 1.0
    x, S, _ = simulate_sensitivity(rhs, [0.2], u, 0.05, directions=D, free_x0=[0])
    assert np.array_equal(x, simulate(rhs, [0.2], u, 0.05))
    eps = 1e-6

    def moved(dc, dx0):
        return simulate(TermsRHS(rhs.coef + dc * D[0], terms, 1), [0.2 + dx0], u, 0.05)[:, 0]

    assert_allclose(S[:, 0, 0], (moved(eps, 0) - moved(-eps, 0)) / (2 * eps), rtol=1e-5, atol=1e-8)
    assert_allclose(S[:, 0, 1], (moved(0, eps) - moved(0, -eps)) / (2 * eps), rtol=1e-5, atol=1e-8)


def test_unknown_operation_codes_are_rejected():
    with pytest.raises(ValueError, match="unknown operation 7"):
        check_terms([[[0, 7, 0, 0]]])
    with pytest.raises(ValueError, match="not a built-in operation .* nor a user operation registered"):
        check_terms([[[0, USER + 999, 0, 0]]])


def test_the_table_holds_every_builtin_operation_once():
    from sindybench.dynamics._optable import OPERATIONS
    from sindybench.dynamics._ops import BUILTIN_OPS

    assert [op.code for op in OPERATIONS] == list(range(len(OPERATIONS))) == list(BUILTIN_OPS)
    assert [op.name for op in OPERATIONS] == ["POW", "ABS_POW", "SQRT", "SIGN", "STEP", "HINGE",
                                                "LOGISTIC"]
    assert len(OPERATIONS) < USER


@pytest.mark.parametrize("factor", FACTORS, ids=lambda f: f"op{f[1]}a{f[2]}")
def test_compiled_dispatch_is_the_table_entry(factor):
    """op_value / op_derivative (written from the table) give each entry's own value and derivative."""
    from sindybench.dynamics._user import operation

    _, code, a, b = factor
    entry = operation(code)
    z = np.array([-1.3, -0.2, 0.0, 0.05, 0.3, 0.7, 1.2, 1.9, 2.6])
    values = evaluate_terms([(factor,)], z[:, None])[:, 0]
    slopes = evaluate_terms_jacobian([(factor,)], z[:, None])[:, 0, 0]
    expect = [entry.value(v, a, b) for v in z]
    assert np.array_equal(values, expect, equal_nan=True)
    assert np.array_equal(slopes, [entry.derivative(v, f, a, b) for v, f in zip(z, expect)], equal_nan=True)


def test_every_operation_has_its_written_forms():
    sympy = pytest.importorskip("sympy")
    from sindybench.dynamics._user import operation

    z = sympy.Symbol("z")
    written = {code: (operation(code).text("z", 0.5, 2.0), operation(code).latex("z", 0.5, 2.0),
                      str(operation(code).sympy(sympy, z, 0.5, 2.0))) for code in (POW, ABS_POW, SQRT, SIGN, STEP)}
    assert written[SQRT] == ("sqrt(z)", r"\sqrt{z}", "sqrt(z)")
    assert written[STEP][0] == "[0.5<=z<=2]" and written[ABS_POW][0] == "|z|^0.5"
    assert (operation(HINGE).text("z", 9.937, 1.0), operation(HINGE).text("z", -0.5, -1.0)) == (
        "max(z-9.937, 0)", "max(-0.5-z, 0)")
    assert str(operation(HINGE).sympy(sympy, z, 0.5, 1.0)) == "Max(0, z - 0.5)"
    assert operation(LOGISTIC).text("z", 9.937, 4.0) == "logistic(4.0*(z-9.937))"
    logistic = operation(LOGISTIC).sympy(sympy, z, 0.5, 4.0)
    assert float(logistic.subs(z, 0.5)) == 0.5 and float(logistic.subs(z, 1.0)) == pytest.approx(1 / (1 + np.exp(-2)))
    op = register_op(np.tanh)
    assert (operation(op).text("v", 0, 0), str(operation(op).sympy(sympy, z, 0, 0))) == ("tanh(v)", "tanh(z)")
    with pytest.raises(ValueError, match="unknown factor operation 7"):
        operation(7)
    with pytest.raises(ValueError, match="nor a user operation registered"):
        operation(USER + 999)


def test_the_logistic_is_the_step_smoothed_and_never_overflows():
    """``LOGISTIC`` tends to ``[z>=a]`` as its slope grows; far from the level it is 0 or 1 without overflow."""
    from sindybench.dynamics._optable import OPERATIONS

    value = OPERATIONS[LOGISTIC].value
    z = np.array([-1e6, 0.3, 0.49, 0.51, 0.7, 1e6])
    with np.errstate(all="raise"):
        smooth = np.array([value(v, 0.5, 1e4) for v in z])
    np.testing.assert_allclose(smooth, [0.0, 0.0, 0.0, 1.0, 1.0, 1.0], atol=1e-12)
    assert value(0.5, 0.5, 10.0) == 0.5 and value(0.6, 0.5, 10.0) == pytest.approx(1 / (1 + np.exp(-1.0)), rel=1e-14)
    assert np.isnan(value(float("nan"), 0.5, 10.0))


def test_no_value_function_of_the_table_divides():
    """A division in ``op_value`` (numba's ZeroDivisionError path) made the free run of every model 5-7x slower.

    ``benchmarks/bench_ops.py --add div`` measures it; the value functions stay free of ``/``.
    """
    import inspect
    import re

    from sindybench.dynamics._optable import OPERATIONS

    for op in OPERATIONS:
        code = "\n".join(line.split("#")[0] for line in inspect.getsource(op.value).splitlines())
        assert not re.search(r"/", code), f"{op.name}'s value divides: {code}"
