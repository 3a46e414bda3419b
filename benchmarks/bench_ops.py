"""What the built-in op table costs the compiled kernels: the same kernels, two tables, one process.

The free-run kernel (``run_state_into``) and the sensitivity kernel
(``run_sensitivity_into``) call the generated dispatch of the term operations
(``op_value``, ``op_derivative``, written from ``dynamics._optable.OPERATIONS``).
An entry added to that table changes the code of every kernel, for every model,
even one that never uses the new operation. This script isolates that change:
it compiles two private copies of ``dynamics/_ops.py`` and ``dynamics/_kernels.py``
(the package's own source, uncached) in this process, one with the reference
table and one with the candidate table, and times both on the same models and
inputs, interleaved (the best of ``--repeat`` calls each, in CPU time of the thread; each model runs the whole record
without diverging, printed), so that the ratio
candidate / reference measures the table alone.

* reference: the built-in table of main before issue 35 (codes 0-5, ``POW`` to
  ``HINGE``), taken from the package's current entries;
* candidate: the package's current ``OPERATIONS``; with ``--add``, the reference
  plus the entries named (``logistic``: branch hinge2's ``LOGISTIC`` entry, code 6,
  as it was written there; ``logistic_call``: the same value computed by a
  separately compiled helper; ``tanh_inverse``: the logistic of ``b`` the inverse
  width, no division; ``div`` and ``exp``: one division, one ``exp``, alone); with
  ``--control``, a second copy of the reference (the noise floor of the ratios).
  ``--error-model numpy`` compiles the candidate's dispatch without numba's
  ``ZeroDivisionError`` path (``--add div --error-model numpy`` shows that path is the cost).

Models (plain ones: none uses an operation beyond ``HINGE``), 20,000 samples of a
random-phase multisine, RK4, zero-order hold:

* ``poly2``: 3 states, the degree-2 polynomial model of ``bench_simulate.py`` (POW);
* ``latent``: a hidden tank feeding a measured one (SQRT, POW): cascaded-tanks-like;
* ``order2+hard``: position, velocity with Coulomb friction and a hinge end stop
  (POW, SIGN, STEP, HINGE): EMPS-like.

Usage::

    nice -n 10 python benchmarks/bench_ops.py [--repeat 7] [--samples 20000] [--add logistic]

Prints, per model and kernel, the reference and candidate times (ms) and their
ratio; a ratio of 1.00 +- 0.05 means the candidate table costs these models nothing.

Measured (2 cores loaded by other jobs; ratios poly2 / latent / order2+hard, free run then
sensitivity): ``--control`` 1.01 / 0.99 / 0.99 and 1.00 / 0.99 / 0.99; the package's table
(``LOGISTIC`` of slope ``b``, no division) 0.92 / 1.03 / 1.00 and 1.00 / 1.01 / 1.03;
``--add logistic`` (hinge2's entry) 4.97 / 7.52 / 6.38 and 1.05 / 1.00 / 1.06; ``--add div``
4.80 / 7.34 / 6.04 and 0.99 / 1.05 / 1.01; ``--add div --error-model numpy`` 0.99 / 1.04 / 0.99
and 0.99 / 1.01 / 1.02. The cause is numba's ``ZeroDivisionError`` path of a division in
``op_value``, not the ``exp`` nor the length of the chain (see ``dynamics/_optable.py``).
"""

import argparse
import inspect
import math
import sys
import time
import types

import numpy as np

from sindybench.dynamics import TermsRHS, sensitivity_arrays, simulation_settings
from sindybench.dynamics import _kernels, _ops, _optable
from sindybench.dynamics._optable import OPERATIONS, Operation
from sindybench.libraries import HINGE, POW, SIGN, SQRT, STEP


# ------------------------------------------------------------ extra table entries (hinge2's LOGISTIC and a variant)
# branch hinge2's entry, as written there
def _logistic_value(v, a, b):
    x = (v - a) / b
    if x >= 0.0:
        return 1.0 / (1.0 + math.exp(-x))
    e = math.exp(x)  # x < 0 (or NaN: NaN stays NaN)
    return e / (1.0 + e)


def _logistic_derivative(v, value, a, b):
    return value * (1.0 - value) / b


# the value from a helper compiled on its own
def _logistic_call_value(v, a, b):
    return bench_logistic(v, a, b)


# diagnostics: one division alone
def _div_value(v, a, b):
    return (v - a) / b


# diagnostics: one exp alone
def _exp_value(v, a, b):
    return math.exp(v - a)


# the logistic with b the inverse width: no division
def _tanh_inverse_value(v, a, b):
    return 0.5 + 0.5 * math.tanh(0.5 * (v - a) * b)


def _tanh_inverse_derivative(v, value, a, b):
    return value * (1.0 - value) * b


def _entry(name, value, derivative):
    return Operation(len(OPERATIONS), name, value, derivative, text=None, latex=None, sympy=None, casadi=None)


EXTRA = {
    "logistic": lambda: _entry("LOGISTIC", _logistic_value, _logistic_derivative),
    "logistic_call": lambda: _entry("LOGISTIC", _logistic_call_value, _logistic_derivative),
    "div": lambda: _entry("DIV", _div_value, _logistic_derivative),
    "exp": lambda: _entry("EXP", _exp_value, _tanh_inverse_derivative),
    "tanh_inverse": lambda: _entry("LOGISTIC", _tanh_inverse_value, _tanh_inverse_derivative),
}


def _helpers():
    """Names the extra entries' bodies use, placed where the generated dispatch looks them up (``_optable``)."""
    from numba import njit

    _optable.math = math
    _optable.bench_logistic = njit(inline="never")(_logistic_value)


# ------------------------------------------------------------ private kernel copies
_COPIES = []


def kernels_with(operations, tag, error_model="python"):
    """``(run_state_into, run_sensitivity_into)`` compiled from the package's source with ``operations`` as the table.

    ``error_model``: numba's, for the generated dispatch (``"numpy"``: a division by zero gives inf, no exception path).
    """
    ops_name, kernels_name = f"_bench_ops_{tag}", f"_bench_kernels_{tag}"
    ops_source = inspect.getsource(_ops).replace("cache=True", "cache=False")
    if error_model != "python":
        assert "return njit(function)" in ops_source
        ops_source = ops_source.replace("return njit(function)", f"return njit(function, error_model={error_model!r})")
    ops_mod = types.ModuleType(f"sindybench.dynamics.{ops_name}")
    ops_mod.__package__ = "sindybench.dynamics"
    saved = _optable.OPERATIONS
    _optable.OPERATIONS = tuple(operations)  # read by the copy's `from ._optable import OPERATIONS`
    try:
        exec(compile(ops_source, f"<{ops_name}>", "exec"), ops_mod.__dict__)  # noqa: S102 - the package's own source
    finally:
        _optable.OPERATIONS = saved
    sys.modules[ops_mod.__name__] = ops_mod
    kernels_source = (inspect.getsource(_kernels).replace("cache=True", "cache=False")
                      .replace("from ._ops import", f"from .{ops_name} import"))
    kernels_mod = types.ModuleType(f"sindybench.dynamics.{kernels_name}")
    kernels_mod.__package__ = "sindybench.dynamics"
    exec(compile(kernels_source, f"<{kernels_name}>", "exec"), kernels_mod.__dict__)  # noqa: S102
    _COPIES.append((ops_mod, kernels_mod))
    return kernels_mod.run_state_into, kernels_mod.run_sensitivity_into


# ------------------------------------------------------------ models
def _f(col, op=POW, a=1.0, b=0.0):
    return (col, op, float(a), float(b))


def models():
    """``name -> (TermsRHS, x0, input scale)`` of three plain models."""
    x0, x1, x2 = _f(0), _f(1), _f(2)
    poly = TermsRHS.from_equations([
        {(x1,): 1.0},
        {(_f(3),): 1.0, (x0,): -1.0, (x1,): -0.2, (x2,): -1.0, (_f(0, POW, 2.0),): -0.1},
        {(x1,): 0.5, (x2,): -0.3, (x1, x2): -0.2},
    ])
    latent = TermsRHS.from_equations([  # y measured, z the hidden upper tank, u the pump
        {(_f(0, SQRT, 0.0, np.inf),): -0.4, (_f(1, SQRT, 0.0, np.inf),): 0.4},
        {(_f(1, SQRT, 0.0, np.inf),): -0.4, (_f(2),): 0.5, (_f(2), _f(1, STEP, 8.0, np.inf)): -0.2},
    ])
    hard = TermsRHS.from_equations([  # position, velocity: Coulomb friction, viscous, an end stop (hinge)
        {(x1,): 1.0},
        {(_f(2),): 2.0, (x1,): -0.5, (_f(1, SIGN),): -0.3, (_f(0, HINGE, 0.8, 1.0),): -20.0,
         (_f(0, HINGE, -0.8, -1.0),): 20.0, (_f(1, STEP, 0.0, np.inf), _f(2)): 0.1},
    ])
    return {"poly2": (poly, np.zeros(3), 1.0), "latent": (latent, np.array([1.0, 1.0]), 4.0),
            "order2+hard": (hard, np.zeros(2), 1.0)}


def multisine(n, dt, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    f = np.linspace(0.05, 2.0, 20)
    return np.sum(np.sin(2 * np.pi * f[:, None] * t + rng.uniform(0, 2 * np.pi, (20, 1))), axis=0)[:, None] / 5


def arguments(rhs, x0, u, dt):
    """The argument tuples of ``run_state_into`` and ``run_sensitivity_into`` (every coefficient a parameter)."""
    st, u, x0 = simulation_settings(rhs.n_states, u, x0, dt)
    h, n_sub, offsets, weights, linear, lo, hi, max_abs = st[:8]
    n, n_in = rhs.n_states, u.shape[1]
    rows, cols = np.nonzero(rhs.coef)
    directions = np.zeros((rows.size, *rhs.coef.shape))
    directions[np.arange(rows.size), rows, cols] = 1.0
    terms, coef, par = sensitivity_arrays(rhs, directions)
    q = rows.size
    k = offsets.shape[0]

    def zeros(*shape):  # written once: no page faults inside the timed call
        out = np.empty(shape)
        out.fill(0.0)
        return out

    def state():
        return (x0.copy(), u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, rhs._arrays, rhs.user,
                zeros(n + n_in), zeros(rhs._arrays[0].shape[0] - 1), zeros(k, n), zeros(u.shape[0], n))

    def sensitivity():
        work = (zeros(n, q), zeros(coef.shape[0]), zeros(terms[1].shape[0]), zeros(terms[1].shape[0]),
                zeros(n, n), zeros(k, n), zeros(k, n, q))
        return (x0.copy(), zeros(n, q), u, h, n_sub, offsets, weights, linear, lo, hi, max_abs, terms, coef,
                par, rhs.user, np.arange(n, dtype=np.int64), zeros(n + n_in), work,
                zeros(u.shape[0], n), zeros(u.shape[0], n, q), zeros(n, q))

    return state, sensitivity


def timed(kernel, make_args):
    """``(seconds, output, step)`` of one call: the simulated states and the kernel's divergence step (-1: none)."""
    args = make_args()
    start = time.thread_time()  # CPU time of this thread: the time slices other jobs take are not counted
    step = kernel(*args)
    return time.thread_time() - start, args[-1] if kernel.__name__ == "run_state_into" else args[-3], step


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--samples", type=int, default=20_000)
    parser.add_argument("--add", nargs="*", default=[], choices=sorted(EXTRA),
                        help="entries appended to the candidate table")
    parser.add_argument("--control", action="store_true",
                        help="the candidate is a second copy of the reference table (the ratios' noise floor)")
    parser.add_argument("--error-model", default="python", choices=("python", "numpy"),
                        help="numba's error model of the candidate's dispatch (the reference keeps the package's)")
    args = parser.parse_args()
    _helpers()
    reference = [op for op in OPERATIONS if op.code <= HINGE]
    if args.control:  # the noise floor: two copies of the same table
        candidate = list(reference)
    elif args.add:  # main's table plus the named entries
        candidate = reference + [EXTRA[name]()._replace(code=len(reference) + i) for i, name in enumerate(args.add)]
    else:
        candidate = list(OPERATIONS)
    print(f"reference table: {[op.name for op in reference]}")
    print(f"candidate table: {[op.name for op in candidate]} (dispatch error model: {args.error_model})")
    start = time.process_time()
    ref = kernels_with(reference, "ref")
    new = kernels_with(candidate, "new", args.error_model)
    dt = 0.05
    u = multisine(args.samples, dt)
    rows = []
    for name, (rhs, x0, scale) in models().items():
        state, sensitivity = arguments(rhs, x0, scale * u + (scale if name == "latent" else 0.0), dt)
        for kind, make, which in (("free run", state, 0), ("sensitivity", sensitivity, 1)):
            ref[which](*make())  # compile both before timing
            new[which](*make())
            times, outputs, steps = ([], []), [None, None], [None, None]
            for r in range(args.repeat):  # interleaved, in turn first: the machine's load hits both alike
                for i in (0, 1) if r % 2 else (1, 0):
                    t, outputs[i], steps[i] = timed((ref, new)[i][which], make)
                    times[i].append(t)
            same = np.array_equal(*outputs, equal_nan=True) and steps[0] == steps[1]
            rows.append((name, kind, min(times[0]), min(times[1]), same, steps[0] == -1))
    print(f"(compilation and runs: {time.process_time() - start:.1f} s CPU; {args.samples} samples, "
          f"best of {args.repeat})")
    print(f"{'model':<12} {'kernel':<12} {'reference ms':>13} {'candidate ms':>13} {'ratio':>6}  same output  "
          "whole record")
    for name, kind, a, b, same, whole in rows:
        print(f"{name:<12} {kind:<12} {1e3 * a:13.2f} {1e3 * b:13.2f} {b / a:6.2f}  {str(same):<11}  {whole}")


if __name__ == "__main__":
    main()
